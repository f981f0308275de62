"""The metaheuristic baseline back end (solver="evolution"): scipy differential evolution."""
from __future__ import annotations

import math
import sys

import numpy as np
import process_group
import pytest

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import ParamError, default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.evolution.algorithm import solve_evolution

SCHEMES = ("proposed", "single-baseline", "fixed-master", "static-power")


def swarm(num_uavs: int):
    return default_params().replace(num_uavs=num_uavs,
                                    rate_min_mbps=[10, 16.95] + [1] * (num_uavs - 2))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_table_one_plans_pass_the_checker_and_never_beat_the_certified_optimum(scheme):
    p = default_params()
    evo = solve(p, scheme, "exact", "evolution")
    best = solve(p, scheme, "exact", "global")
    assert evo.feasible and evo.solver == "evolution", evo.message
    ev = evaluate(p, evo.formation, evo.p_com_w, scheme)
    assert ev.feasible and ev.sigma_h == pytest.approx(evo.sigma_h_m)
    # the certificate: no feasible plan is below the global lower bound
    assert evo.sigma_h_m >= best.lower_bound_m * (1 - 1e-9)
    assert evo.sigma_h_m <= 1.01 * best.sigma_h_m  # and a useful baseline: within 1 %
    assert math.isnan(evo.lower_bound_m) and "no certificate" in evo.message


def test_bound_objective_is_no_better_than_the_certified_bound_optimum():
    p = default_params()
    evo = solve(p, "proposed", "bound", "evolution")
    best = solve(p, "proposed", "bound", "global")
    assert evo.feasible
    assert evo.sigma_h_bound_m >= best.lower_bound_m * (1 - 1e-9)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_four_slaves_pass_the_checker(scheme):
    p = swarm(5)
    plan = solve(p, scheme, "exact", "evolution")
    assert plan.feasible, plan.message
    assert np.isfinite(plan.formation).all(axis=1).sum() == (2 if scheme == "single-baseline"
                                                             else 5)


def test_deterministic_with_its_seed():
    p = default_params()
    a, b = (solve_evolution(p, "proposed", "exact", seed=3) for _ in range(2))
    assert np.array_equal(a.formation, b.formation) and a.message == b.message
    c = solve_evolution(p, "proposed", "exact", seed=4)
    assert not np.array_equal(a.formation, c.formation)


def test_an_infeasible_scenario_names_families_without_a_proof():
    # 500 m between UAVs: beyond the C6 reach of any slave (the global solver proves it)
    # (the paper's C10: with the rate margin the least violation also strains C6 and C10)
    p = default_params().replace(d_min_m=500, rate_margin=0.0)
    plan = solve(p, "proposed", "exact", "evolution")
    assert not plan.feasible and plan.blocking_constraints == ["C4"]
    assert "not a proof" in plan.message
    assert not solve(p, "proposed", "exact", "global").feasible


def test_multilook_is_refused_in_one_line():
    with pytest.raises(ParamError, match="solver 'evolution'"):
        default_params().replace(objective="multilook", solver="evolution")


def test_cli_solves_with_evolution_and_refuses_a_bad_solver_in_one_line():
    cli = [sys.executable, "-m", "uav_insar_planner.cli", "solve"]
    ok = process_group.run([*cli, "--set", "solver=evolution"], capture_output=True, text=True,
                        timeout=120)
    assert ok.returncode == 0 and "solver evolution: FEASIBLE" in ok.stdout, ok.stderr
    bad = process_group.run([*cli, "--set", "solver=evolutoin"], capture_output=True, text=True,
                         timeout=60)
    lines = bad.stderr.strip().splitlines()
    assert bad.returncode == 2 and len(lines) == 1
    assert "solver: value 'evolutoin' is not allowed" in lines[0] and "evolution" in lines[0]
