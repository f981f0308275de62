"""Certified global solver: certificate, cross-check, symmetry, feasibility edges."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import SCHEMES, default_params
from uav_insar_planner.schemes import static_power_w
from uav_insar_planner.solver import blocking, power, rays, solve
from uav_insar_planner.solver.global_opt import box_splits, branch_bound, infeasibility
from uav_insar_planner.solver.global_opt.kernel import slave_weight
from uav_insar_planner.solver.global_opt.optimum import solve_global
from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.problem import c7_interval, make_problem
from uav_insar_planner.solver.start_grid import find_start
from uav_insar_planner.study.band import bound_minimizer_band

FIG3 = {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}
FIG4 = {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}


def with_rate(p, k, mbps):
    rates = list(p.raw["rate_min_mbps"])
    rates[k] = mbps
    return p.replace(rate_min_mbps=rates)


def sweep_points():
    p3, p4 = default_params().replace(**FIG3), default_params().replace(**FIG4)
    for h in np.linspace(0.5, 2.0, 16):
        yield p3.replace(h_amb_min_m=float(h))
    for r in np.linspace(10.0, 20.0, 21):
        yield with_rate(p4, 1, float(r))


# --- structural claims the solver relies on --------------------------------------------------

def test_c7_interval_and_ray_model():
    p = default_params()
    sc = make_problem(p, "proposed", "exact", frozenset({"C3"}))
    a, b = c7_interval(sc)
    th = np.linspace(-1.5, 1.5, 30001)
    ok = rays.coherence_rg(sc, th) >= p.coherence_rg_min - 1e-12
    assert th[ok].min() == pytest.approx(a, abs=2e-4) and th[ok].max() <= b + 1e-4
    # polar b_perp equals eq. 3 for a master on its ray
    r0, r, t = 70.0, 80.0, 0.7
    x0, z0 = rays.position(sc, r0, p.theta0)
    x1, z1 = rays.position(sc, r, t)
    assert model.perpendicular_baseline(x0, z0, x1, z1, p.theta0) == pytest.approx(
        r * abs(math.sin(t - p.theta0)), rel=1e-12)


def test_weight_increases_with_slave_range():
    p = default_params()
    sc = make_problem(p, "proposed", "exact")
    r = np.linspace(5.0, 400.0, 2000)
    for r0 in (60.0, 90.0, 130.0):
        for t in (0.66, 0.75, 0.84):
            w = slave_weight(sc, r0, t, r)
            assert np.all(np.diff(w) > 0)


# --- certificate ------------------------------------------------------------------------------

def test_certificate_on_sweep_points():
    for p in sweep_points():
        for scheme in SCHEMES:
            plan = solve(p, scheme=scheme, objective="exact", solver="global")
            if not plan.feasible:
                assert plan.blocking_constraints
                continue
            assert plan.lower_bound_m <= plan.sigma_h_m * (1 + 1e-12)
            assert 0.0 <= plan.optimality_gap <= 1e-4


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("objective", ["exact", "bound"])
def test_global_plans_pass_checker_at_defaults(scheme, objective):
    p = default_params()
    res = solve_global(p, scheme, objective)
    ev = evaluate(p, res.formation, res.p_com, scheme)
    assert res.feasible and ev.feasible, ev.violated
    value = ev.sigma_h if objective == "exact" else ev.sigma_h_bound
    assert res.lower_bound <= value * (1 + 1e-12)
    assert (value - res.lower_bound) / value <= 1e-4
    if scheme == "single-baseline":
        assert np.all(np.isnan(res.formation[2])) and not res.p_com[2].any()
    if scheme == "static-power":
        assert np.allclose(res.p_com[[0, 1, 2]], static_power_w(p))


def test_exact_beats_every_bound_minimiser():
    p = default_params()
    for scheme in SCHEMES:
        exact = solve(p, scheme=scheme, objective="exact").sigma_h_m
        bound_plan = solve(p, scheme=scheme, objective="bound")
        lo, hi = bound_minimizer_band(p, scheme)
        assert exact <= bound_plan.sigma_h_m * (1 + 1e-9)
        assert exact <= lo * (1 + 1e-9) and lo <= bound_plan.sigma_h_m * (1 + 1e-3) <= hi * 1.002


def test_boxes_bisected_toward_the_landed_start_still_cover_the_domain():
    """box_splits.toward: the root's boxes holding Table I's optimum bisected 8 times
    toward it cover what the root's boxes covered (the same volume; random points of the
    domain each in some box), and the box holding the optimum is 1/256 of the one before."""
    p = default_params()
    sc = make_problem(p, "proposed", "exact")
    res = branch_bound.search(sc, rel_gap=5e-5)
    point = np.array([res.point[0], *res.point[1]])
    root = branch_bound._root_boxes(sc, branch_bound.interchangeable_pairs(sc), landed=True)
    boxes = box_splits.toward(sc, root, res.point, 8)

    def volume(b):
        return np.prod(b[:, 1::2] - b[:, 0::2], axis=1)

    def holding(b, x):
        return np.all((b[:, 0::2] <= x) & (x <= b[:, 1::2]), axis=1)

    assert len(boxes) == len(root) + 8
    assert volume(boxes).sum() == pytest.approx(volume(root).sum(), rel=1e-12)
    assert volume(boxes[holding(boxes, point)]).max() == pytest.approx(
        volume(root[holding(root, point)]).max() / 256, rel=1e-9)
    lo, hi = root[:, 0::2].min(axis=0), root[:, 1::2].max(axis=0)
    for x in np.random.default_rng(3).uniform(lo, hi, (500, len(lo))):
        assert holding(boxes, x).any()


def test_slave_swap_symmetry():
    """Swapping U1's and U2's rate requirements swaps their roles: same optimum."""
    for p in (default_params(), default_params().replace(h_amb_min_m=2.0),
              with_rate(default_params().replace(**FIG4), 1, 17.5)):
        q = p.replace(rate_min_mbps=[p.raw["rate_min_mbps"][0], p.raw["rate_min_mbps"][2],
                                     p.raw["rate_min_mbps"][1]])
        for scheme in ("proposed", "fixed-master", "static-power"):
            a, b = solve_global(p, scheme, "exact"), solve_global(q, scheme, "exact")
            assert a.feasible == b.feasible
            if a.feasible:
                sa = evaluate(p, a.formation, a.p_com, scheme).sigma_h
                sb = evaluate(q, b.formation, b.p_com, scheme).sigma_h
                assert sa == pytest.approx(sb, rel=1e-7)


def test_feasibility_edge_in_rate():
    """Raise R_min,1 until infeasible: the edge is sharp and the blocking set is right."""
    base = default_params().replace(**FIG4)
    for scheme in ("proposed", "static-power"):
        lo, hi = 10.0, 40.0
        assert solve_global(with_rate(base, 1, lo), scheme, "exact").feasible
        assert not solve_global(with_rate(base, 1, hi), scheme, "exact").feasible
        while hi - lo > 1e-3:
            mid = 0.5 * (lo + hi)
            if solve_global(with_rate(base, 1, mid), scheme, "exact").feasible:
                lo = mid
            else:
                hi = mid
        below = solve(with_rate(base, 1, lo), scheme=scheme)
        assert below.feasible  # and the independent checker agrees
        p_hi = with_rate(base, 1, hi)
        above = solve_global(p_hi, scheme, "exact")
        assert not above.feasible and above.blocking
        # the blocking families cannot hold together, and each is needed for that (an
        # irreducible infeasible set): without all the others no point is found, and
        # dropping any one member as well gives a formation that the independent checker
        # finds meets every remaining blocking family
        others = frozenset(blocking.FAMILIES) - set(above.blocking)
        assert not infeasibility.feasible_without(p_hi, scheme, others)
        for family in above.blocking:
            rest = set(above.blocking) - {family}
            start = find_start(p_hi, scheme, rest | {"C2"}, first=True)
            assert start is not None, family
            q = start.formation
            ev = evaluate(p_hi, q, schedules(p_hi, q, scheme), scheme)
            assert all(ev.constraints[c].ok for c in rest if c not in ("C9", "C10", "C11"))
        # the message names the single relaxations that would help, each proven
        fixes, _ = infeasibility.blocking_sets(p_hi, scheme)
        assert fixes and infeasibility.feasible_without(p_hi, scheme, frozenset(fixes))
        # a local search on the original variables finds no feasible point above the edge
        assert _multistart(p_hi, scheme, 30, seed=3)[0] == math.inf


def test_a_search_near_the_edge_proves_emptiness_from_one_blocked_slave():
    """Figure 4 at 17.5 Mbit/s: slave 1 alone has no feasible position, which the search
    asks once it has no point after branch_bound.PROJECT_AFTER boxes, well before the 20 000
    boxes the whole problem took to get there; at 17 Mbit/s nothing is blocked."""
    base = default_params().replace(**FIG4)
    calls = []
    for rate, blocked in ((17.5, True), (17.0, False)):
        sc = make_problem(with_rate(base, 1, rate), "proposed", "exact")
        alone = [branch_bound.search(replace(sc, slaves=(k,)), stop_when_feasible=True)
                 for k in sc.slaves]
        assert [r.point is None and r.exhausted for r in alone] == [blocked, False]
        calls.append(branch_bound.search(sc))
    assert calls[0].exhausted and calls[0].point is None and calls[0].nodes < 10_000
    assert calls[1].exhausted and calls[1].point is not None


def test_the_one_slave_set_spares_the_filter_its_proofs(monkeypatch):
    """Figure 4's first infeasible point (R_min,1 17.5 Mbit/s): the deletion filter run on one
    slave alone gives a set that (P)'s own search proves empty, and (P)'s filter, starting from
    it, searches only its feasible trials (each decided by a found point), fewer than without
    it, and ends with the same set."""
    p = with_rate(default_params().replace(**FIG4), 1, 17.5)
    for scheme in ("proposed", "fixed-master"):
        alone = infeasibility.one_slave_set(p, scheme)
        assert alone
        sc = make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - alone)
        res = branch_bound.search(sc, stop_when_feasible=True)
        assert res.exhausted and res.point is None
        runs = {}
        for name, one_slave in (("plain", lambda *a: None),
                                ("hinted", infeasibility.one_slave_set)):
            verdicts: list = []

            def spy(*args, log=verdicts, decide=infeasibility.decide_families, **kw):
                log.append(decide(*args, **kw))
                return log[-1]

            monkeypatch.setattr(infeasibility, "decide_families", spy)
            monkeypatch.setattr(infeasibility, "one_slave_set", one_slave)
            runs[name] = (infeasibility.irreducible_set(p, scheme), verdicts)
            monkeypatch.undo()
        (plain, proven), searched = runs["plain"]
        assert proven and runs["hinted"][0] == (plain, True)
        assert frozenset(plain) == alone
        hinted = runs["hinted"][1]
        assert all(ok for ok, _ in hinted) and len(hinted) < len(searched)
        assert sum(not ok for ok, _ in searched) >= 3


def test_infeasible_static_power_names_c9():
    p = default_params().replace(p_com_max_db=5.0)  # 3.2 W < E_max / N = 7.4 W
    res = solve_global(p, "static-power", "exact")
    assert not res.feasible and res.blocking == ["C9"]  # the fixed 7.4 W breaks C9 anywhere


# --- independent multi-start local search on the original variables ------------------------

def _fused_sigma(p, q, slaves):
    gm = model.gamma_m(p)
    bp = p.fractional_bandwidth
    r0 = model.slant_range(q[0, 0], q[0, 1], p.x_t)
    inv = 0.0
    for k in slaves:
        rk = model.slant_range(q[k, 0], q[k, 1], p.x_t)
        g = model.coherence_total(
            model.coherence_baseline(model.chi(p.theta0, model.look_angle(q[k, 0], q[k, 1],
                                                                           p.x_t)), bp),
            model.coherence_snr(model.snr_monostatic(r0, gm), model.snr_bistatic(r0, rk, gm)),
            p.coherence_other)
        b = model.perpendicular_baseline(q[0, 0], q[0, 1], q[k, 0], q[k, 1], p.theta0)
        s = model.height_error(model.height_of_ambiguity(p.wavelength, r0, p.theta0, b),
                               model.phase_error_crb(g, p.looks))
        inv += 1.0 / max(s, 1e-12) ** 2
    return inv ** -0.5 if np.isfinite(inv) else 1e6


def _constraints(p, q, scheme, slaves):
    """C1..C11 as g(x) >= 0 from the model functions (C9-C11 via the cheapest schedule)."""
    gm = model.gamma_m(p)
    bp = p.fractional_bandwidth
    uavs = (0, *slaves)
    out = []
    r0 = model.slant_range(q[0, 0], q[0, 1], p.x_t)
    for k in uavs:
        z = q[k, 1]
        out += [(z - p.z_min) / 10, (p.z_max - z) / 10]
        r = model.slant_range(q[k, 0], z, p.x_t)
        th = p.theta0 if k == 0 else model.look_angle(q[k, 0], z, p.x_t)
        out.append((model.swath_width(r, th, p.beamwidth) - p.swath_min) / 10)
        d = model.distance_to_station(q[k, 0], p.y_track, z, p.ground_station)
        if scheme == "static-power":
            rate = model.fdma_rate(static_power_w(p), d, p.comm_bandwidth_hz, p.beta_c)
            out.append(rate.min() / p.rate_min_bps[k] - 1.0)
            out.append(1.0 - static_power_w(p) / p.p_max_w)
        else:
            sched = model.power_for_rate(p.rate_min_bps[k], d, p.comm_bandwidth_hz, p.beta_c)
            out += [1.0 - sched.max() / p.p_max_w,
                    1.0 - sched.sum() * p.slot_duration_s / p.e_max_j]
        if k:
            out += [th - p.theta_min, p.theta_max - th]
            snrk = model.snr_bistatic(r0, r, gm)
            out.append(model.coherence_snr(model.snr_monostatic(r0, gm), snrk)
                       - p.coherence_snr_min)
            out.append(model.coherence_baseline(model.chi(p.theta0, th), bp)
                       - p.coherence_rg_min)
            b = model.perpendicular_baseline(q[0, 0], q[0, 1], q[k, 0], q[k, 1], p.theta0)
            out.append(p.wavelength * r0 * math.sin(p.theta0) - p.h_amb_min * b)
    for i in uavs:
        for j in uavs:
            if i < j:
                out.append(float(np.sum((q[i] - q[j]) ** 2)) - p.d_min**2)
    return np.array(out, dtype=float)


def _multistart(p, scheme, starts, seed=0):
    """Best exact sigma_h over SLSQP runs from random starts on (x0, z0, x1, z1[, x2, z2]);
    +inf when no run ends at a point the independent checker accepts."""
    rng = np.random.default_rng(seed)
    slaves = (1,) if scheme == "single-baseline" else (1, 2)
    fixed = scheme == "fixed-master"

    def unpack(v):
        q = np.full((3, 2), np.nan)
        q[0] = p.master_fixed if fixed else v[:2]
        rest = v if fixed else v[2:]
        for i, k in enumerate(slaves):
            q[k] = rest[2 * i:2 * i + 2]
        return q

    cons = [{"type": "ineq", "fun": lambda v: _constraints(p, unpack(v), scheme, slaves)}]
    if not fixed:
        cons.append({"type": "eq", "fun": lambda v: v[0] - model.master_x(v[1], p.x_t,
                                                                          p.theta0)})
    best = math.inf
    for _ in range(starts):
        v0 = []
        if not fixed:
            z0 = rng.uniform(20, 100)
            v0 += [float(model.master_x(z0, p.x_t, p.theta0)), z0]
        for _k in slaves:
            v0 += [rng.uniform(-80, 0), rng.uniform(20, 100)]
        with np.errstate(invalid="ignore", divide="ignore"):  # SLSQP probes wild points
            res = minimize(lambda v: _fused_sigma(p, unpack(v), slaves) * 100.0, np.array(v0),
                           method="SLSQP", constraints=cons,
                           options={"maxiter": 200, "ftol": 1e-13})
        q = unpack(res.x)
        ev = evaluate(p, q, power.schedules(p, q, scheme), scheme)
        if ev.feasible and ev.sigma_h < best:
            best = ev.sigma_h
    return best, None


@pytest.mark.slow
@pytest.mark.parametrize("scheme,params", [
    ("proposed", default_params()),
    ("single-baseline", default_params()),
    ("fixed-master", default_params().replace(**FIG3)),
    ("static-power", with_rate(default_params().replace(**FIG4), 1, 17.0)),
    ("proposed", default_params().replace(h_amb_min_m=2.0)),
])
def test_agrees_with_multistart_slsqp(scheme, params):
    res = solve_global(params, scheme, "exact")
    ours = evaluate(params, res.formation, res.p_com, scheme).sigma_h
    theirs, _ = _multistart(params, scheme, 100)
    assert ours <= theirs * (1 + 1e-6)  # never beaten by a local search
    assert theirs <= ours * (1 + 1e-6)  # and the local search reaches it


@pytest.mark.parametrize("num_uavs", [4, 5, 6])
def test_the_bound_minimisers_band_is_sampled_for_more_than_two_slaves(num_uavs):
    """With K > 2 slaves the band spans the C8-tight set (no longer a zero-width point): it
    holds the bound-optimal plan, and the exact optimum is below all of it."""
    p = default_params().replace(num_uavs=num_uavs,
                                 rate_min_mbps=[10.0, 16.95] + [1.0] * (num_uavs - 2))
    exact = solve(p, scheme="proposed", objective="exact").sigma_h_m
    bound_plan = solve(p, scheme="proposed", objective="bound").sigma_h_m
    lo, hi = bound_minimizer_band(p, "proposed")
    assert exact <= lo * (1 + 1e-9) and lo <= bound_plan <= hi
    assert hi > lo * 1.05, (lo, hi)
