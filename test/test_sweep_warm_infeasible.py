"""Infeasible points along a warm sweep (infeasibility.Held, warm.held_here): the irreducible set
and the relaxations that make a point feasible are the cold solve's at every point, and what a
step carries unchecked is feasible indeed."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.params import SCHEMES, default_params
from uav_insar_planner.solver import blocking, new_warm_start, solve
from uav_insar_planner.solver.global_opt import branch_bound, infeasibility, local_refine, warm
from uav_insar_planner.solver.problem import make_problem

FIG4 = {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}


def _at(base, rate: float, h_amb: float):
    items = list(base.raw["rate_min_mbps"])
    items[1] = rate
    return base.replace(rate_min_mbps=items, h_amb_min_m=h_amb)


def _sweep(seed: int):
    """(scheme, base, points): a random tightening sweep near Figure 4's feasibility edge;
    each step raises R_min,1, h_amb_min or both (the swept family C10, C8 or both)."""
    rng = np.random.default_rng(seed)
    base = default_params().replace(master_fixed_xz_m=FIG4["master_fixed_xz_m"],
                                    d_min_m=float(rng.uniform(1.0, 3.0)),
                                    p_com_max_db=float(9.0 + rng.uniform(-1.0, 1.0)))
    rate, h_amb, points = float(rng.uniform(14.0, 17.0)), float(rng.uniform(0.8, 1.5)), []
    for _ in range(9):
        which = rng.integers(3)
        rate += float(rng.uniform(0.2, 1.5)) if which != 1 else 0.0
        h_amb += float(rng.uniform(0.5, 8.0)) if which != 0 else 0.0
        points.append((rate, h_amb))
    return SCHEMES[seed % len(SCHEMES)], base, points


def test_random_tightening_sweeps_name_the_cold_sets_at_every_infeasible_point() -> None:
    """Warm and cold give the same irreducible set and the same single relaxations (the whole
    message) at every point, through points where that list changes and steps that raise
    h_amb_min, R_min or both."""
    infeasible = changed = 0
    for seed in range(8):
        scheme, base, points = _sweep(seed)
        state, before = new_warm_start("global"), None
        for rate, h_amb in points:
            p = _at(base, rate, h_amb)
            hot = solve(p, scheme=scheme, objective="exact", solver="global", warm_start=state)
            cold = solve(p, scheme=scheme, objective="exact", solver="global")
            where = f"seed {seed} {scheme} R_min {rate:.3f} h_amb {h_amb:.3f}"
            assert hot.feasible == cold.feasible, where
            assert hot.message == cold.message, where
            assert hot.blocking_constraints == cold.blocking_constraints, where
            if not hot.feasible:
                infeasible += 1
                changed += before is not None and before != hot.message
                before = hot.message
    assert infeasible >= 20 and changed >= 2  # the sweeps cross edges, not only sit past them


@pytest.mark.parametrize("scheme", ["proposed", "static-power"])
def test_what_a_step_holds_feasible_unchecked_is_feasible(scheme: str) -> None:
    """After each point of a sweep that raises R_min, then h_amb_min, then both, every
    relaxation warm.held_here carries to the next point without a test is feasible there by a
    cold search; a step down carries nothing."""
    base = default_params().replace(**FIG4)
    state = new_warm_start("global")
    steps = [(16.5, 1.0), (17.5, 1.0), (18.5, 1.0), (18.5, 6.0), (19.5, 12.0), (20.5, 12.0)]
    seen = 0
    for (rate, h_amb), (rate_next, h_next) in zip(steps, steps[1:], strict=False):
        solve(_at(base, rate, h_amb), scheme=scheme, objective="exact", solver="global",
              warm_start=state)
        p = _at(base, rate_next, h_next)
        held = warm.held_here(state, make_problem(p, scheme, "exact"))
        swept = {"C10"} if h_next == h_amb else {"C8"} if rate_next == rate else {"C8", "C10"}
        assert held and all(swept <= off for off in held)
        for off in held:
            seen += 1
            assert infeasibility.feasible_without(p, scheme, off), (rate_next, h_next, off)
    assert seen >= len(steps) - 1
    assert not warm.held_here(state, make_problem(_at(base, 17.0, 12.0), scheme, "exact"))


def test_a_carried_point_whose_relaxations_stand_needs_no_search(monkeypatch) -> None:
    """Figure 4, proposed, 18 -> 18.5 Mbit/s (C3 + C5 + C9 + C10, each alone a fix at both):
    the carried proof, the relaxation without C10 held and the other witnesses accepted as
    they stand settle the point: no branch and bound and no inner solve."""
    base = default_params().replace(**FIG4)
    state = new_warm_start("global")
    for rate in (17.0, 17.5, 18.0):
        solve(_at(base, rate, 1.0), scheme="proposed", objective="exact", solver="global",
              warm_start=state)
    calls = []

    def spy(name: str, real):
        def called(*args, **kw):
            calls.append(name)
            return real(*args, **kw)
        return called

    monkeypatch.setattr(branch_bound, "search", spy("search", branch_bound.search))
    monkeypatch.setattr(local_refine, "checked", spy("checked", local_refine.checked))
    hot = solve(_at(base, 18.5, 1.0), scheme="proposed", objective="exact", solver="global",
                warm_start=state)
    assert not hot.feasible and "previous sweep point" in hot.certificate
    assert hot.message.endswith("alone makes it feasible: C3, C5, C9, C10") and not calls


def test_a_point_accepted_as_it_stands_is_one_checked_accepts() -> None:
    """local_refine.accepted (checked()'s direct test without its inner solve) never accepts a
    point that local_refine.checked rejects, over random points and relaxations near
    Figure 4's edge, and it does accept some."""
    rng = np.random.default_rng(7)
    p = _at(default_params().replace(**FIG4), 17.5, 1.0)
    accepted = 0
    for _ in range(300):
        off = frozenset(f for f in blocking.FAMILIES if rng.random() < 0.3)
        sc = make_problem(p, str(rng.choice(SCHEMES)), "bound", off)
        th = rng.uniform(sc.th_lo, sc.th_hi, len(sc.slaves))
        r0 = float(rng.uniform(sc.r0_lo, min(sc.r0_hi, 2.0 * sc.r0_lo)))
        ranges = rng.uniform(0.7, 1.3, len(sc.slaves)) * r0
        point = (r0, tuple(th), tuple(ranges))
        with np.errstate(all="ignore"):
            found = local_refine.accepted(sc, point)
            if found is not None:
                accepted += 1
                assert local_refine.checked(sc, np.array([r0, *th, *ranges])) is not None
                assert local_refine.accepted(sc, found) == found
    assert accepted >= 10


def test_first_infeasible_points_guess_from_any_point_and_name_the_cold_set(monkeypatch) -> None:
    """Figure 4's first infeasible point (R_min,1 17.5 after a feasible 17.0) and random edges:
    the one-slave set guessed from a point (infeasibility._grown) is proven empty for (P) by
    its own search, and the filter ends with the cold set whatever the point: the previous
    optimum (a good guess), or points far from it (wrong guesses the filter must widen, or
    give up for its full run)."""
    grown: list = []
    looks: list = []

    def spy(*args, grow=infeasibility._grown):
        grown.append(grow(*args))
        return grown[-1]

    def seen(*args, at=infeasibility._families_at):
        looks.append(at(*args))
        return looks[-1]

    monkeypatch.setattr(infeasibility, "_grown", spy)
    monkeypatch.setattr(infeasibility, "_families_at", seen)
    rng = np.random.default_rng(3)
    base = default_params().replace(**FIG4)
    h_amb = base.raw["h_amb_min_m"]
    cases = [(scheme, _at(base, 17.0, h_amb), _at(base, 17.5, h_amb)) for scheme in SCHEMES]
    cases += [(SCHEMES[i], _at(base, 17.0, h), _at(base, 17.5, h))
              for i, h in enumerate(rng.uniform(0.8, 1.6, len(SCHEMES)))]
    wrong = ran = 0
    for scheme, before, p in cases:
        state = new_warm_start("global")
        if not solve(before, scheme=scheme, objective="exact", solver="global", warm_start=state
                     ).feasible or solve(p, scheme=scheme, solver="global").feasible:
            continue
        cold, ran = infeasibility.irreducible_set(p, scheme), ran + 1
        sc = make_problem(p, scheme, "bound")
        far = (float(rng.uniform(sc.r0_lo, min(sc.r0_hi, 3 * sc.r0_lo + 50))),
               tuple(rng.uniform(0.3, 1.2, len(sc.slaves))),
               tuple(rng.uniform(20.0, 300.0, len(sc.slaves))))
        for point in (state.point, far):
            grown.clear()
            looks.clear()
            alone = infeasibility.one_slave_set(p, scheme, point=point)
            assert grown and alone, (scheme, point)
            off = frozenset(blocking.FAMILIES) - alone
            res = branch_bound.search(make_problem(p, scheme, "bound", off),
                                      stop_when_feasible=True)
            assert res.exhausted and res.point is None, (scheme, alone)
            assert infeasibility.irreducible_set(
                p, scheme, witnesses={frozenset(): point}) == cold, (scheme, point)
            wrong += len(looks) > 1  # the guess had a feasible point: widened
    assert ran >= 6 and wrong >= 1, (ran, wrong)
