"""`uav-insar`: solve, sweep and plot the planning problem; echo topics.

Exit codes: 0 solved, 3 infeasible (solve), 2 bad input (one line per problem, no traceback),
1 a solver failed on an allowed scenario (a bug: one line naming it, no traceback).
"""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

import numpy as np

from uav_insar_planner.cli.checks import check_output_path, finite_float, sweep_count
from uav_insar_planner.cli.parser import OneLineParser as _Parser
from uav_insar_planner.cli.parser import one_line as _one_line
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.params import OBJECTIVES, SCHEMES, SOLVERS, ParamError, Params
from uav_insar_planner.params_file import load_params, parse_override
from uav_insar_planner.solver import SolverFailure

EXIT_SOLVER_FAILED = EXIT_CRASH


def _add_scenario_args(command: argparse.ArgumentParser) -> None:
    command.add_argument("--params", metavar="FILE",
                         help="ROS 2 params file (default: Table I)")
    command.add_argument("--set", metavar="NAME=VALUE", action="append", default=[],
                         help="override a parameter (repeatable), e.g. --set h_amb_min_m=0.9")
    command.add_argument("--objective", choices=OBJECTIVES,
                         help="exact sigma_h, Prop. 1 bound, or sigma_h with the exact "
                         "multilook phase std")
    command.add_argument("--solver", choices=SOLVERS, help="global (certified) or paper-ao")


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="uav-insar", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("solve", help="solve problem (P) and print the plan")
    _add_scenario_args(s)
    s.add_argument("--scheme", choices=SCHEMES, help="proposed or benchmark 1-3")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--min-separation-m", type=float, default=None, metavar="M",
                   help="warn when two planned UAVs are closer than M metres (default 2.0: "
                        "standard GNSS error; 0 turns the warning off)")

    w = sub.add_parser("sweep", help="solve along one parameter for several schemes")
    w.add_argument("name", help="parameter, e.g. h_amb_min_m or rate_min_mbps[1]")
    w.add_argument("start", type=finite_float, help="first value (the parameter's file unit)")
    w.add_argument("stop", type=finite_float, help="last value")
    w.add_argument("count", type=sweep_count, help="number of evenly spaced values (1..10000)")
    _add_scenario_args(w)
    w.add_argument("--schemes", nargs="+", choices=SCHEMES, default=list(SCHEMES),
                   help="schemes to solve at each value (default: all four)")
    w.add_argument("--band", action="store_true",
                   help="also show the bound's optimum and sigma_h's range over the bound's "
                   "minimisers (the paper's solution set)")
    w.add_argument("--montecarlo", action="store_true",
                   help="also the Monte-Carlo fused sigma_h and ambiguity rate of each plan "
                   "(seed 0)")
    w.add_argument("--mc-samples", default="100000", metavar="N",
                   help="samples per pair for --montecarlo (default 100000)")
    w.add_argument("--csv", metavar="FILE", help="write one row per (value, scheme)")
    w.add_argument("--plot", metavar="FILE.png", help="plot as the paper's Figures 3/4")
    w.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")

    f = sub.add_parser("plot-formation", help="draw the across-track plane")
    _add_scenario_args(f)
    f.add_argument("--scheme", choices=SCHEMES)
    f.add_argument("--out", default="formation.png", metavar="FILE.png")

    from uav_insar_planner.cli.montecarlo import add_parser as add_montecarlo_parser

    add_montecarlo_parser(sub, _add_scenario_args)

    # echo parses its own options (uav_insar_planner/ros/tools/echo.py): they pass through.
    sub.add_parser("echo", help="print a topic like `ros2 topic echo` (see echo --help)",
                   add_help=False)
    # record and report parse their own options too (ros/tools/record.py, cli/report.py).
    sub.add_parser("record", help="record the topics into a rosbag2 MCAP bag (see record "
                   "--help)", add_help=False)
    sub.add_parser("report", help="plots and a table of a recorded mission (see report "
                   "--help)", add_help=False)
    return parser


def _scenario(args: argparse.Namespace) -> Params:
    overrides = dict(parse_override(item) for item in args.set)
    if args.objective:
        overrides["objective"] = args.objective
    if args.solver:
        overrides["solver"] = args.solver
    if getattr(args, "scheme", None):
        overrides["scheme"] = args.scheme
    return load_params(args.params, overrides)


def _cmd_solve(args: argparse.Namespace) -> int:
    from uav_insar_planner.plan import SAFE_SEPARATION_M, closest_pair
    from uav_insar_planner.report.plan_text import format_plan
    from uav_insar_planner.solver import solve

    limit = SAFE_SEPARATION_M if args.min_separation_m is None else args.min_separation_m
    if not (limit >= 0.0 and np.isfinite(limit)):
        raise ParamError([f"--min-separation-m: value {limit!r} is not allowed; expected a "
                          "finite number >= 0"])
    plan = solve(_scenario(args))
    print(json.dumps(plan.to_dict(), indent=2) if args.json else format_plan(plan))
    closest = closest_pair(plan.formation) if plan.feasible else None
    if closest is not None and closest[0] < limit:
        d, j, k = closest
        print(f"uav-insar: warning: uav{j} and uav{k} are planned {d:.2f} m apart, closer than "
              f"{limit:g} m: with standard GNSS (1.5-3 m error) they may collide; fly RTK "
              "or raise d_min_m", file=sys.stderr)
    return EXIT_OK if plan.feasible else EXIT_INFEASIBLE


def _cmd_sweep(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from uav_insar_planner.sweep import gains, parse_sweep_name, run_sweep, with_value, write_csv

    params = _scenario(args)
    parse_sweep_name(args.name)
    if args.csv:
        check_output_path("--csv", args.csv)
    if args.plot:
        check_output_path("--plot", args.plot, image=True)
    mc = 0
    if args.montecarlo:
        from uav_insar_planner.cli.montecarlo import MAX_SAMPLES, parse_int

        mc = parse_int("--mc-samples", args.mc_samples, 2, MAX_SAMPLES)
    values = np.linspace(args.start, args.stop, args.count)
    for value in values:  # every value is validated before the first solve
        with_value(params, *parse_sweep_name(args.name), float(value))
    bar = tqdm(total=len(values) * len(args.schemes), unit="solve", file=sys.stderr,
               disable=args.no_progress)
    rows = run_sweep(params, args.name, values, args.schemes, band=args.band,
                     progress=bar.update, montecarlo=mc)
    bar.close()
    extra = f" {'bound_opt':>10} {'band_lo':>9} {'band_hi':>9}" if args.band else ""
    extra += f" {'mc_sigma_h':>10} {'mc_amb_%':>8}" if mc else ""
    print(f"{'value':>10}  {'scheme':<16} {'sigma_h_m':>10} {'bound_m':>10}{extra}  blocking")
    for r in rows:
        sh = f"{r.sigma_h_m:10.5f}" if r.feasible else f"{'infeas.':>10}"
        bd = f"{r.sigma_h_bound_m:10.5f}" if r.feasible else f"{'':>10}"
        if args.band:
            bd += (f" {r.bound_opt_m:10.5f} {r.band_lo_m:9.5f} {r.band_hi_m:9.5f}"
                   if r.feasible else " " * 31)
        if mc:
            bd += (f" {r.mc_sigma_h_m:10.5f} {100 * r.mc_ambiguity:8.2f}" if r.feasible
                   else " " * 20)
        print(f"{r.value:10.4g}  {r.scheme:<16} {sh} {bd}  {r.blocking}")
    if "proposed" in args.schemes and len(args.schemes) > 1:
        for scheme, g in sorted(gains(rows).items()):
            print(f"least gain of proposed over {scheme}: {100 * g:.1f}% "
                  "(1 - sigma_h(proposed)/sigma_h(scheme), where both are feasible)")
    if args.csv:
        write_csv(rows, args.csv, args.name)
        print(f"wrote {args.csv}")
    if args.plot:
        from uav_insar_planner.report.figures import plot_sweep

        plot_sweep(rows, args.name, args.plot)
        print(f"wrote {args.plot}")
    return EXIT_OK


def _cmd_plot_formation(args: argparse.Namespace) -> int:
    from uav_insar_planner.report.figures import plot_formation
    from uav_insar_planner.solver import solve

    params = _scenario(args)
    check_output_path("--out", args.out, image=True)
    plan = solve(params)
    if not plan.feasible:
        print("infeasible, blocked by: " + ", ".join(plan.blocking_constraints),
              file=sys.stderr)
        return EXIT_INFEASIBLE
    plot_formation(params, plan, args.out)
    print(f"wrote {args.out}")
    return EXIT_OK


def _cmd_montecarlo(args: argparse.Namespace) -> int:
    from uav_insar_planner.cli.montecarlo import run

    return run(args, _scenario)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = _build_parser()
    args, rest = parser.parse_known_args(argv)
    if args.command == "echo":
        from uav_insar_planner.ros.tools.echo import main as echo_main

        return echo_main(rest)
    if args.command == "record":
        from uav_insar_planner.ros.tools.record import main as record_main

        return record_main(rest)
    if args.command == "report":
        from uav_insar_planner.cli.report import main as report_main

        return report_main(rest)
    if rest:
        parser.error("unrecognized arguments: " + " ".join(rest))
    commands = {"solve": _cmd_solve, "sweep": _cmd_sweep, "plot-formation": _cmd_plot_formation,
                "montecarlo": _cmd_montecarlo}
    try:
        return commands[args.command](args)
    except ParamError as exc:
        for line in exc.problems:
            print(_one_line(f"uav-insar: error: {line}"), file=sys.stderr)
        return EXIT_BAD_INPUT
    except SolverFailure as exc:
        print(_one_line(f"uav-insar: error: {exc}"), file=sys.stderr)
        return EXIT_SOLVER_FAILED
