"""Solve on the grid of two parameters for several schemes: a parameter map.

Each cell is a sweep point (sweep.solve_point) with both parameters set, solved in chains along
value2 (sweep.run_points); the rows come in the order value1, then value2, then scheme,
whichever runner (study/executors.py) solved them.
"""
from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from uav_insar_planner.params import Params
from uav_insar_planner.study.executors import Runner, run_serial
from uav_insar_planner.study.sweep import (
    SweepRow,
    csv_fields,
    parse_sweep_name,
    run_points,
    with_value,
)


@dataclass
class MapRow:
    """One (value1, value2, scheme) cell; `point.value` is value1."""

    value1: float
    value2: float
    point: SweepRow


def map_params(params: Params, name1: str, values1: Sequence[float], name2: str,
               values2: Sequence[float]) -> list[tuple[Params, float, float]]:
    """(Params, value1, value2) of every cell, value2 varying fastest; raises ParamError on
    the first cell whose scenario is not allowed (before any solve)."""
    (b1, i1), (b2, i2) = parse_sweep_name(name1, "map NAME1"), parse_sweep_name(name2, "map NAME2")
    return [(with_value(with_value(params, b1, i1, float(v1)), b2, i2, float(v2)),
             float(v1), float(v2)) for v1 in values1 for v2 in values2]


def run_map(cells: Sequence[tuple[Params, float, float]], schemes: Sequence[str],
            objective: str | None = None, solver: str | None = None,
            progress: Callable[[], None] | None = None,
            run: Runner = run_serial) -> list[MapRow]:
    """Solve every cell of map_params for every scheme; `progress` is called once per solve."""
    points = run_points([(p, v1) for p, v1, _ in cells], schemes, objective, solver,
                        band=False, montecarlo=0, progress=progress, run=run)
    value2 = [v2 for _, _, v2 in cells for _ in schemes]
    return [MapRow(pt.value, v2, pt) for pt, v2 in zip(points, value2, strict=True)]


def write_map_csv(rows: Sequence[MapRow], path: str | Path, name1: str, name2: str) -> None:
    """One row per (value1, value2, scheme) with the sweep CSV's columns."""
    fields = [f for f in csv_fields([r.point for r in rows]) if f != "value"]
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=["value1", "value2", *fields])
        fh.write(f"# map of {name1} (value1) x {name2} (value2)\n")
        writer.writeheader()
        for r in rows:
            point = asdict(r.point)
            writer.writerow({"value1": r.value1, "value2": r.value2,
                             **{k: point[k] for k in fields}})
