"""The tomographic objective (objective tomography, solver evolution): at N = 5 it beats equal
spacing on ISLR at the same resolution and reports a certified bound that no array of the
relaxation beats (checked by random arrays measured independently of the branch and bound)."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.params import ParamError, default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.tomography.array_factor import tomography_figures
from uav_insar_planner.tomography.bound import certified_bound
from uav_insar_planner.tomography.design import equal_spacing, minimum_redundancy, search


def swarm(n: int, **extra):
    rates = [10.0, 16.95] + [1.0] * (n - 2)
    return default_params().replace(**{"num_uavs": n, "rate_min_mbps": rates,
                                       "objective": "tomography", "solver": "evolution",
                                       **extra})


def test_five_uavs_beat_equal_spacing_and_report_their_bound():
    p = swarm(5)
    plan = solve(p)
    assert plan.feasible, plan.message
    t, obj = plan.metrics["tomography"], plan.metrics["tomography_objective"]
    assert t["resolution_m"] == pytest.approx(p.tomo_resolution_m, rel=1e-6)
    assert t["ambiguity_height_m"] >= p.tomo_ambiguity_min_m
    equal = tomography_figures(equal_spacing(5, 1.0 / p.tomo_resolution_m), p.tomo_height_span_m)
    assert t["islr_db"] < equal.islr_db - 0.5
    assert obj["islr_db"] == pytest.approx(t["islr_db"], abs=1e-6)  # the checker's figure
    assert obj["islr_lower_bound_db"] <= t["islr_db"]
    assert obj["bound_closed"] and obj["gap_db"] <= 0.02
    assert "ISLR >=" in plan.certificate
    assert plan.constraints["C8"].ok and plan.constraints["C8"].detail in ("ambiguity",
                                                                            "resolution")


@pytest.mark.parametrize("n", [4, 5])
def test_no_random_array_beats_the_certified_bound(n):
    """Arrays drawn at random (and the uniform and minimum-redundancy ones) that meet the
    ambiguity: none has an ISLR below the bound proven with the search's incumbent."""
    span, amb = 2.5, 2.5
    best = search(n, 1.0, span, amb)[0].figures.islr_db
    bound = certified_bound(n, 1.0, span, amb, incumbent_db=best, budget_s=30.0)
    assert bound.closed and bound.islr_db is not None
    rng = np.random.default_rng(n)
    arrays = [np.sort(np.r_[0.0, rng.uniform(0, 1, n - 2), 1.0]) for _ in range(300)]
    arrays += [np.sort(np.r_[0.0, 0.5 + rng.normal(0, 0.2, n - 2).clip(-0.5, 0.5), 1.0])
               for _ in range(300)]  # near-symmetric, as the best arrays are
    arrays += [equal_spacing(n, 1.0), minimum_redundancy(n, 1.0)]
    seen = 0
    for s in arrays:
        f = tomography_figures(s, span)
        if f.islr_db is not None and (f.ambiguity_height_m or np.inf) >= amb:
            seen += 1
            assert f.islr_db >= bound.islr_db - 1e-9, (s, f.islr_db, bound.islr_db)
    assert seen > 20


def test_the_objective_is_the_evolution_back_ends():
    with pytest.raises(ParamError) as err:
        swarm(5, solver="global")
    line = str(err.value)
    assert "objective" in line and "'tomography'" in line and "evolution" in line
    assert len(line.splitlines()) == 1


def test_two_uavs_have_no_tomographic_objective():
    plan = solve(swarm(2))
    assert not plan.feasible and "three or more UAVs" in plan.message
