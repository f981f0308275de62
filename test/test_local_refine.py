"""The local moves of the global solver (solver/global_opt/local_refine.py): each lands where
the search's certificate says the optimum is, and stops once there."""
from __future__ import annotations

import numpy as np

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import new_warm_start, solve
from uav_insar_planner.solver.global_opt import local_refine, slave_sets
from uav_insar_planner.solver.problem import make_problem

FIG4 = {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}


def test_slsqp_stops_at_its_vertex_instead_of_line_searching_in_rounding_noise(
        monkeypatch) -> None:
    """Figure 4's single-baseline point at R_min,1 = 17 Mbit/s from the warm search's
    incumbent (a box centre 2e-4 rad off the optimum, where C6 and the station disk meet):
    SLSQP reaches the vertex within 8 iterations, then its own test (the constraints' summed
    violation below ftol = 1e-12 m, their rounding noise) kept it line-searching there for
    23 more, 99 evaluations in all. Stopped where the iterate stalls, it lands on the cold
    solve's optimum in fewer than 40."""
    items = list(default_params().raw["rate_min_mbps"])
    items[1] = 17.0
    p = default_params().replace(**FIG4, rate_min_mbps=items)
    sc = make_problem(p, "single-baseline", "exact")
    th = np.array([[0.7191063314374215]])
    f, ranges = slave_sets.ranges_for(sc, np.array([sc.r0_lo]), th)
    start = (sc.r0_lo, (float(th[0, 0]),), (float(ranges[0, 0]),))
    calls: list[int] = []

    def counted(sc, v, inner=local_refine._constraints):
        calls.append(len(v))
        return inner(sc, v)

    monkeypatch.setattr(local_refine, "_constraints", counted)
    value, point, landed = local_refine.refine(sc, start, float(f[0]))
    monkeypatch.undo()
    cold = solve(p, scheme="single-baseline", objective="exact", solver="global")
    assert landed and value < f[0]
    assert cold.lower_bound_m <= value <= cold.sigma_h_m * (1.0 + 1e-12)
    assert local_refine.at_kkt(sc, point)
    assert len(calls) < 40


def test_a_followed_vertex_the_ray_model_accepts_as_it_is_needs_no_inner_solve(
        monkeypatch) -> None:
    """Figure 3's fixed-master optimum at h_amb_min 1.2 m followed to 1.3 m: Newton's vertex
    is accepted on the ray model as it is, so follow asks no inner solve at its angles
    (slave_sets.ranges_for), and it is still the cold solve's optimum, at a KKT point."""
    fig3 = default_params().replace(master_fixed_xz_m=[-54.0, 74.0], p_com_max_db=10.1)
    state = new_warm_start("global")
    solve(fig3.replace(h_amb_min_m=1.2), scheme="fixed-master", objective="exact",
          solver="global", warm_start=state)
    sc = make_problem(fig3.replace(h_amb_min_m=1.3), "fixed-master", "exact")
    inner: list[int] = []

    def counted(*args, ranges_for=slave_sets.ranges_for):
        inner.append(1)
        return ranges_for(*args)

    monkeypatch.setattr(slave_sets, "ranges_for", counted)
    followed = local_refine.follow(state.problem, sc, state.point)
    monkeypatch.undo()
    assert followed is not None and not inner
    assert local_refine.at_kkt(sc, followed[1])
    cold = solve(fig3.replace(h_amb_min_m=1.3), scheme="fixed-master", objective="exact",
                 solver="global")
    assert cold.lower_bound_m <= followed[0] <= cold.sigma_h_m * (1.0 + 1e-11)
