"""Solve along one parameter for several schemes (the paper's Figures 3 and 4)."""
from __future__ import annotations

import csv
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from uav_insar_planner.params import PARAM_SPECS, SPEC_BY_NAME, ParamError, Params, shown
from uav_insar_planner.solver import new_warm_start, solve
from uav_insar_planner.study.executors import Runner, run_serial
from uav_insar_planner.swarm import MAX_UAVS, count_problem, fit_to_swarm

_INDEXED = re.compile(r"^(?P<name>[a-z_0-9]+)(?:\[(?P<index>\d+)\])?$")
# A task solves up to this many consecutive points of one scheme, each warm-started from the
# one before (solver.solve's warm_start); the chains are cut the same way whatever the runner,
# so a parallel run gives the serial run's rows. A chain's first point is solved cold: with 16,
# Figure 4's 21 points made two chains a scheme, the second starting at an infeasible point (a
# full proof and deletion filter where a warm start carries the previous proof), and both
# figure sweeps took 15 % longer; a parallel run still has a task per scheme and 32 points.
CHAIN_POINTS = 32


@dataclass
class SweepRow:
    """One (value, scheme) point. With `band`: bound_opt_m, the least Proposition-1 bound (the
    paper's optimum), and band_lo/hi_m, the range of sigma_h over the formations reaching it
    (the paper's solution set); NaN when not computed."""

    value: float
    scheme: str
    feasible: bool
    sigma_h_m: float
    sigma_h_bound_m: float
    bound_opt_m: float
    band_lo_m: float
    band_hi_m: float
    optimality_gap: float
    solve_time_s: float
    blocking: str
    # Opt-in (run_sweep's montecarlo): the Monte-Carlo fused sigma_h of the plan's formation and
    # its fused ambiguity rate without resolution (montecarlo.py); NaN when not run.
    mc_sigma_h_m: float = float("nan")
    mc_ambiguity: float = float("nan")
    # The plan's certified worst-case sigma_h within nav_error_m (solver/robust.py; sigma_h_m
    # at 0): a column only where some row planned for an error (`has_worst`).
    sigma_h_worst_m: float = float("nan")


def parse_sweep_name(text: str, field: str = "sweep NAME") -> tuple[str, int | None]:
    """`h_amb_min_m` or an element of a list parameter, `rate_min_mbps[1]`; `field` names the
    argument in the error line."""
    m = _INDEXED.match(text)
    spec = SPEC_BY_NAME.get(m.group("name")) if m else None
    if spec is None or spec.kind is str:
        raise ParamError([f"{field}: value {shown(text)} is not allowed; expected a numeric "
                          "parameter of config/params.yaml, e.g. h_amb_min_m or "
                          "rate_min_mbps[1]"])
    index = m.group("index")
    items = MAX_UAVS if spec.per_uav else spec.length  # num_uavs is checked by with_value
    if (index is None) != (items == 0) or (index is not None and int(index) >= items):
        raise ParamError([f"{field}: value {shown(text)} is not allowed; {spec.name} "
                          + (f"needs an index 0..{items - 1}" if items else "takes no index")])
    return spec.name, None if index is None else int(index)


def with_value(params: Params, name: str, index: int | None, value: float) -> Params:
    """params with one (file-unit) parameter, or one element of a list parameter, set. A swarm
    size (num_uavs) takes the per-UAV lists with it, fitted by swarm.fit_to_swarm, so that one
    sweep or map runs over swarms of several sizes; any other value is validated as given."""
    if name == "num_uavs" and float(value).is_integer() and not count_problem(name, int(value)):
        n = int(value)
        return params.replace(**{name: n}, **{s.name: fit_to_swarm(params.raw[s.name], n)
                                              for s in PARAM_SPECS if s.per_uav})
    if index is None:
        return params.replace(**{name: value})
    items = list(params.raw[name])
    if index >= len(items):
        raise ParamError([f"{name}[{index}]: index {index} is not allowed; expected 0.."
                          f"{len(items) - 1} (one per UAV of num_uavs {params.num_uavs})"])
    items[index] = value
    return params.replace(**{name: items})


def run_sweep(params: Params, name: str, values: Iterable[float], schemes: Sequence[str],
              objective: str | None = None, solver: str | None = None, band: bool = False,
              progress: Callable[[], None] | None = None,
              montecarlo: int = 0, run: Runner = run_serial) -> list[SweepRow]:
    """Solve every (value, scheme), in that order; `progress` is called once per solve.
    `montecarlo` > 0: that many Monte-Carlo samples per pair (seed 0) for each feasible plan.
    `run` (study/executors.py) runs the solves: here by default, or on worker processes."""
    base, index = parse_sweep_name(name)
    points = [(with_value(params, base, index, float(v)), float(v)) for v in values]
    return run_points(points, schemes, objective, solver, band, montecarlo, progress, run)


def run_points(points: Sequence[tuple[Params, float]], schemes: Sequence[str],
               objective: str | None, solver: str | None, band: bool, montecarlo: int,
               progress: Callable[[], None] | None, run: Runner) -> list[SweepRow]:
    """Every (Params, value) of `points` for every scheme, rows in the order of the points,
    then the schemes: each scheme's points in chains of CHAIN_POINTS (`solve_chain`)."""
    chains = [(scheme, start) for scheme in schemes
              for start in range(0, len(points), CHAIN_POINTS)]
    tasks = [(points[start:start + CHAIN_POINTS], scheme, objective, solver, band, montecarlo)
             for scheme, start in chains]
    done = run(solve_chain, tasks, _per_solve(progress, len(points) * len(schemes), len(tasks)))
    by = {(scheme, start + i): row for (scheme, start), rows in zip(chains, done, strict=True)
          for i, row in enumerate(rows)}
    return [by[(scheme, i)] for i in range(len(points)) for scheme in schemes]


def _per_solve(progress: Callable[[], None] | None, solves: int, tasks: int):
    """`progress` called once per solve in all, spread evenly over the finished chains (a
    runner reports tasks, not which one finished)."""
    if progress is None or not tasks:
        return progress
    state = {"tasks": 0, "solves": 0}

    def step() -> None:
        state["tasks"] += 1
        upto = solves * state["tasks"] // tasks
        for _ in range(upto - state["solves"]):
            progress()
        state["solves"] = upto
    return step


def solve_chain(points: Sequence[tuple[Params, float]], scheme: str, objective: str | None,
                solver: str | None, band: bool, montecarlo: int) -> list[SweepRow]:
    """Rows of consecutive points of one scheme (a task of any runner), each solve
    warm-started from the one before (solver.new_warm_start; nothing when the back end
    takes no warm start)."""
    warm = new_warm_start(solver or points[0][0].solver) if points else None
    return [solve_point(p, value, scheme, objective, solver, band, montecarlo, warm)
            for p, value in points]


def solve_point(p: Params, value: float, scheme: str, objective: str | None,
                solver: str | None, band: bool, montecarlo: int,
                warm_start: object | None = None) -> SweepRow:
    """One row: `p` (already at `value`) solved for `scheme`."""
    plan = solve(p, scheme=scheme, objective=objective, solver=solver, warm_start=warm_start)
    bound_opt = lo = hi = float("nan")
    if band and plan.feasible:
        from uav_insar_planner.study.band import bound_minimizer_band

        bound_opt = solve(p, scheme=scheme, objective="bound",
                          solver="global").sigma_h_bound_m
        lo, hi = bound_minimizer_band(p, scheme)
    return SweepRow(value, scheme, plan.feasible, plan.sigma_h_m, plan.sigma_h_bound_m,
                    bound_opt, lo, hi, plan.optimality_gap, plan.solve_time_s,
                    " ".join(plan.blocking_constraints),
                    *(_montecarlo(p, plan, montecarlo) if montecarlo and plan.feasible
                      else (float("nan"),) * 2),
                    sigma_h_worst_m=plan.sigma_h_worst_m)


def _montecarlo(p: Params, plan, samples: int) -> tuple[float, float]:
    from uav_insar_planner.montecarlo import pairs_of_formation, simulate

    r = simulate(pairs_of_formation(p, plan.formation), p.looks, samples, seed=0)
    top = r.get("fused") or next(iter(r["pairs"].values()))
    return top["sigma_h_mc_m"]["value"], top["ambiguity_rate"]["value"]


def csv_fields(rows: Sequence[SweepRow]) -> list[str]:
    """The CSV columns of `rows`: every field, the Monte-Carlo ones only when they were run, the
    worst case only when a navigation error was planned for."""
    fields = list(asdict(rows[0]).keys()) if rows else ["value"]
    if not any(np.isfinite(r.mc_sigma_h_m) for r in rows):  # the default columns only
        fields = [f for f in fields if not f.startswith("mc_")]
    if not has_worst(rows):
        fields = [f for f in fields if f != "sigma_h_worst_m"]
    return fields


def has_worst(rows: Sequence[SweepRow]) -> bool:
    """Did some row plan for a navigation error (its worst case above its sigma_h)?"""
    return any(r.feasible and r.sigma_h_worst_m != r.sigma_h_m for r in rows)


def write_csv(rows: Sequence[SweepRow], path: str | Path, name: str) -> None:
    fields = csv_fields(rows)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        fh.write(f"# sweep of {name}\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: v for k, v in asdict(row).items() if k in fields})


def gains(rows: Sequence[SweepRow], reference: str = "proposed") -> dict[str, float]:
    """Least gain of `reference` over each other scheme along the sweep, gain being
    1 - sigma_h(reference) / sigma_h(other), over the points where both are feasible."""
    by = {(r.value, r.scheme): r for r in rows}
    out: dict[str, float] = {}
    for scheme in {r.scheme for r in rows} - {reference}:
        g = [1.0 - by[(v, reference)].sigma_h_m / r.sigma_h_m
             for (v, s), r in by.items() if s == scheme and r.feasible
             and (v, reference) in by and by[(v, reference)].feasible]
        out[scheme] = float(np.min(g)) if g else float("nan")
    return out
