"""`uav-insar VERB ...`: solve, sweep and plot the planning problem; simulate, echo, record and
report missions.

One module per verb, as ros2cli's: `HELP` (one line), `add_arguments(parser)` and
`main(args) -> int`. A verb needs the `planner` extra (extras.py) unless it says `LEAN =
True`. A verb with `ROS_ARGS = True` also takes `--ros-args ...`, which the
dispatcher takes out before argparse (parser.split_ros_args) and hands over as `args.ros_args`;
the rclpy work of such a verb is in ros/tools/, imported only when it runs. The exit codes are
exit_codes.py's for every verb; errors are one line on stderr: a ParamError line as
`uav-insar: error: ...`, a CommandFailed or a usage error after the verb's name. A verb
stopped by SIGINT (Ctrl-C) that does not take it as its own way to stop (record, echo,
start-missions do) ends with one line and EXIT_INTERRUPTED, not a KeyboardInterrupt traceback.
"""
from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from uav_insar_planner.cli.parser import OneLineParser, one_line, split_ros_args
from uav_insar_planner.exit_codes import (
    EXIT_BAD_INPUT,
    EXIT_CRASH,
    EXIT_INTERRUPTED,
    EXIT_OK,
    CommandFailed,
)
from uav_insar_planner.extras import missing_line
from uav_insar_planner.params import ParamError
from uav_insar_planner.solver import SolverFailure

PROG = "uav-insar"


def verbs() -> dict[str, ModuleType]:
    """The verb table: command name -> module (imported here, so `import cli.parser` stays
    light)."""
    from uav_insar_planner.cli import (
        echo,
        export_mission,
        montecarlo,
        param_map,
        plot_formation,
        record,
        report,
        solve,
        start_missions,
        survey,
        sweep,
        upload_mission,
    )

    return {"solve": solve, "sweep": sweep, "map": param_map, "plot-formation": plot_formation,
            "montecarlo": montecarlo, "export-mission": export_mission, "echo": echo,
            "record": record, "report": report, "start-missions": start_missions,
            "survey": survey, "upload-mission": upload_mission}


def build_parser(table: dict[str, ModuleType]) -> tuple[argparse.ArgumentParser,
                                                         dict[str, argparse.ArgumentParser]]:
    """`uav-insar` with one subparser per verb of `table`, and the subparsers by name."""
    parser = OneLineParser(prog=PROG, description=__doc__.split("\n\n")[0].replace("\n", " "))
    sub = parser.add_subparsers(dest="verb", required=True, metavar="VERB",
                                parser_class=OneLineParser)
    verb_parsers = {}
    for name, verb in table.items():
        verb_parsers[name] = sub.add_parser(name, help=verb.HELP,
                                            description=verb.__doc__.split("\n\n")[0])
        verb.add_arguments(verb_parsers[name])
    return parser, verb_parsers


def main(argv: Sequence[str] | None = None) -> int:
    """Run `uav-insar` with `argv` (default sys.argv[1:]); returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args: list[str] = []
    try:
        table = verbs()
        verb = table.get(argv[0]) if argv else None
        if getattr(verb, "ROS_ARGS", False):
            own, ros_args = split_ros_args(argv[1:])
            argv = [argv[0], *own]
        parser, verb_parsers = build_parser(table)
        args, unknown = parser.parse_known_args(argv)
        if unknown:  # said by the verb's parser, as its other usage errors
            verb_parsers[args.verb].error("unrecognized arguments: " + " ".join(unknown))
        args.ros_args = ros_args
        if not getattr(table[args.verb], "LEAN", False) and (line := missing_line()):
            raise CommandFailed(line, EXIT_CRASH)
        return table[args.verb].main(args)
    except CommandFailed as exc:
        print(one_line(f"{PROG} {argv[0]}: error: {exc}"), file=sys.stderr)
        return exc.code
    except ParamError as exc:
        for line in exc.problems:
            print(one_line(f"{PROG}: error: {line}"), file=sys.stderr)
        return EXIT_BAD_INPUT
    except SolverFailure as exc:
        print(one_line(f"{PROG}: error: {exc}"), file=sys.stderr)
        return EXIT_CRASH
    except KeyboardInterrupt:
        print(f"{' '.join([PROG, *argv[:1]])}: interrupted (SIGINT) before it finished",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader of our output stopped (`uav-insar solve --json | head`): nothing is
        # wrong, as for any Unix filter. Point stdout at /dev/null so that the interpreter's
        # final flush does not raise again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
