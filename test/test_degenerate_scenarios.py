"""Degenerate and extreme scenarios (relaxations of Table I, every parameter at the edge of
its range, extreme allowed values): every allowed scenario gets a right verdict from both back
ends without an exception or a numpy RuntimeWarning; values that make the model meaningless
are refused by the parameter ranges, with the reason in the line."""
from __future__ import annotations

import warnings

import pytest

from uav_insar_planner.params import PARAM_SPECS, ParamError, default_params
from uav_insar_planner.params_file import load_params
from uav_insar_planner.solver import solve


def strict_solve(overrides: dict, **kw):
    """solve() with numpy RuntimeWarnings turned into errors (they must not reach stderr)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        return solve(load_params(None, overrides), **kw)


@pytest.mark.parametrize("overrides, says", [
    ({"coherence_rg_min": 1e-300, "coherence_snr_min": 1e-300}, "below 0.01 eq. 14's phase"),
    ({"coherence_rg_min": 1.0}, "gamma_Rg = 1 only where b_perp = 0"),
    ({"coherence_snr_min": 1.0}, "gamma_SNR = 1 needs an infinite SNR"),
    ({"coherence_other": 1e-300}, "below 0.01"),
    ({"wavelength_m": 1e308}, "1 mm (mm-wave) to 10 m (VHF)"),
    ({"wavelength_m": 1e-300}, "1 mm (mm-wave) to 10 m (VHF)"),
    ({"z_max_m": 1e308}, "1000 km at most"),
    ({"speed_mps": 1e308}, "1 cm/s to 1 km/s"),
    ({"speed_mps": 1e-300}, "gamma_m grows as 1/v_y"),
    ({"d_min_m": 1e308}, "1000 km at most"),
    ({"h_amb_min_m": 1e-300}, "1 mm to 1000 km"),
    ({"system_temperature_k": 1e-300}, "no receiver is below 1 K"),
    ({"radar_bandwidth_hz": 1e-300}, "fractional bandwidth B_Rg/f_0 in [0.0001, 2)"),
    ({"z_min_m": 0.0, "swath_min_m": 0.0}, "master's least slant range"),
    ({"z_min_m": 0.0, "swath_min_m": 0.0, "d_min_m": 0.0}, "onto the target"),
])
def test_meaningless_values_are_refused_with_a_reason(overrides: dict, says: str) -> None:
    with pytest.raises(ParamError) as err:
        load_params(None, overrides)
    problems = err.value.problems
    assert problems and all(says in line for line in problems), problems


TABLE_ONE = {scheme: solve(default_params(), scheme=scheme)
             for scheme in ("proposed", "single-baseline", "fixed-master", "static-power")}


@pytest.mark.parametrize("scheme", sorted(TABLE_ONE))
@pytest.mark.parametrize("relaxed", [
    {"z_min_m": 0.0},
    {"swath_min_m": 0.0},
    {"d_min_m": 0.0},
    {"z_max_m": 1e6},
    {"comm_bandwidth_hz": 1e308},
    # at the master's range floor (0.1 m): the formation may shrink to centimetres
    {"swath_min_m": 0.0, "d_min_m": 0.0, "z_min_m": 0.0708},
], ids=lambda d: ",".join(f"{k}={v:g}" for k, v in d.items()))
def test_a_relaxation_of_table_one_is_feasible_and_no_worse(scheme: str, relaxed: dict) -> None:
    """Each case only loosens constraints of a feasible scenario: the certified optimum may
    only fall (to within the optimality gaps), and the plan passes the independent check.
    `swath_min_m=0 d_min_m=0 z_min_m=0` was once INFEASIBLE with all UAVs at range 0 (a
    clamp of underflowed weights made r0 = 1e-161 look optimal); `z_min_m=0` had gap 1.0."""
    base = TABLE_ONE[scheme]
    plan = strict_solve({**relaxed, "master_fixed_xz_m": [-54.0, 74.0]}, scheme=scheme)
    assert plan.feasible, plan.message
    assert plan.optimality_gap < 1e-4, plan.message
    assert plan.sigma_h_m <= base.sigma_h_m * (1 + 1e-4)


@pytest.mark.parametrize("overrides", [
    {"z_max_m": 1e6},         # once "C5, C6 cannot hold together": a 1250 m grid step
    {"comm_bandwidth_hz": 1e308},  # once infeasible by C10: 1 + SNR rounded to 1
    {"z_min_m": 0.0},
    {"swath_min_m": 0.0, "d_min_m": 0.0, "z_min_m": 0.0708},
    {"slave_look_angle_max_deg": 90.0},  # once C8 missed by 7e-5 m: tan(90 deg) in C3
    {"slave_look_angle_min_deg": 0.0},
], ids=lambda d: ",".join(f"{k}={v:g}" for k, v in d.items()))
def test_paper_ao_on_relaxations_of_table_one(overrides: dict) -> None:
    plan = strict_solve({**overrides, "solver": "paper-ao"})
    assert plan.feasible, plan.message
    assert not plan.blocking_constraints


@pytest.mark.parametrize("solver", ["global", "paper-ao", "evolution"])
@pytest.mark.parametrize("overrides, blocking", [
    ({"comm_bandwidth_hz": 1e-300}, {"C9", "C10"}),      # 2^(R/B) beyond doubles: no power
    ({"speed_mps": 1000.0}, {"C6"}),                     # gamma_m ~ 1/v_y: no SNR left
    ({"swath_min_m": 1e6}, {"C5"}),
    ({"rate_min_mbps": [1e308, 1e308, 1e308]}, {"C10"}),
], ids=["B_c=1e-300", "v_y=1000", "S_min=1e6", "R_min=1e308"])
def test_extreme_allowed_values_give_a_verdict(solver: str, overrides: dict,
                                               blocking: set) -> None:
    plan = strict_solve({**overrides, "solver": solver})
    assert not plan.feasible
    assert blocking & set(plan.blocking_constraints), plan.message


def _edges():
    """Each numeric parameter at each end of its allowed range (open ends approached)."""
    for spec in PARAM_SPECS:
        if spec.kind is str:
            continue
        ends = []
        for end, is_open, towards in ((spec.lo, spec.lo_open, 1.0), (spec.hi, spec.hi_open, -1.0)):
            if end is None:
                end, is_open = (1e308 if towards < 0 else -1e308), False
            ends.append(end if not is_open else
                        (end + towards * 1e-300 if end == 0 else end * (1 - towards * 1e-12)))
        for v in ends:
            value = [v] * spec.length if spec.length else (int(v) if spec.kind is int else v)
            try:
                load_params(None, {spec.name: value})
            except ParamError:
                continue  # a cross-field rule (e.g. z_min < z_max) refuses it alone
            yield pytest.param(spec.name, value, id=f"{spec.name}={v:g}")


@pytest.mark.parametrize("name, value", list(_edges()))
def test_global_solver_is_total_on_every_range_edge(name: str, value) -> None:
    """No exception and no RuntimeWarning at any edge of the allowed domain, and a verdict:
    a feasible plan passes the independent check, an infeasible one names its blockers."""
    plan = strict_solve({name: value})
    assert plan.feasible or plan.blocking_constraints, plan.message
