"""The certified global solver under a time budget, and swarms of up to ten UAVs.

A search stopped by its budget must still hand back a feasible plan (as the independent
checker sees it) with a proven lower bound, and say that the certificate is incomplete: never
a silent uncertified answer. Ten UAVs with every slave at 1 Mbit/s are certified by the chain
bound (chain_packing.py), and so is Table I's U1 at 16.95 Mbit/s beside them (the bound
relaxes every slave to the loosest disk); the bound is checked at random feasible formations
and against the branch and bound alone.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.solver.global_opt import branch_bound, chain_packing, slave_sets
from uav_insar_planner.solver.global_opt.optimum import REL_GAP, solve_global
from uav_insar_planner.solver.problem import make_problem
from uav_insar_planner.swarm import MAX_UAVS


def swarm(num_uavs: int):
    """Table I with `num_uavs` UAVs, every slave at 1 Mbit/s (the master keeps 10)."""
    return default_params().replace(num_uavs=num_uavs,
                                    rate_min_mbps=[10.0] + [1.0] * (num_uavs - 1))


def test_ten_uavs_are_a_swarm():
    assert MAX_UAVS == 10
    assert swarm(10).num_uavs == 10


@pytest.mark.parametrize("budget_s", [0.0, 0.05])
def test_budget_reached_returns_the_best_feasible_plan_and_its_gap(budget_s):
    p = swarm(10)
    res = solve_global(p, "proposed", "exact", time_budget_s=budget_s)
    ev = evaluate(p, res.formation, res.p_com, "proposed")
    assert res.feasible and ev.feasible, ev.violated
    assert "certificate incomplete: time budget reached" in res.message
    assert "time budget reached" in res.certificate
    assert f"{res.gap:.2g}" in res.message
    # The gap is the proven one: the bound is below the plan's own (independent) sigma_h.
    assert 0.0 < res.gap < 0.05
    assert res.lower_bound <= ev.sigma_h * (1.0 + 1e-9)
    assert math.isclose(res.gap, (ev.sigma_h - res.lower_bound) / ev.sigma_h, rel_tol=1e-6)


def test_a_budget_the_search_does_not_need_changes_nothing():
    p = swarm(3)
    free = solve_global(p, "proposed", "exact")
    timed = solve_global(p, "proposed", "exact", time_budget_s=60.0)
    assert free.message == timed.message == ""
    assert timed.gap <= 1e-4
    assert (timed.formation == free.formation).all()


@pytest.mark.parametrize("u1_mbps", [1.0, 16.95])
def test_ten_uavs_at_1_mbit_are_certified_and_pass_the_independent_check(u1_mbps):
    p = swarm(10).replace(rate_min_mbps=[10.0, u1_mbps] + [1.0] * 8)
    res = solve_global(p, "proposed", "exact")
    ev = evaluate(p, res.formation, res.p_com, "proposed")
    assert res.feasible and ev.feasible, ev.violated
    assert res.message == "" and "all closed" in res.certificate
    assert res.gap <= 1e-4
    assert res.lower_bound <= ev.sigma_h * (1.0 + 1e-9)
    assert math.isclose(res.gap, (ev.sigma_h - res.lower_bound) / ev.sigma_h, rel_tol=1e-6)
    # sigma_h falls as sigma_1 / sqrt(K) at best: nine slaves cannot beat one slave's optimum
    # over three, and the chain loses little to it
    one = solve_global(swarm(2), "proposed", "exact")
    sigma_1 = one.lower_bound / (1.0 - one.gap)
    assert sigma_1 / 3.0 * (1.0 - 1e-4) <= ev.sigma_h <= sigma_1 / 3.0 * 1.01


@pytest.mark.parametrize("num_uavs", [7])
def test_the_chain_bound_agrees_with_the_branch_and_bound(num_uavs):
    sc = make_problem(swarm(num_uavs), "proposed", "exact")
    chained = solve_global(swarm(num_uavs), "proposed", "exact")
    assert "chain packing" in chained.certificate and chained.gap <= 1e-4
    boxes = branch_bound.search(sc, rel_gap=REL_GAP, refine=True)
    assert boxes.exhausted
    # each certificate's lower bound is below the other's plan
    assert chained.lower_bound <= boxes.value * (1.0 + 1e-12)
    assert boxes.lower_bound <= chained.lower_bound / (1.0 - chained.gap) * (1.0 + 1e-12)


def test_the_chain_bound_holds_at_random_feasible_formations():
    rng = np.random.default_rng(7)
    table_i_grown = default_params().replace(num_uavs=7, rate_min_mbps=[10.0, 16.95] + [1.0] * 5)
    for num_uavs, p in ((3, swarm(3)), (6, swarm(6)), (10, swarm(10)), (7, table_i_grown)):
        sc = make_problem(p, "proposed", "exact")
        n = 4000
        r0 = sc.r0_lo + (sc.r0_hi - sc.r0_lo) * rng.random(n) ** 3
        # angles near theta_max, where the optimum's chain is, and anywhere
        th = np.where(rng.random((n, len(sc.slaves))) < 0.7,
                      sc.th_hi - 0.03 * rng.random((n, len(sc.slaves))),
                      rng.uniform(sc.th_lo, sc.th_hi, (n, len(sc.slaves))))
        f, _ = slave_sets.ranges_for(sc, r0, np.sort(th, axis=1))
        feasible = np.flatnonzero(np.isfinite(f))
        assert len(feasible) > 12
        for i in feasible[np.argsort(f[feasible])[:12]]:
            for width in (1e-6, 1e-3, 0.1):
                a = max(sc.r0_lo, r0[i] * (1.0 - width))
                lb = chain_packing.interval_bound(sc, a, r0[i] * (1.0 + width))
                assert lb <= f[i] * (1.0 + 1e-12), (num_uavs, r0[i], width)


def test_the_scenario_budget_reaches_the_solver_and_the_plan_says_so():
    """time_budget_s is a scenario parameter (file, CLI, node): `solve` honours it and the
    plan keeps the honest gap and the incomplete certificate in its message."""
    from uav_insar_planner.solver import solve

    plan = solve(swarm(10).replace(time_budget_s=0.01))
    assert plan.feasible
    assert "certificate incomplete: time budget reached" in plan.message
    assert 0.0 < plan.optimality_gap < 0.05
    assert solve(swarm(10)).optimality_gap <= 1e-4  # 0: no budget, certified


def test_strip_sums_when_no_two_columns_fit_the_gap():
    """A gap wider than the columns leaves room for one strip, never two (this crashed the
    chain bound of a five-UAV fixed-master swarm: below)."""
    w = np.array([1.0, 3.0, 2.0, 0.5, 4.0, 1.0])
    f = chain_packing._strip_sums(w, gap=8, m=3)
    assert f[0] == 0.0 and f[1] == 4.0 and np.all(np.isneginf(f[2:]))
    # two columns at least 3 apart: 3 + 4 (columns 1 and 4); three do not fit
    np.testing.assert_array_equal(chain_packing._strip_sums(w, gap=3, m=3),
                                  [0.0, 4.0, 7.0, -np.inf])


def test_a_five_uav_fixed_master_swarm_whose_chain_strips_outgrow_its_columns():
    """Found by random warm/cold sweeps: d_min 3.32 m, P_com^max 9.28 dB, h_amb_min 0.749 m,
    Figure 4's master. It used to fail in chain_packing._strip_sums (a bug); now it is solved
    and its plan passes the independent check."""
    p = default_params().replace(
        num_uavs=5, rate_min_mbps=[10.0, 16.95, 1.0, 1.0, 1.0], d_min_m=3.3191218004168364,
        p_com_max_db=9.27660995707559, master_fixed_xz_m=[-41.0, 61.0],
        h_amb_min_m=0.7492458568126803)
    res = solve_global(p, "fixed-master", "multilook")
    if res.feasible:
        from uav_insar_planner.solver import power

        assert res.gap <= 1e-4
        assert evaluate(p, res.formation, power.schedules(p, res.formation, "fixed-master"),
                        "fixed-master", "multilook").feasible
    else:
        assert res.blocking


def test_the_rest_refined_heaviest_first_bounds_every_rest_position():
    """chain_packing._refined_rest cuts only the heaviest coarse cells of the rest (|b| below
    the strip) into fine ones: it must give what cutting every coarse cell gives, and bound
    the weight of every feasible slave position there (a slave anywhere on the rest, r0
    anywhere in the interval)."""
    from uav_insar_planner.solver.global_opt import kernel, slave_ranges

    rng = np.random.default_rng(3)
    sc, k = chain_packing.relaxed(make_problem(swarm(6), "proposed", "exact"))
    r0_best = solve_global(swarm(6), "proposed", "exact").formation  # the chain's r0 region
    r0_mid = float(np.hypot(*(r0_best[0] - (sc.p.x_t, 0.0))))
    for width in (1e-3, 0.05):
        r0a, r0b = r0_mid * (1.0 - width), r0_mid * (1.0 + width)
        cap_b = slave_ranges.c8_cap(sc, k) * r0b
        b_top = cap_b - min(chain_packing.STRIP_M, chain_packing.STRIP_FRAC * sc.p.d_min, cap_b)
        lo, up, _, _ = slave_ranges.slave_box(sc, k, r0a, r0b, np.array([sc.th_lo]),
                                              np.array([sc.th_hi]))
        u_lo = lo[0] * np.cos(max(abs(sc.th_lo - sc.th0), abs(sc.th_hi - sc.th0)))
        cols, rows, coarse = chain_packing._rest_cells(sc, k, r0a, r0b, u_lo, up[0], b_top)
        got = chain_packing._refined_rest(sc, k, r0a, r0b, cols, rows, coarse)
        # every coarse cell cut
        n = chain_packing.REST_COARSEN
        fine_u = np.concatenate([np.linspace(a, b, n + 1)[:-1] for a, b in
                                 zip(cols[:-1], cols[1:], strict=True)] + [cols[-1:]])
        fine_b = np.concatenate([np.linspace(a, b, n + 1)[:-1] for a, b in
                                 zip(rows[:-1], rows[1:], strict=True)] + [rows[-1:]])
        every = float(np.max(chain_packing._grid_cells(sc, k, r0a, r0b, fine_u, fine_b)))
        assert got == pytest.approx(every, rel=1e-12)
        assert got <= float(np.max(coarse))
        # positions anywhere in the rest, kept where the ray model allows them
        m = 200_000
        u = rng.uniform(u_lo, up[0], m)
        b = rng.uniform(-b_top, b_top, m)
        r0 = rng.uniform(r0a, r0b, m)
        theta, r = sc.th0 + np.arctan2(b, u), np.hypot(u, b)
        with np.errstate(invalid="ignore"):
            (lo_a, top_a), (lo_b, top_b) = kernel.range_components(sc, k, r0, theta)
            ok = ((theta >= sc.th_lo) & (theta <= sc.th_hi)
                  & (((r >= lo_a) & (r <= top_a)) | ((r >= lo_b) & (r <= top_b))))
        assert ok.sum() > 1000
        w = kernel.slave_weight(sc, r0[ok], theta[ok], r[ok])
        assert float(np.max(w)) <= got * (1.0 + 1e-12)
