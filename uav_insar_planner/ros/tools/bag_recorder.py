"""The ROS side of `uav-insar record` (cli/record.py, which parses and documents it): a node
that records the suite's topics into a rosbag2 MCAP bag, on rclpy.

The node (`uav_insar_recorder`) looks at the ROS graph every DISCOVERY_PERIOD_S and subscribes to
each new topic that has a publisher: every topic except /rosout, /parameter_events and hidden
ones, or only those given with --topics (names resolved as ros2 resolves them). It subscribes
with raw=True, so it gets the serialized CDR bytes rclpy received, and matches the publishers'
QoS as `ros2 bag record` does: reliable only if every publisher is, transient_local only if
every publisher is (a latched topic such as /formation is recorded even when the recorder
starts after its publisher), depth RECORD_DEPTH. Each message is written with its receive and
send times (bag.writer.McapBagWriter: OUT/metadata.yaml + OUT/OUT_0.mcap as rosbag2 Jazzy
writes them, the publishers' QoS as the topic's offered_qos_profiles, so `ros2 bag play`
latches /formation and /formation/power again).
"""
from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.exceptions import InvalidTopicNameException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions
from rclpy.validate_full_topic_name import validate_full_topic_name

from uav_insar_planner.bag.definitions import DefinitionError
from uav_insar_planner.bag.writer import McapBagWriter
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_OK, CommandFailed
from uav_insar_planner.ros.run import startup_problems
from uav_insar_planner.ros.tools.echo import check_ros_args, message_class
from uav_insar_planner.ros.topics import matching_qos

PROG = "uav-insar record"
NODE_NAME = "uav_insar_recorder"
DISCOVERY_PERIOD_S = 0.2
RECORD_DEPTH = 1000  # a burst of this many messages per topic waits in the queue, not lost
NOT_RECORDED = ("/rosout", "/parameter_events")


def qos_dict(qos: QoSProfile) -> dict[str, Any]:
    """An rclpy QoSProfile as the plain dictionary rosbag2's metadata holds (bag.writer)."""
    def duration(d: Any) -> dict[str, int]:
        sec, nsec = divmod(int(d.nanoseconds), 10**9)
        return {"sec": sec, "nsec": nsec}

    return {"history": qos.history.name.lower(), "depth": int(qos.depth),
            "reliability": qos.reliability.name.lower(),
            "durability": qos.durability.name.lower(),
            "deadline": duration(qos.deadline), "lifespan": duration(qos.lifespan),
            "liveliness": qos.liveliness.name.lower(),
            "liveliness_lease_duration": duration(qos.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": bool(qos.avoid_ros_namespace_conventions)}


class BagRecorder(Node):
    """The recorder node in `context`, writing to `bag`; `topics` (absolute names) limits what
    it records (None: every topic but NOT_RECORDED and hidden ones). `log(line)` hears of each
    topic it subscribes to or cannot record."""

    def __init__(self, context: Context, bag: McapBagWriter,
                 topics: Sequence[str] | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        super().__init__(NODE_NAME, context=context, start_parameter_services=False)
        self.bag = bag
        self.topics = None if topics is None else set(topics)
        self.skipped: set[str] = set()
        self._log = log or (lambda line: None)
        self.create_timer(DISCOVERY_PERIOD_S, self.discover)
        self.discover()

    def wanted(self, topic: str) -> bool:
        if self.topics is not None:
            return topic in self.topics
        return topic not in NOT_RECORDED and "/_" not in topic

    def discover(self) -> None:
        """Subscribe to each wanted topic that has a publisher and is not recorded yet."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self.bag or topic in self.skipped or not self.wanted(topic):
                continue
            infos = [i for i in self.get_publishers_info_by_topic(topic)
                     if i.node_name != NODE_NAME]
            if not infos:
                continue  # only subscribers so far
            if len(types) != 1:
                self._skip(topic, f"more than one type ({', '.join(types)})")
                continue
            offered = [i.qos_profile for i in infos]
            try:
                cls = message_class(types[0], topic)
                self.bag.add_topic(topic, types[0], [qos_dict(q) for q in offered])
            except (CommandFailed, DefinitionError) as exc:
                self._skip(topic, str(exc))
                continue
            self.create_subscription(cls, topic, self._writer(topic),
                                     matching_qos(offered, RECORD_DEPTH), raw=True)
            self._log(f"recording {topic} ({types[0]}, "
                      f"{offered[0].durability.name.lower()})")

    def _writer(self, topic: str) -> Callable[[bytes, dict], None]:
        def write(data: bytes, info: dict) -> None:
            # as rosbag2's recorder: receive time, and the publisher's send time (recorder.cpp)
            self.bag.write(topic, info["received_timestamp"], data,
                           info.get("source_timestamp") or None)
        return write

    def _skip(self, topic: str, why: str) -> None:
        self.skipped.add(topic)
        self._log(f"not recording {topic}: {why}")


# Set by SIGINT / SIGTERM; the spin loop ends at its next turn (within 0.1 s). Not an exception
# raised from the handler: that lands wherever the main thread is, also inside a message's
# write, and left the last chunk with a message record begun and never finished (a bag whose
# last chunk no reader could read: seen in test_sitl_px4_hosts.py's busy recording).
_STOPPING = threading.Event()


def _stop(signum: int, frame: Any) -> None:
    _STOPPING.set()


def record(args: argparse.Namespace) -> int:
    """Record (args of cli/record.py, `args.ros_args` for rcl) until SIGINT / SIGTERM or
    --duration; the exit code, or CommandFailed (EXIT_BAD_INPUT) before anything is written."""
    check_ros_args(args.ros_args)
    topics = None
    if args.topics:
        topics = ["/" + t.lstrip("/") for t in args.topics]
        for t in topics:
            try:
                validate_full_topic_name(t)
            except InvalidTopicNameException as exc:
                raise _bad(f"--topics: {str(exc).splitlines()[0][:200]}") from None
    problems = startup_problems(args.ros_args, NODE_NAME)
    if problems:
        raise _bad(problems[0])
    previous = {}
    _STOPPING.clear()
    if threading.current_thread() is threading.main_thread():
        previous = {s: signal.signal(s, _stop) for s in (signal.SIGINT, signal.SIGTERM)}
    context = rclpy.Context()
    bag = node = executor = None
    try:
        rclpy.init(args=[PROG, *args.ros_args], context=context,
                   signal_handler_options=SignalHandlerOptions.NO)
        bag = McapBagWriter(args.out)
        print(f"{PROG}: recording to {args.out} (Ctrl-C stops)", file=sys.stderr, flush=True)
        node = BagRecorder(context, bag, topics,
                           lambda line: print(f"{PROG}: {line}", file=sys.stderr, flush=True))
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        end = float("inf") if args.duration is None else time.monotonic() + args.duration
        while time.monotonic() < end and not _STOPPING.is_set():
            executor.spin_once(timeout_sec=min(0.1, max(0.0, end - time.monotonic())))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (_rclpy.RCLError, _rclpy.UnknownROSArgsError) as exc:
        raise _bad(f"bad ROS arguments: {str(exc).splitlines()[0][:200]}") from None
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):  # a second Ctrl-C must not lose the bag
            if previous:
                signal.signal(sig, signal.SIG_IGN)
        if executor is not None:
            executor.shutdown(timeout_sec=0)
        if node is not None:
            node.destroy_node()
        context.try_shutdown()
        if bag is not None:
            bag.close()
            print(f"recorded {sum(bag.counts.values())} messages on {len(bag.counts)} topics "
                  f"to {args.out}", flush=True)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return EXIT_OK


def _bad(message: str) -> CommandFailed:
    return CommandFailed(message, EXIT_BAD_INPUT)
