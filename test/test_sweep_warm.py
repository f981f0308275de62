"""Warm starts along a sweep (solver/global_opt/warm.py): the same certified answers as cold
solves, and nothing carried is used without its re-check at the new point."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.solver import blocking, new_warm_start, power, solve
from uav_insar_planner.solver.global_opt import (
    angle_domain,
    branch_bound,
    infeasibility,
    local_refine,
    optimum,
    slave_sets,
    warm,
)
from uav_insar_planner.solver.problem import make_problem
from uav_insar_planner.study.sweep import run_sweep

FIG3 = {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}
FIG4 = {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}


def _rate(p, value: float):
    items = list(p.raw["rate_min_mbps"])
    items[1] = value
    return p.replace(rate_min_mbps=items)


@pytest.mark.parametrize("scheme", ["proposed", "fixed-master"])
def test_a_warm_sweep_gives_the_cold_sigma_h_and_uses_what_it_carries(scheme: str) -> None:
    base = default_params().replace(**FIG3)
    state = new_warm_start("global")
    used = []
    for h in (1.0, 1.1, 1.2, 1.3):
        p = base.replace(h_amb_min_m=h)
        hot = solve(p, scheme=scheme, objective="exact", solver="global", warm_start=state)
        used.append(state.used_incumbent or state.used_leaves)
        cold = solve(p, scheme=scheme, objective="exact", solver="global")
        assert hot.feasible and cold.feasible
        assert hot.optimality_gap <= 1e-4 and "incomplete" not in hot.message
        # both certified: each sigma_h within the gap of the other's lower bound
        assert hot.sigma_h_m <= cold.lower_bound_m / (1.0 - 1e-4)
        assert cold.sigma_h_m <= hot.lower_bound_m / (1.0 - 1e-4)
        assert hot.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
    assert used == [False, True, True, True]  # the first point has nothing to start from


def test_the_sweep_runner_gives_the_cold_rows_through_an_infeasible_stretch() -> None:
    """Figure 4's top: feasible, then infeasible points; the blocking sets are the cold ones
    (the carried irreducible set and witnesses only save trials)."""
    base = default_params().replace(**FIG4)
    values = [16.5, 17.0, 17.5, 18.0]
    ticks = []
    rows = run_sweep(base, "rate_min_mbps[1]", values, ["single-baseline", "static-power"],
                     objective="exact", solver="global", progress=lambda: ticks.append(1))
    assert len(ticks) == 8  # once per solve, though a task is a chain of solves
    for row in rows:
        cold = solve(_rate(base, row.value), scheme=row.scheme, objective="exact",
                     solver="global")
        assert row.feasible == cold.feasible
        assert row.blocking == " ".join(cold.blocking_constraints)
        if row.feasible:
            assert row.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
    assert [r.feasible for r in rows] == [True, True, True, True, False, False, False, False]


def test_a_carried_point_infeasible_at_the_new_point_is_not_the_incumbent() -> None:
    """The optimum at h_amb_min 0.5 m has baselines far too long for 2 m (C8 at every slave
    range its angles allow): the independent checker agrees, and the warm solve does not take
    it, yet returns the cold answer."""
    base = default_params().replace(**FIG3)
    state = new_warm_start("global")
    solve(base.replace(h_amb_min_m=0.5), scheme="proposed", objective="exact", solver="global",
          warm_start=state)
    carried = state.point
    p = base.replace(h_amb_min_m=2.0)
    sc = make_problem(p, "proposed", "exact")
    q = optimum.formation_of(sc, carried)
    assert not evaluate(p, q, power.schedules(p, q, "proposed"), "proposed").feasible
    assert optimum.warm_incumbent(p, sc, state) is None
    hot = solve(p, scheme="proposed", objective="exact", solver="global", warm_start=state)
    assert not state.used_incumbent
    cold = solve(p, scheme="proposed", objective="exact", solver="global")
    assert hot.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
    assert hot.optimality_gap <= 1e-4


def test_carried_boxes_that_do_not_cover_the_new_domain_are_dropped() -> None:
    """Boxes of a narrower look-angle domain (C3's theta_max lowered) cannot start a search over a
    wider one; the other way round they are cut to it."""
    base = default_params()
    narrow = make_problem(base.replace(slave_look_angle_max_deg=44.0), "proposed", "exact")
    wide = make_problem(base, "proposed", "exact")
    assert wide.th_hi > narrow.th_hi
    for sc_from, sc_to, usable in ((narrow, wide, False), (wide, narrow, True)):
        state = warm.WarmStart()
        leaves = np.array([[sc_from.r0_lo, sc_from.r0_hi] + [sc_from.th_lo, sc_from.th_hi] * 2])
        state.leaves, state.domain = leaves, warm.domain_of(sc_from)
        boxes, bounds = warm.start_boxes(sc_to, state)
        assert (boxes is not None) == usable and bounds is None  # no bounds carried
        if usable:
            assert boxes[0, 3] == sc_to.th_hi and boxes[0, 1] == sc_to.r0_hi


def test_a_carried_point_the_independent_checker_rejects_is_not_the_incumbent(monkeypatch) -> None:
    """Fault injected: the checker (evaluate.py) made to reject every formation, so the ray
    model's acceptance alone must not make the carried point the incumbent."""
    base = default_params().replace(**FIG4)
    state = new_warm_start("global")
    solve(_rate(base, 12.0), scheme="proposed", objective="exact", solver="global",
          warm_start=state)
    p = _rate(base, 12.5)
    sc = make_problem(p, "proposed", "exact")
    assert optimum.warm_incumbent(p, sc, state) is not None

    class Rejected:
        feasible = False

    monkeypatch.setattr(optimum, "evaluate", lambda *args, **kw: Rejected())
    assert optimum.warm_incumbent(p, sc, state) is None


def _fig3(h: float):
    return default_params().replace(**FIG3, h_amb_min_m=h)


def test_only_a_raised_h_amb_min_or_rate_min_restricts_the_problem() -> None:
    state = warm.WarmStart()
    warm.remember(state, make_problem(_fig3(1.0), "proposed", "exact"), None, None)

    def restricts(p, scheme="proposed", objective="exact"):
        return warm.restricts(state, make_problem(p, scheme, objective))

    assert restricts(_fig3(1.1))
    assert restricts(_rate(_fig3(1.0), 17.0))  # R_min,1 16.95 -> 17 Mbit/s
    assert not restricts(_fig3(0.9))  # C8 relaxed
    assert not restricts(_rate(_fig3(1.0), 16.0))
    assert not restricts(_fig3(1.1).replace(d_min_m=2.0))  # not declared
    # another scheme or objective is another problem, however the parameters move
    assert not restricts(_fig3(1.1), scheme="static-power")
    assert not restricts(_fig3(1.1), objective="bound")


def test_carried_bounds_hold_at_a_restricted_point_and_are_dropped_at_a_relaxed_one() -> None:
    """Every carried bound is at most the objective at feasible points sampled in its box at
    the tighter point (the carried bounds are proven there, not merely plausible), and the
    boxes proven empty before, which are not carried, hold no feasible point there; a relaxed
    point (h_amb_min lowered) after that gets no boxes (they no longer cover its domain), and
    both solves give the cold answer."""
    state = new_warm_start("global")
    solve(_fig3(1.2), scheme="proposed", objective="exact", solver="global", warm_start=state)
    sc = make_problem(_fig3(1.3), "proposed", "exact")
    boxes, bounds = warm.start_boxes(sc, state, warm.restricts(state, sc))
    assert bounds is not None and np.all(np.isfinite(bounds))
    empty = state.leaves[np.isinf(state.leaf_lb)]
    assert len(empty) and len(boxes) + len(empty) == len(state.leaves)
    rng = np.random.default_rng(7)
    for cut, lower in ((boxes, bounds), (empty, np.inf)):
        for _ in range(40):
            u = rng.random(cut.shape[0] * 3).reshape(3, -1, 1)
            pts = cut[:, 0::2] + (cut[:, 1::2] - cut[:, 0::2]) * np.concatenate(
                [u[0], u[1], u[2]], axis=1)
            f, _ = slave_sets.ranges_for(sc, pts[:, 0], pts[:, 1:])
            assert np.all(f >= lower * (1.0 - 1e-12))
    for h in (1.3, 1.0):  # tighter, then looser than the point before
        p = _fig3(h)
        if h == 1.0:
            assert state.partial and warm.start_boxes(
                make_problem(p, "proposed", "exact"), state) == (None, None)
        hot = solve(p, scheme="proposed", objective="exact", solver="global", warm_start=state)
        cold = solve(p, scheme="proposed", objective="exact", solver="global")
        assert hot.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
        assert hot.optimality_gap <= 1e-4


def test_a_proven_infeasibility_is_carried_up_a_tightening_sweep_and_not_down() -> None:
    """Figure 4: infeasible from R_min,1 = 17.5 Mbit/s. At 18 the previous proof holds (a
    tighter point) and the blocking set is the cold one; back at 17 (looser) it must not."""
    base = default_params().replace(**FIG4)
    state = new_warm_start("global")
    for value, feasible, carried in ((17.5, False, False), (18.0, False, True),
                                     (17.0, True, False)):
        p = _rate(base, value)
        hot = solve(p, scheme="fixed-master", objective="exact", solver="global",
                    warm_start=state)
        cold = solve(p, scheme="fixed-master", objective="exact", solver="global")
        assert hot.feasible == cold.feasible == feasible
        assert hot.blocking_constraints == cold.blocking_constraints
        assert ("previous sweep point" in hot.certificate) == carried


def _inside(angles: np.ndarray, outer: np.ndarray) -> bool:
    """Does the union of intervals `outer` cover every interval of `angles`?"""
    return all(any(a >= lo and b <= hi for lo, hi in outer) for a, b in angles)


@pytest.mark.parametrize("scheme, before, tighter", [
    ("static-power", _fig3(0.5), _fig3(0.6)),
    ("static-power", _rate(default_params().replace(**FIG4), 17.0),
     _rate(default_params().replace(**FIG4), 17.5))])  # the first infeasible point
# (Figure 4's fixed-master points at 16.5-17 Mbit/s ground here too until boxes were cut at
# the C5/C8 crossing, angle_domain.clip_to_cap; they now close without the angles.)
def test_feasible_angles_carry_up_a_tightening_sweep_and_hold_there(scheme, before,
                                                                    tighter) -> None:
    """These searches prove the slaves' feasible angles (they grind along a slave's
    feasibility edge). At a tighter point (h_amb_min raised, or R_min,1 raised: a smaller
    station disk) those angles contain that point's own, which is what makes cutting its
    boxes to them sound; its answer is the cold one."""
    state = new_warm_start("global")
    solve(before, scheme=scheme, objective="exact", solver="global", warm_start=state)
    carried = state.angles
    assert carried is not None
    sc = make_problem(tighter, scheme, "exact")
    assert warm.restricts(state, sc)
    own = angle_domain.feasible_angles(sc)
    assert all(_inside(a, c) for a, c in zip(own, carried, strict=True))
    hot = solve(tighter, scheme=scheme, objective="exact", solver="global",
                warm_start=state)
    cold = solve(tighter, scheme=scheme, objective="exact", solver="global")
    assert hot.feasible == cold.feasible
    assert hot.blocking_constraints == cold.blocking_constraints
    if cold.feasible:
        assert hot.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
        assert hot.optimality_gap <= 1e-4


def test_an_optimum_the_tighter_point_still_accepts_is_kept_as_it_is() -> None:
    """Figure 4 from R_min,1 12 to 12.5 Mbit/s: C10 is not active at the optimum, which stays
    feasible, and so optimal (the previous bound holds). It is kept without Newton's method,
    and the warm solve gives the cold answer. At Figure 3's raised h_amb_min the optimum sits
    on C8 and breaks it, and is not kept."""
    base = default_params().replace(**FIG4)
    state = new_warm_start("global")
    solve(_rate(base, 12.0), scheme="proposed", objective="exact", solver="global",
          warm_start=state)
    sc = make_problem(_rate(base, 12.5), "proposed", "exact")
    kept = optimum._kept(sc, state.point)
    assert kept is not None
    hot = solve(_rate(base, 12.5), scheme="proposed", objective="exact", solver="global",
                warm_start=state)
    cold = solve(_rate(base, 12.5), scheme="proposed", objective="exact", solver="global")
    assert hot.sigma_h_m == pytest.approx(kept[0], rel=1e-12)
    assert hot.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
    assert hot.optimality_gap <= 1e-4

    solve(_fig3(1.2), scheme="proposed", objective="exact", solver="global", warm_start=state)
    assert optimum._kept(make_problem(_fig3(1.3), "proposed", "exact"), state.point) is None


def test_the_previous_vertex_is_followed_to_the_next_point_without_slsqp() -> None:
    """The optimum at h_amb_min 1.2 m, carried to 1.3 m by Newton on its active constraints
    (local_refine.follow), is a KKT point there with the cold solve's sigma_h."""
    state = new_warm_start("global")
    solve(_fig3(1.2), scheme="fixed-master", objective="exact", solver="global",
          warm_start=state)
    sc = make_problem(_fig3(1.3), "fixed-master", "exact")
    followed = local_refine.follow(state.problem, sc, state.point)
    assert followed is not None and followed[1] != state.point
    assert local_refine.at_kkt(sc, followed[1])
    cold = solve(_fig3(1.3), scheme="fixed-master", objective="exact", solver="global")
    assert followed[0] == pytest.approx(cold.sigma_h_m, rel=1e-9)


@pytest.mark.parametrize("scheme", ["proposed", "single-baseline"])
def test_the_last_optimum_decides_the_next_points_relaxations_that_drop_c10(
        scheme: str, monkeypatch) -> None:
    """Figure 4, 17 then 17.5 Mbit/s (the first infeasible point): R_min,1 only shrank slave
    1's station disk, so the optimum at 17, carried, is a feasible point of each relaxation
    without C10 at 17.5, found without a search and meeting every family the relaxation keeps
    as the independent checker sees it; it decides nothing that keeps the new disk."""
    base = default_params().replace(**FIG4)
    state = new_warm_start("global")
    assert solve(_rate(base, 17.0), scheme=scheme, objective="exact", solver="global",
                 warm_start=state).feasible
    assert state.witnesses[frozenset()] == state.point
    p, seen, searches = _rate(base, 17.5), dict(state.witnesses), []

    def counted(*args, search=branch_bound.search, **kw):
        searches.append(1)
        return search(*args, **kw)

    monkeypatch.setattr(branch_bound, "search", counted)
    off = frozenset({"C10", "C11"})
    assert infeasibility.feasible_without(p, scheme, off, witnesses=seen) and not searches
    q = optimum.formation_of(make_problem(p, scheme, "exact", off), seen[off])
    ev = evaluate(p, q, power.schedules(p, q, scheme), scheme)
    assert all(ev.constraints[c].ok for c in blocking.FAMILIES if c not in ("C9", "C10", "C11"))
    assert not ev.constraints["C10"].ok or not ev.constraints["C9"].ok  # (P) is infeasible
    assert infeasibility.feasible_without(p, scheme, frozenset({"C3"}), witnesses=seen)
    assert searches  # the carried point is outside the new disk: a search found one


@pytest.mark.parametrize("scheme", ["proposed", "single-baseline"])
def test_an_optimum_sliding_along_its_c8_line_is_followed_as_slsqp_finds_it(scheme) -> None:
    """At h_amb_min 0.5 m the optimum has one free direction (the master at its lowest range,
    the slaves on their C8 lines, d_min apart where two fly): follow slides along it to a KKT
    point at 0.6 m (local_refine._slide), which SLSQP from the same point (the path it
    replaces) and the cold solve agree with; one constraint fewer is refused."""
    state = new_warm_start("global")
    solve(_fig3(0.5), scheme=scheme, objective="exact", solver="global", warm_start=state)
    before, sc = state.problem, make_problem(_fig3(0.6), scheme, "exact")
    followed = local_refine.follow(before, sc, state.point)
    assert followed is not None and local_refine.at_kkt(sc, followed[1])
    r0, th = state.point[0], np.array(state.point[1])
    value, ranges = slave_sets.ranges_for(sc, np.array([r0]), th[None])  # warm_incumbent's
    start = (r0, tuple(map(float, th)), tuple(map(float, ranges[0])))
    slsqp = local_refine.refine(sc, start, float(value[0]))
    assert slsqp[2] and followed[0] == pytest.approx(slsqp[0], rel=1e-11)
    cold = solve(_fig3(0.6), scheme=scheme, objective="exact", solver="global")
    assert cold.lower_bound_m <= followed[0] <= cold.sigma_h_m * (1.0 + 1e-11)
    loose = make_problem(_fig3(0.3), scheme, "exact")  # C8 slack there: more than one free
    assert local_refine.follow(loose, sc, state.point) is None


def test_the_fallback_start_is_asked_once_and_only_when_box_centres_find_nothing(
        monkeypatch) -> None:
    """A warm search without an incumbent tries the box centres first and asks its fallback
    (the chain's SLSQP start) only after FALLBACK_ROUNDS rounds without a feasible point.
    Table I's centres find one at once; with every centre made infeasible (a fault injected
    into branch_bound._incumbent, which the search then never fills) the fallback's point is
    the plan, certified as a cold solve's."""
    sc = make_problem(default_params(), "proposed", "exact")
    cold = optimum.solve_global(default_params(), "proposed", "exact")
    asked: list[int] = []

    def fallback():
        asked.append(1)
        got = optimum._landed_start(sc, None)
        return None if got is None else got[:2]

    res = branch_bound.search(sc, rel_gap=optimum.REL_GAP, fallback=fallback)
    assert not asked and res.exhausted
    monkeypatch.setattr(branch_bound, "_incumbent", lambda sc, boxes: (np.inf, None))
    res = branch_bound.search(sc, rel_gap=optimum.REL_GAP, fallback=fallback)
    assert asked == [1] and res.exhausted and res.point is not None
    # the same optimum as the cold solve, to the certified gaps
    assert cold.lower_bound * (1 - 1e-12) <= res.value <= cold.lower_bound / (1 - 1e-4)
    assert (res.value - res.lower_bound) / res.value <= 1e-4
