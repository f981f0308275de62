"""The run-until-stopped loop every node of the suite shares, with its start-up checks.

`run_node` checks what rcl would otherwise turn into a traceback before it initialises
rclpy: ROS_DOMAIN_ID, and each `--params-file`, read by the suite's one params-file reader
(`params_file.parse_params_file`, as `uav-insar solve --params` reads it). Every problem is one
line on stderr, exit code 2 (EXIT_BAD_INPUT), nothing published.
"""
from __future__ import annotations

import faulthandler
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import rclpy
import rclpy.logging
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, STACK_DUMP_SIGNAL
from uav_insar_planner.params_file import params_file_problems

# Fast DDS derives its ports from the domain id; above 232 they pass 65535 and the process
# aborts inside the middleware.
DOMAIN_ID_MAX = 232


def params_files(args: Sequence[str]) -> Iterator[str]:
    """The paths given with --params-file inside the --ros-args ... [--] spans of `args`."""
    in_ros, expect_file = False, False
    for arg in args:
        if expect_file:
            expect_file = False
            yield arg
        elif arg == "--ros-args":
            in_ros = True
        elif arg == "--":
            in_ros = False
        elif in_ros and arg == "--params-file":
            expect_file = True


def startup_problems(args: Sequence[str], own_name: str) -> list[str]:
    """What would stop rcl from starting, each as one line: domain id and params files."""
    problems = []
    domain = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if domain and not (domain.isdigit() and int(domain) <= DOMAIN_ID_MAX):
        problems.append(f"ROS_DOMAIN_ID: value {domain[:20]!r} is not allowed; expected an "
                        f"integer 0..{DOMAIN_ID_MAX}")
    for path in params_files(args):
        problems += params_file_problems(path, own_name)
    return problems


def _report(name: str, lines: Sequence[str]) -> None:
    for line in lines:
        print(f"[ERROR] [{name}]: {line}", file=sys.stderr, flush=True)


def _terminate(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt  # SIGTERM stops a node the way Ctrl-C does


SHUTDOWN_GRACE_S = 0.5


def _raise_unless_shut_down(context: Any) -> None:
    """Re-raise the exception being handled unless a stop signal shut `context` down.

    rclpy's SIGINT/SIGTERM handler shuts the context down under whatever the node is doing:
    the executor can then fail to take a message that was ready (a RuntimeError from
    take_message, seen about once in 10 two-planner stops), and a node still being built fails
    to create its next publisher (RCLError "context is invalid", seen once in CI when the
    signal came between the node's appearance on the graph and the end of its constructor).
    That is Ctrl-C, not a bug. A failure while the context is still up is a bug, and
    propagates (exit 1 with its traceback)."""
    # The handler may still be shutting the context down: give it a moment to show.
    end = time.monotonic() + SHUTDOWN_GRACE_S
    while rclpy.ok(context=context) and time.monotonic() < end:
        time.sleep(0.02)
    if rclpy.ok(context=context):
        raise


def _ignore_stop_signals() -> None:
    """From here on Ctrl-C / SIGTERM are ignored, so that clean-up is not cut short.

    rclpy passes the signal that shut the context down on to Python's handler, whose
    KeyboardInterrupt arrives at the interpreter's next check, which may be inside this very
    call: it is the signal already being handled, so it is swallowed and the call repeated."""
    while True:
        try:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            return
        except KeyboardInterrupt:
            continue


# The last of a stop, destroying the node and shutting rcl and the middleware down, once took
# longer than SIGINT's and SIGTERM's five seconds each (agents and once a planner, a few times
# in thousands of stops under load). Past TEARDOWN_MAX_S every thread's stack is printed (by
# faulthandler's own thread, which needs no GIL) and, TEARDOWN_EXIT_S later, the process ends
# with the node's code: its work is done, and a Ctrl-C must end it. Where it was seen, the
# hang was inside rclpy's destroy_node (Node.destroy_when_not_in_use: the rosout publisher, the
# node and the DDS participant), which holds the GIL: then only the stacks come out, and the
# caller's SIGKILL ends the process (the tests print its native stacks first, with gdb).
TEARDOWN_MAX_S = 3.0
TEARDOWN_EXIT_S = 0.5


@contextmanager
def _bounded_teardown(name: str, code: int) -> Iterator[None]:
    faulthandler.dump_traceback_later(TEARDOWN_MAX_S)
    timer = threading.Timer(TEARDOWN_MAX_S + TEARDOWN_EXIT_S, _end_teardown, (name, code))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        faulthandler.cancel_dump_traceback_later()


def _name_of(node: Node | None, default_name: str) -> str:
    try:
        return node.get_name() if node is not None else default_name
    except Exception:  # a handle already gone: the name is only for the log line
        return default_name


def _end_teardown(name: str, code: int) -> None:
    print(f"[WARN] [{name}]: the node's teardown in rcl and the middleware did not finish in "
          f"{TEARDOWN_MAX_S:g} s (every thread's stack above); exiting with code {code}",
          file=sys.stderr, flush=True)
    os._exit(code)


def run_node(make_node: Callable[[], Node], default_name: str,
             args: list[str] | None = None) -> int:
    """Check the start-up arguments, init, build the node, spin until Ctrl-C / SIGTERM, shut
    down; 0, or EXIT_BAD_INPUT when the arguments or the node's parameters were invalid
    (the node's `problems`, one line each), in which case nothing was published. A node's
    optional `stop()` runs before it is destroyed, unbounded; the teardown after it is bounded
    (TEARDOWN_MAX_S)."""
    argv = list(sys.argv if args is None else args)
    problems = startup_problems(argv, default_name)
    if problems:
        _report(default_name, problems)
        return EXIT_BAD_INPUT
    signal.signal(signal.SIGTERM, _terminate)
    # A node stuck past SIGINT and SIGTERM shows where (stop_nodes sends it before SIGKILL).
    faulthandler.register(STACK_DUMP_SIGNAL, all_threads=True)
    # rcl logs its own "Failed to parse global arguments" before raising; ours says which.
    rclpy.logging.set_logger_level("rcl", rclpy.logging.LoggingSeverity.FATAL)
    try:
        rclpy.init(args=argv)
    except _rclpy.UnknownROSArgsError as exc:
        _report(default_name, [f"unknown ROS arguments {str(exc)[:200]}; expected -p NAME:=VALUE, "
                               "-r FROM:=TO, --params-file FILE, --log-level LEVEL, ..."])
        return EXIT_BAD_INPUT
    except _rclpy.RCLError as exc:
        _report(default_name, [" ".join(str(exc).split(", at ")[0].split())])
        return EXIT_BAD_INPUT
    rclpy.logging.set_logger_level("rcl", rclpy.logging.LoggingSeverity.UNSET)
    context = rclpy.get_default_context()
    node = None
    code = 0
    try:
        try:
            node = make_node()
            if node.problems:
                for line in node.problems:
                    node.get_logger().error(line)
                code = EXIT_BAD_INPUT
            else:
                rclpy.spin(node)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        except Exception:
            _raise_unless_shut_down(context)
    except KeyboardInterrupt:
        pass  # the stop signal's own KeyboardInterrupt, arriving while its failure was handled
    finally:
        _ignore_stop_signals()
        stop = getattr(node, "stop", None)
        if stop is not None:
            stop()
        # a failure on its way out (a bug) must not end as a clean stop
        with _bounded_teardown(_name_of(node, default_name),
                               code if sys.exc_info()[0] is None else EXIT_CRASH):
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
    return code
