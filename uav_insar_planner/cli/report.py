"""`uav-insar report BAG`: the planned-versus-achieved table and plots of a recorded mission.

    uav-insar report BAG [--out DIR] [--params FILE] [--set NAME=VALUE ...] [--no-progress]
                         [--survey SURVEY_JSON]

BAG is a rosbag2 folder (`uav-insar record`, `make demo`, `ros2 bag record`). The scenario
(R_min, E_max, the radar, for sigma_h) is the one the mission flew with: Table I, or --params
and --set as for `uav-insar solve`; num_slots and num_uavs are taken from the recorded plan
(with another num_uavs than the scenario's, R_min,k as the planner reported it on
/diagnostics). Prints report.recorded.report_table, writes report.recorded_plots.FILES into
DIR (default BAG_report beside the bag) and names them, then the Foxglove layout to open the
bag with (report/foxglove_layout.py): the shipped one for Table I's three UAVs, else one for
the bag's number of UAVs, written into DIR. With `--survey` (the survey.json `uav-insar survey`
wrote, survey/survey_file.py) a bag of a survey flown strip after strip also gets its coverage
map: each strip's slots as flown (the agents' offload samples grouped by their strip,
report/flown.py), the planned and the flown sigma_h over the area's cells
(survey/flown_coverage.py), drawn as coverage.png and summed up in coverage.json, the covered
fractions printed. The parameters, DIR, the survey file and the bag folder are checked first;
then a progress bar on stderr follows the read. Exit codes (exit_codes.py): EXIT_OK written;
EXIT_BAD_INPUT, one line on stderr and nothing written, for bad parameters, a DIR that cannot
be written, no such bag, not a bag, a bag that cannot be read or holds no plan, a survey file
that cannot be read or is not valid, or with --survey a bag of a single pass (no strip
named) or of strips or slots the survey does not have.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from uav_insar_planner.cli.checks import check_output_folder
from uav_insar_planner.cli.scenario import scenario_params
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_OK, CommandFailed

HELP = "plots and a table of a recorded mission"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("bag", type=Path, help="rosbag2 bag folder")
    parser.add_argument("--out", type=Path, metavar="DIR",
                        help="folder for the PNGs (default: BAG_report beside the bag)")
    parser.add_argument("--params", metavar="FILE",
                        help="ROS 2 params file the mission flew with (default: Table I)")
    parser.add_argument("--set", metavar="NAME=VALUE", action="append", default=[],
                        help="override a parameter (repeatable), e.g. --set num_slots=10")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.add_argument("--survey", type=Path, metavar="SURVEY_JSON", help="the survey.json "
                        "of `uav-insar survey` the bag flew: also draw coverage.png (planned "
                        "and flown sigma_h over the area) and write coverage.json")


SURVEY_MAX_BYTES = 10 << 20


def _read_survey_file(path: Path):
    """The SurveyFile at `path`; CommandFailed (one line) when it cannot be read or is not
    valid."""
    from uav_insar_planner.survey.survey_file import read_survey

    shown = repr(str(path)[:200])
    try:
        if path.stat().st_size > SURVEY_MAX_BYTES:
            raise CommandFailed(f"--survey: {shown} is over {SURVEY_MAX_BYTES >> 20} MB; "
                                "expected a survey.json of `uav-insar survey`", EXIT_BAD_INPUT)
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise CommandFailed(f"--survey: {shown} cannot be read ({why}); expected a "
                            "survey.json of `uav-insar survey`", EXIT_BAD_INPUT) from None
    try:
        return read_survey(text)
    except ValueError as exc:
        raise CommandFailed(f"--survey: {shown}: {exc}", EXIT_BAD_INPUT) from None


def _coverage(record, params, survey):
    """(the coverage, its coverage.json summary) of the bag's strips over `survey`."""
    from uav_insar_planner.report.coverage_map import coverage_summary
    from uav_insar_planner.report.recorded import ReportError, flown_by_strip
    from uav_insar_planner.survey.flown_coverage import flown_coverage

    try:
        flown = flown_by_strip(record, params)
        coverage = flown_coverage(survey, survey.sigma_h_m, flown)
    except (ReportError, ValueError) as exc:
        raise CommandFailed(f"--survey: {exc}", EXIT_BAD_INPUT) from None
    return coverage, coverage_summary(coverage, survey, flown)


def main(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from uav_insar_planner.bag.reader import BagError, check_bag, read_mission
    from uav_insar_planner.report.recorded import (
        ReportError,
        flown_scenario,
        mission_figures,
        report_table,
    )

    params = scenario_params(args)
    out = args.out or args.bag.resolve().parent / f"{args.bag.resolve().name}_report"
    check_output_folder("--out", out)
    survey = None if args.survey is None else _read_survey_file(args.survey)
    try:
        check_bag(args.bag)
        bar = tqdm(unit="msg", file=sys.stderr, disable=args.no_progress, desc="reading")
        try:
            record = read_mission(args.bag, progress=bar.update,
                                  total=lambda n: setattr(bar, "total", n))
        finally:
            bar.close()
        params = flown_scenario(record, params)
        figures = mission_figures(record, params)
    except (BagError, ReportError) as exc:
        raise CommandFailed(str(exc), EXIT_BAD_INPUT) from None
    coverage = None if survey is None else _coverage(record, params, survey)
    from uav_insar_planner.report.foxglove_layout import LAYOUT_FILE, SHIPPED, layout_json
    from uav_insar_planner.report.recorded_plots import plot_report

    print(report_table(figures, params))
    for path in plot_report(figures, params, out):
        print(f"wrote {path}")
    if coverage is not None:
        from uav_insar_planner.report.coverage_map import FILE, JSON_FILE, plot_coverage

        cells, summary = coverage
        plot_coverage(cells, survey, out / FILE)
        (out / JSON_FILE).write_text(json.dumps(summary, indent=1) + "\n")
        print(f"coverage: {summary['planned_fraction']:.1%} of the area planned, "
              f"{summary['flown_fraction']:.1%} flown with usable data ({summary['cells']} "
              f"cells of {summary['cell_m']:g} m; {len(summary['strips'])} of "
              f"{len(survey.strips)} strips flown)")
        print(f"wrote {out / FILE}")
        print(f"wrote {out / JSON_FILE}")
    # a plot series per UAV of the bag's plan (mission_figures checked it has num_uavs rows):
    # the shipped layout is Table I's; another swarm's is written beside the plots
    layout = SHIPPED
    if layout_json(params.num_uavs) != SHIPPED.read_text():
        layout = out / LAYOUT_FILE
        layout.write_text(layout_json(params.num_uavs))
        print(f"wrote {layout}")
    storage = sorted(args.bag.glob("*.mcap")) or [args.bag]
    print(f"Foxglove: open {storage[0]}, then import the layout {layout}")
    return EXIT_OK
