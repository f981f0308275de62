"""`uav-insar sweep NAME START STOP COUNT`: solve along one parameter for several schemes.

Prints the rate margin every row holds, once (`--paper`: the paper's problem (P), margin 0),
then one row per (value, scheme); `--csv` and `--plot` (the paper's Figures 3/4) write them.
Every value, `--mc-samples`, both output paths and where to solve are checked before the first
solve. Time: COUNT (at most checks.SWEEP_COUNT_MAX) times the schemes solves, each with a
Monte-Carlo of at most cli/montecarlo.MAX_DRAWS draws per pair with `--montecarlo`, on `--jobs`
worker processes (default one per core) or a Dask cluster's workers (`--scheduler`;
cli/execution.py), rows in the same order and with the same values whichever. Exit codes
(exit_codes.py): EXIT_OK (an infeasible value is a row, not a failure), EXIT_BAD_INPUT,
EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse

from uav_insar_planner.cli.checks import check_output_path, finite_float, sweep_count
from uav_insar_planner.cli.execution import add_execution_arguments, solving
from uav_insar_planner.cli.output import whole_file
from uav_insar_planner.cli.scenario import add_scenario_arguments, margin_line, scenario_params
from uav_insar_planner.exit_codes import EXIT_OK
from uav_insar_planner.params import SCHEMES, ParamError

HELP = "solve along one parameter for several schemes"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", help="parameter, e.g. h_amb_min_m or rate_min_mbps[1]")
    parser.add_argument("start", type=finite_float,
                        help="first value (the parameter's file unit)")
    parser.add_argument("stop", type=finite_float, help="last value")
    parser.add_argument("count", type=sweep_count,
                        help="number of evenly spaced values (1..10000)")
    add_scenario_arguments(parser, paper=True)
    parser.add_argument("--schemes", nargs="+", choices=SCHEMES, default=list(SCHEMES),
                        help="schemes to solve at each value (default: all four)")
    parser.add_argument("--band", action="store_true",
                        help="also show the bound's optimum and sigma_h's range over the "
                        "bound's minimisers (the paper's solution set)")
    parser.add_argument("--montecarlo", action="store_true",
                        help="also the Monte-Carlo fused sigma_h and ambiguity rate of each "
                        "plan (seed 0)")
    parser.add_argument("--mc-samples", default="100000", metavar="N",
                        help="samples per pair for --montecarlo (default 100000)")
    parser.add_argument("--csv", metavar="FILE", help="write one row per (value, scheme)")
    parser.add_argument("--plot", metavar="FILE.png", help="plot as the paper's Figures 3/4")
    add_execution_arguments(parser)


def main(args: argparse.Namespace) -> int:
    import numpy as np

    from uav_insar_planner.study.sweep import parse_sweep_name, run_sweep, with_value, write_csv

    params = scenario_params(args)
    parse_sweep_name(args.name)
    if args.csv:
        check_output_path("--csv", args.csv)
    if args.plot:
        check_output_path("--plot", args.plot, image=True)
    values = np.linspace(args.start, args.stop, args.count)
    # every value is validated before the first solve
    scenarios = [with_value(params, *parse_sweep_name(args.name), float(v)) for v in values]
    looks = max(p.looks for p in scenarios)
    if args.band and (error := max(p.nav_error_m for p in scenarios)) > 0:
        raise ParamError([f"--band: not allowed with nav_error_m {error:g}; expected "
                          "nav_error_m 0 (the band spreads sigma_h over the nominal bound's "
                          "minimisers, a study of the nominal problem)"])
    mc = 0
    if args.montecarlo:
        from uav_insar_planner.cli.montecarlo import parse_samples

        mc = parse_samples("--mc-samples", args.mc_samples, looks)
    with solving(args, len(values) * len(args.schemes)) as (run, bar):
        rows = run_sweep(params, args.name, values, args.schemes, band=args.band,
                         progress=bar.update, montecarlo=mc, run=run)
    _print_rows(rows, args, mc, params.rate_margin)
    if args.csv:
        with whole_file(args.csv) as tmp:
            write_csv(rows, tmp, args.name)
        print(f"wrote {args.csv}")
    if args.plot:
        from uav_insar_planner.report.figures import plot_sweep

        with whole_file(args.plot) as tmp:
            plot_sweep(rows, args.name, tmp)
        print(f"wrote {args.plot}")
    return EXIT_OK


def _print_rows(rows: list, args: argparse.Namespace, mc: int, margin: float) -> None:
    from uav_insar_planner.study.sweep import gains, has_worst

    if args.name != "rate_margin":  # swept, it is the table's first column
        print(margin_line(margin, args.paper))
    extra = f" {'bound_opt':>10} {'band_lo':>9} {'band_hi':>9}" if args.band else ""
    extra += f" {'mc_sigma_h':>10} {'mc_amb_%':>8}" if mc else ""
    worst = has_worst(rows)
    extra += f" {'worst_m':>10}" if worst else ""
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
        if worst:
            bd += f" {r.sigma_h_worst_m:10.5f}" if r.feasible else " " * 11
        print(f"{r.value:10.4g}  {r.scheme:<16} {sh} {bd}  {r.blocking}")
    if "proposed" in args.schemes and len(args.schemes) > 1:
        for scheme, g in sorted(gains(rows).items()):
            print(f"least gain of proposed over {scheme}: {100 * g:.1f}% "
                  "(1 - sigma_h(proposed)/sigma_h(scheme), where both are feasible)")
