"""`uav-insar report BAG`: the planned-versus-achieved table and plots of a recorded mission.

    uav-insar report BAG [--out DIR] [--params FILE] [--set NAME=VALUE ...] [--no-progress]

BAG is a rosbag2 folder (`uav-insar record`, `make demo`, `ros2 bag record`). The scenario
(R_min, E_max, the radar, for sigma_h) is the one the mission flew with: Table I, or --params
and --set as for `uav-insar solve`; num_slots is taken from the recorded plan. Prints
report.recorded.report_table, writes report.recorded_plots.FILES into DIR (default BAG_report
beside the bag) and names them. A progress bar on stderr follows the read. Exit codes: 0
written; 2 bad input (no such bag, not a bag, no plan in it, bad parameters), one line on
stderr.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

PROG = "uav-insar report"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Plots and a table of a recorded mission.")
    p.add_argument("bag", type=Path, help="rosbag2 bag folder")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="folder for the PNGs (default: BAG_report beside the bag)")
    p.add_argument("--params", metavar="FILE",
                   help="ROS 2 params file the mission flew with (default: Table I)")
    p.add_argument("--set", metavar="NAME=VALUE", action="append", default=[],
                   help="override a parameter (repeatable), e.g. --set num_slots=10")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run `uav-insar report` with `argv`; returns the exit code."""
    from tqdm import tqdm

    from uav_insar_planner.bag.reader import BagError, read_mission
    from uav_insar_planner.params import ParamError
    from uav_insar_planner.params_file import load_params, parse_override
    from uav_insar_planner.report.recorded import (
        ReportError,
        flown_scenario,
        mission_figures,
        report_table,
    )

    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    out = args.out or args.bag.resolve().parent / f"{args.bag.resolve().name}_report"
    try:
        params = load_params(args.params, dict(parse_override(s) for s in args.set))
        if out.exists() and not out.is_dir():
            raise ParamError([f"--out: {str(out)[:200]!r} exists and is not a folder"])
        bar = tqdm(unit="msg", file=sys.stderr, disable=args.no_progress, desc="reading")
        try:
            record = read_mission(args.bag, progress=bar.update,
                                  total=lambda n: setattr(bar, "total", n))
        finally:
            bar.close()
        params = flown_scenario(record, params)
        figures = mission_figures(record, params)
    except ParamError as exc:
        for line in exc.problems:
            print(f"{PROG}: error: {line}", file=sys.stderr)
        return 2
    except (BagError, ReportError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    from uav_insar_planner.report.recorded_plots import plot_report

    print(report_table(figures, params))
    for path in plot_report(figures, params, out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
