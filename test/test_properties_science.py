"""Property-based tests (Hypothesis, derandomized, bounded examples) for the params loader, the
independent checker and the certified solver's verdicts: any values, file or --set text gives
Params or one-line problems; C1 and C4 are absolute position tests; loosening a bound never
makes the certified optimum worse."""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import yaml
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from uav_insar_planner.evaluate import POSITION_TOL_M, evaluate
from uav_insar_planner.params import SPEC_BY_NAME, ParamError, Params, default_params
from uav_insar_planner.params_file import load_params, parse_override
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.power import schedules

FAST = settings(derandomize=True, max_examples=60, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
NAMES = sorted(SPEC_BY_NAME)
scalars = (st.none() | st.booleans() | st.integers(-10**30, 10**30)
           | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=80))
values = st.recursive(scalars, lambda kids: st.lists(kids, max_size=4)
                      | st.dictionaries(st.text(max_size=10), kids, max_size=3), max_leaves=12)
keys = st.sampled_from(NAMES) | st.text(max_size=30) | st.integers() | st.none()


def refused_in_one_line_each(exc: ParamError) -> None:
    assert exc.problems
    for line in exc.problems:
        assert "\n" not in line and len(line) < 400, line


@FAST
@given(st.dictionaries(keys, values, max_size=5))
@example({"\n": None})  # once a two-line "unknown parameter" error
def test_load_params_returns_params_or_one_line_problems(mapping: dict) -> None:
    try:
        assert isinstance(load_params(None, mapping), Params)
    except ParamError as exc:
        refused_in_one_line_each(exc)


@FAST
@given(st.dictionaries(keys, values, max_size=5), st.sampled_from(["/**", "planner", "other"]))
def test_params_file_returns_params_or_one_line_problems(tmp_path: Path, mapping: dict,
                                                          section: str) -> None:
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump({section: {"ros__parameters": mapping}}))
    try:
        assert isinstance(load_params(path), Params)
    except ParamError as exc:
        refused_in_one_line_each(exc)


@FAST
@given(st.text(max_size=400) | st.binary(max_size=400))
def test_params_file_of_any_bytes_is_params_or_one_line(tmp_path: Path, text) -> None:
    path = tmp_path / "p.yaml"
    (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
    try:
        load_params(path)
    except ParamError as exc:
        refused_in_one_line_each(exc)


@FAST
@given(st.sampled_from(NAMES) | st.text(max_size=20), st.text(max_size=60))
def test_set_override_of_any_text_is_params_or_one_line(name: str, raw: str) -> None:
    try:
        key, value = parse_override(f"{name}={raw}")
        load_params(None, {key: value})
    except ParamError as exc:
        refused_in_one_line_each(exc)


P = default_params()
coords = st.floats(-300.0, 300.0)


@FAST
@given(st.lists(st.tuples(coords, coords), min_size=3, max_size=3),
       st.floats(0.0, 50.0), st.floats(1.0, 500.0), st.floats(0.0, 20.0))
def test_checker_c1_and_c4_are_absolute_position_tests(rows, z_min, z_span, d_min) -> None:
    """C1 holds iff every altitude is within [z_min, z_max] to POSITION_TOL_M, C4 iff every
    pair is at least d_min - POSITION_TOL_M apart: no scale enters either."""
    p = P.replace(z_min_m=z_min, z_max_m=z_min + z_span, d_min_m=d_min)
    q = np.array(rows, dtype=float)
    with np.errstate(all="ignore"):  # arbitrary points may sit on the target (r = 0)
        ev = evaluate(p, q, schedules(p, q, "proposed"), "proposed")
    z = q[:, 1]
    c1 = bool(np.all(z >= p.z_min - POSITION_TOL_M) and np.all(z <= p.z_max + POSITION_TOL_M))
    assert ev.constraints["C1"].ok == c1
    gaps = [math.dist(q[i], q[j]) for i in range(3) for j in range(i + 1, 3)]
    assert ev.constraints["C4"].ok == (min(gaps) >= p.d_min - POSITION_TOL_M)


# Relaxations of feasible scenarios near Table I (solves cost time: few examples)
RELAX = {  # name -> how to loosen its bound by a factor f in (0, 1)
    "z_min_m": lambda v, f: v * f,
    "z_max_m": lambda v, f: v / f,
    "d_min_m": lambda v, f: v * f,
    "swath_min_m": lambda v, f: v * f,
    "h_amb_min_m": lambda v, f: v * f,
    "coherence_rg_min": lambda v, f: max(0.01, v * f),
    "coherence_snr_min": lambda v, f: max(0.01, v * f),
    "e_com_max_j": lambda v, f: v / f,
    "p_com_max_db": lambda v, f: min(60.0, v + 3.0 * (1 - f)),
    "slave_look_angle_min_deg": lambda v, f: v * f,
    "slave_look_angle_max_deg": lambda v, f: min(90.0, v / f),
}
NEAR_TABLE_ONE = st.fixed_dictionaries({
    "h_amb_min_m": st.floats(0.9, 1.5),
    "d_min_m": st.floats(0.5, 3.0),
    "swath_min_m": st.floats(40.0, 60.0),
    "z_max_m": st.floats(80.0, 120.0),
    "coherence_rg_min": st.floats(0.7, 0.85),
    "e_com_max_j": st.floats(450.0, 700.0),
})


@settings(derandomize=True, max_examples=20, deadline=None, database=None)
@given(NEAR_TABLE_ONE, st.sampled_from(sorted(RELAX)), st.floats(0.3, 0.95),
       st.sampled_from(["proposed", "single-baseline", "static-power"]))
def test_loosening_a_bound_never_hurts(base_values, name, factor, scheme) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        base_params = load_params(None, base_values)
        base = solve(base_params, scheme=scheme)
        assume(base.feasible)
        relaxed = solve(base_params.replace(**{name: RELAX[name](base_params.raw[name], factor)}),
                        scheme=scheme)
    assert relaxed.feasible, relaxed.message
    slack = base.optimality_gap + relaxed.optimality_gap + 1e-9
    assert relaxed.sigma_h_m <= base.sigma_h_m * (1 + slack), (relaxed.sigma_h_m, base.sigma_h_m)
