"""The C5-floor/C8-ceiling crossing (angle_domain.clip_to_cap): every sampled point of the ray
model that keeps C5 and C8 lies inside its box's cut angles, the cut narrows boxes across the
crossing of Figure 3's static-power slave, and along that chain a warm incumbent moved to the
crossing (optimum._inside_caps) is taken where the previous vertex fell off its ceiling, with
the cold solve's answer."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import new_warm_start, solve
from uav_insar_planner.solver.global_opt import angle_domain, local_refine, slave_ranges
from uav_insar_planner.solver.problem import make_problem

FIG3 = {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}


@pytest.mark.parametrize(("scheme", "h_amb", "crossing"), [
    ("static-power", 1.2, True), ("static-power", 2.0, True), ("proposed", 0.5, False)])
def test_cut_keeps_every_point_that_holds_c5_and_c8(scheme, h_amb, crossing):
    sc = make_problem(default_params().replace(**FIG3, h_amb_min_m=h_amb), scheme, "exact")
    rng = np.random.default_rng(5)
    n = 20000
    ta = rng.uniform(sc.th_lo, sc.th_hi, n)
    tb = np.minimum(sc.th_hi, ta + 10.0 ** rng.uniform(-5, -0.7, n))
    r0a = rng.uniform(sc.r0_lo, sc.r0_hi, n)
    r0b = np.minimum(sc.r0_hi, r0a * (1.0 + 10.0 ** rng.uniform(-5, -0.5, n)))
    caps = np.array([[slave_ranges.c8_cap(sc, k)] for k in sc.slaves])
    ca, cb = angle_domain.clip_to_cap(sc, r0b, ta[None], tb[None], caps)
    th = ta + (tb - ta) * rng.uniform(size=n)
    r0 = r0a + (r0b - r0a) * rng.uniform(size=n)
    floor = sc.p.swath_min * np.cos(th) / sc.p.beamwidth  # C5
    for j, k in enumerate(sc.slaves):
        ceiling = slave_ranges.c8_cap(sc, k) * r0 / np.abs(np.sin(th - sc.th0))  # C8
        held = floor <= ceiling  # some range on the ray keeps both
        assert held.sum() > n // 10
        assert np.all((ca[j] <= th) & (th <= cb[j])
                      | ~held), "a point keeping C5 and C8 was cut away"
    if crossing:  # slave 1's floor and ceiling cross inside its angle domain
        assert np.any(cb[0] - ca[0] < 0.5 * (tb - ta)), "the cut never narrows a box"


def _fig3(h_amb):
    return default_params().replace(**FIG3, h_amb_min_m=h_amb)


def test_vertex_moved_to_the_crossing_is_the_warm_incumbent():
    """At 1.2 m the 1.1 m vertex of the chain (from 1.0 m) has slave 1 on the far side of its
    new C5/C8 crossing, where local_refine.follow fails; moved to the crossing it is feasible,
    used, and the answer is the cold one's."""
    warm = new_warm_start("global")
    for h_amb in (1.0, 1.1):
        solve(_fig3(h_amb), scheme="static-power", objective="exact", solver="global",
              warm_start=warm)
    sc = make_problem(_fig3(1.2), "static-power", "exact")
    assert local_refine.follow(warm.problem, sc, warm.point) is None
    plan = solve(_fig3(1.2), scheme="static-power", objective="exact", solver="global",
                 warm_start=warm)
    cold = solve(_fig3(1.2), scheme="static-power", objective="exact", solver="global")
    assert warm.used_incumbent
    assert plan.feasible and cold.feasible
    # both certified: each sigma_h within the gap of the other's lower bound
    assert plan.sigma_h_m <= cold.lower_bound_m / (1.0 - 1e-4)
    assert cold.sigma_h_m <= plan.lower_bound_m / (1.0 - 1e-4)
