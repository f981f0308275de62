"""Robust plans (nav_error_m): every UAV moved anywhere within e keeps C1, C3-C11 with the plan's
power schedule under the independent checker, sigma_h stays below the certified worst case,
e = 0 is the nominal plan, infeasibility is proved, the other back ends refuse it."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.param_specs.science import BACKENDS
from uav_insar_planner.params import ParamError, default_params
from uav_insar_planner.solver import backend, power, robust, solve
from uav_insar_planner.solver.worst_case import robust_slacks, worst_sigma

SAMPLES = 3000
# Families whose checker slack is in the same SI unit as robust_slacks' (evaluate.py).
SAME_UNIT = ("C1", "C3", "C4", "C5", "C6", "C7", "C8", "C10")


def moved(formation: np.ndarray, e: float, rng: np.random.Generator, adversarial: np.ndarray
          ) -> np.ndarray:
    """SAMPLES formations, each flown UAV moved within e: a third uniform in the disks, a
    third on their rims, a third on the rims within 20 degrees of the directions that shrink
    every b_perp (the master along n, the slaves against it)."""
    n = len(formation)
    third = SAMPLES // 3
    angle = rng.uniform(0.0, 2.0 * math.pi, (SAMPLES, n))
    radius = np.full((SAMPLES, n), e)
    radius[:third] = e * np.sqrt(rng.uniform(0.0, 1.0, (third, n)))
    angle[2 * third:] = adversarial + rng.uniform(-0.35, 0.35, (SAMPLES - 2 * third, n))
    step = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=2)
    return formation[None] + step


@pytest.mark.parametrize("e", [0.25, 0.5])
def test_perturbed_formations_hold_and_stay_below_the_worst_case(e):
    p = default_params()
    plan = solve(p.replace(nav_error_m=e))
    assert plan.feasible, plan.message
    assert plan.sigma_h_m < plan.sigma_h_worst_m
    along = math.atan2(math.sin(p.theta0), math.cos(p.theta0))  # n's direction
    slave_side = np.sign(np.array([math.cos(p.theta0), math.sin(p.theta0)])
                         @ (plan.formation[1] - plan.formation[0]))
    adversarial = np.array([along + (math.pi if slave_side < 0 else 0.0)]
                           + [along + (0.0 if slave_side < 0 else math.pi)] * 2)
    held = plan.robust_constraints
    worst_seen = 0.0
    for q in moved(plan.formation, e, np.random.default_rng(29), adversarial):
        ev = evaluate(p, q, plan.p_com_w, plan.scheme)
        assert set(ev.violated) <= {"C2"}, (q, ev.violated)
        for family in SAME_UNIT:
            assert ev.constraints[family].slack >= held[family].slack - 1e-9 * max(
                1.0, abs(held[family].slack)), family
        worst_seen = max(worst_seen, ev.sigma_h)
    assert worst_seen <= plan.sigma_h_worst_m
    assert plan.sigma_h_worst_m <= 1.05 * worst_seen
    assert 0.0 < plan.worst_gap < 1.0
    nominal = solve(p)
    assert nominal.sigma_h_m * (1 - 1e-4) <= plan.worst_lower_bound_m <= plan.sigma_h_worst_m


def test_zero_error_is_the_nominal_plan():
    p = default_params()
    assert robust.tightened(p, "proposed") is p
    plan = solve(p)
    direct = backend("global")(p, "proposed", "exact")
    assert plan.formation.tobytes() == direct.formation.tobytes()
    assert plan.p_com_w.tobytes() == direct.p_com.tobytes()
    assert plan.sigma_h_worst_m == plan.sigma_h_m and not plan.robust_constraints
    assert math.isnan(plan.worst_gap)
    # power.py's e = 0 path: the least schedule at the planned point and the nominal disk
    x, z = plan.formation[1]
    d = np.sqrt((x - p.ground_station[0]) ** 2 + (p.y_track - p.ground_station[1]) ** 2
                + (z - p.ground_station[2]) ** 2)
    cost = power.rate_cost(p, 1, "proposed")
    np.testing.assert_allclose(power.power_schedule(p, 1, x, z, "proposed"), cost * d**2,
                               rtol=1e-12)
    shrunk = p.replace(nav_error_m=0.5)
    assert math.sqrt(power.station_radius_sq(shrunk, 1, "proposed")) == pytest.approx(
        math.sqrt(power.station_radius_sq(p, 1, "proposed")) - 0.5)


def test_worst_case_bound_brackets_the_rim_search():
    p = default_params().replace(nav_error_m=0.25)
    plan = solve(p)
    worst = worst_sigma(p, plan.formation, plan.scheme)
    assert worst.achieved <= worst.upper <= worst.achieved * 1.01
    assert worst_sigma(p.replace(nav_error_m=0.0), plan.formation, plan.scheme).upper == (
        pytest.approx(evaluate(p, plan.formation, plan.p_com_w, plan.scheme).sigma_h))


def test_robust_slacks_run_once_per_plan_of_the_search(monkeypatch):
    """robust_slacks checks each plan of the floor search and the built formation once
    (robust.py) and the chosen
    plan's slacks are those, not computed again by solver.robust_plan."""
    import uav_insar_planner.solver as solver_package
    from uav_insar_planner.solver import worst_case

    tightenings, checked, plans = [], [], []
    real_tightened, real_backend = robust.tightened, solver_package.backend

    def tightened(*args, **kwargs):
        tightenings.append(real_tightened(*args, **kwargs))
        return tightenings[-1]

    def counted_backend(name):
        run = real_backend(name)

        def counted(q, *args, **kwargs):
            res = run(q, *args, **kwargs)
            if res.feasible and any(q is t for t in tightenings):
                plans.append(res)
            return res
        return counted

    def spy(*args, **kwargs):
        checked.append(args)
        return robust_slacks(*args, **kwargs)

    real_search = robust.robust_search.search

    def search(*args):
        built = real_search(*args)
        if built is not None:  # the formation built for its worst case is checked once too
            plans.append(built)
        return built

    monkeypatch.setattr(robust.robust_search, "search", search)
    monkeypatch.setattr(robust, "tightened", tightened)
    monkeypatch.setattr(solver_package, "backend", counted_backend)
    for module in (robust, worst_case, solver_package):
        monkeypatch.setattr(module, "robust_slacks", spy, raising=False)
    p = default_params().replace(nav_error_m=0.25)
    plan = solve(p)
    assert plan.feasible, plan.message
    assert plans and len(checked) == len(plans)
    assert plan.robust_constraints == robust_slacks(p, plan.formation, plan.p_com_w, plan.scheme)


def test_large_error_is_proved_infeasible_naming_the_constraints():
    plan = solve(default_params().replace(nav_error_m=30.0))
    assert not plan.feasible
    assert {"C1", "C4"} <= set(plan.blocking_constraints)
    assert plan.worst_certificate.startswith("robust problem infeasible")
    assert "within 30 m" in plan.message and "C1" in plan.message


def test_robust_slacks_fail_where_the_error_breaks_a_nominal_plan():
    p = default_params()
    plan = solve(p)  # C4, C8 and C10 active: any error breaks them
    held = robust_slacks(p.replace(nav_error_m=0.1), plan.formation, plan.p_com_w, plan.scheme)
    assert {"C4", "C8", "C10"} <= {n for n, c in held.items() if not c.ok}
    assert held["C4"].slack == pytest.approx(plan.constraints["C4"].slack - 0.2)


@pytest.mark.parametrize("b", [b for b in BACKENDS if b.nominal_only], ids=lambda b: b.name)
def test_backends_without_it_refuse_in_one_line(b):
    with pytest.raises(ParamError) as err:
        default_params().replace(nav_error_m=0.5, solver=b.name)
    line = str(err.value)
    assert "\n" not in line and line.startswith("nav_error_m: value 0.5 is not allowed")
    assert b.nominal_only in line
    with pytest.raises(ParamError):
        solve(default_params().replace(nav_error_m=0.5), solver=b.name)


@pytest.mark.parametrize("value", [-0.1, 101.0, float("nan"), "1", True])
def test_bad_values_are_one_line(value):
    with pytest.raises(ParamError) as err:
        default_params().replace(nav_error_m=value)
    assert len(err.value.problems) == 1
    assert err.value.problems[0].startswith("nav_error_m: value ")
    assert "[0, 100]" in err.value.problems[0]


def test_cli_json_and_text_show_both_figures():
    cli = [sys.executable, "-m", "uav_insar_planner.cli", "solve", "--set", "nav_error_m=0.25"]
    out = json.loads(subprocess.run([*cli, "--json"], capture_output=True, text=True,
                                    timeout=120, check=True).stdout)
    assert out["nav_error_m"] == 0.25 and out["sigma_h_worst_m"] > out["sigma_h_m"]
    assert out["worst_gap"] > 0 and all(c["ok"] for c in out["robust_constraints"].values())
    text = subprocess.run(cli, capture_output=True, text=True, timeout=120, check=True).stdout
    assert f"worst case, nav error 0.25 m = {out['sigma_h_worst_m']:.6f} m" in text


SCENARIOS = {
    "table I": {},
    "three slaves": {"num_uavs": 4, "rate_min_mbps": [10, 16.95, 1, 1]},
    "ladder 1.25": {"num_uavs": 4, "rate_min_mbps": [10, 16.95, 1, 1], "h_amb_ratio": 1.25},
    "figure 3": {"master_fixed_xz_m": [-54.0, 74.0]},
}


@pytest.mark.parametrize("scheme", ["proposed", "fixed-master", "static-power",
                                    "single-baseline"])
@pytest.mark.parametrize("name", list(SCENARIOS))
def test_every_optimum_of_the_tightening_is_robust(name, scheme):
    """The tightening is certified, not checked afterwards: the back end's optimum of the
    tightened problem, which sits on its active constraints, keeps every family over the disks
    for e from 0.1 to 1 m and master-range floors from none to 1.4 times the least range."""
    run = backend("global")
    solved = 0
    for e in (0.1, 0.5, 1.0):
        p = default_params().replace(nav_error_m=e, **SCENARIOS[name])
        for floor in (0.0, 80.0, 95.0):
            res = run(robust.tightened(p, scheme, floor), scheme, "exact")
            if not res.feasible:
                continue
            solved += 1
            held = robust_slacks(p, res.formation, res.p_com, scheme)
            assert all(c.ok for c in held.values()), (e, floor, held)
    assert solved >= 2


def test_sweep_band_refuses_a_navigation_error_before_any_solve():
    cli = [sys.executable, "-m", "uav_insar_planner.cli", "sweep", "nav_error_m", "0", "0.5",
           "2", "--band", "--schemes", "proposed"]
    proc = subprocess.run(cli, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and not proc.stdout
    assert proc.stderr.strip() == (
        "uav-insar: error: --band: not allowed with nav_error_m 0.5; expected nav_error_m 0 "
        "(the band spreads sigma_h over the nominal bound's minimisers, a study of the nominal "
        "problem)")


def test_a_sweep_of_the_error_gains_the_worst_case_column(tmp_path):
    from uav_insar_planner.study.sweep import csv_fields, run_sweep, write_csv

    rows = run_sweep(default_params(), "nav_error_m", [0.0, 0.25], ["proposed"])
    assert rows[0].sigma_h_worst_m == rows[0].sigma_h_m
    assert rows[1].sigma_h_worst_m == solve(default_params().replace(
        nav_error_m=0.25)).sigma_h_worst_m > rows[1].sigma_h_m
    write_csv(rows, tmp_path / "s.csv", "nav_error_m")
    assert "sigma_h_worst_m" in (tmp_path / "s.csv").read_text().splitlines()[1].split(",")
    nominal = run_sweep(default_params(), "h_amb_min_m", [1.2], ["proposed"])
    assert "sigma_h_worst_m" not in csv_fields(nominal)
