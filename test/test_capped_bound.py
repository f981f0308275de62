"""The C8-capped weight bound (slave_ranges.capped_weight_bound): along the capped ray of each
slave it is above w / r0^2 at every sampled angle and master range of the box, on both sides
of theta_0, and the box bound that uses it stays below the objective of every sampled feasible
point of Figure 3's flat valley (the proposed scheme at h_amb_min 0.5-0.8 m)."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.params import default_params
from uav_insar_planner.solver.global_opt import slave_ranges, slave_sets
from uav_insar_planner.solver.global_opt.kernel import slave_weight
from uav_insar_planner.solver.problem import make_problem

FIG3 = {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}
VALLEY = [{**FIG3, "h_amb_min_m": h} for h in (0.5, 0.6, 0.7, 0.8)]
CASES = [("exact", v) for v in VALLEY] + [
    ("exact", {}),                                                      # Table I
    ("exact", {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}),  # Figure 4
    ("multilook", {**FIG3, "h_amb_min_m": 0.6}),
    ("exact", {"radar_bandwidth_hz": 2.0e9}),       # a wide band: gamma_Rg falls slowly
    ("exact", {"radar_bandwidth_hz": 5.0e7}),       # a narrow one: it falls fast
    ("exact", {"h_amb_min_m": 0.3, "num_uavs": 3, "rate_min_mbps": [10.0, 16.95, 1.0]}),
]


def _problem(objective, overrides):
    return make_problem(default_params().replace(**overrides), "proposed", objective)


def _capped(sc, k, r0, th):
    """w / r0^2 of slave k at the C8 cap on ray th: the largest any feasible range gives."""
    cap = slave_ranges.c8_cap(sc, k)
    return slave_weight(sc, r0, th, cap * r0 / np.abs(np.sin(th - sc.th0)))


@pytest.mark.parametrize(("objective", "overrides"), CASES)
def test_capped_bound_is_above_the_capped_ray(objective, overrides):
    """Random boxes of every width on both sides of theta_0 (and straddling it, where the bound
    must give up): the bound is at least the capped weight at sampled angles (corners and
    interior) and master ranges, and within 1e-6 of the sampled maximum on boxes narrower than
    1e-5 rad."""
    sc = _problem(objective, overrides)
    rng = np.random.default_rng(11)
    n, per_box = 4000, 40
    ta = rng.uniform(sc.th_lo, sc.th_hi, n)
    tb = np.minimum(sc.th_hi, ta + 10.0 ** rng.uniform(-6, -0.5, n))
    r0a = rng.uniform(sc.r0_lo, sc.r0_hi, n)
    u = np.concatenate([[0.0, 1.0], rng.uniform(size=per_box - 2)])[:, None]
    ths = ta + (tb - ta) * u
    r0s = r0a * (1.0 + np.where(u < 0.5, 0.0, rng.uniform(0, 0.05, (per_box, n))))
    for k in sc.slaves:
        bound = slave_ranges.capped_weight_bound(sc, r0a, ta, tb, slave_ranges.c8_cap(sc, k))
        used = np.isfinite(bound)
        assert used.sum() > n // 3
        sampled = _capped(sc, k, r0s, ths)
        assert np.all(sampled[:, used] <= bound[used] * (1 + 1e-12))
        narrow = used & (tb - ta < 1e-5)
        top = _capped(sc, k, r0a, ta + (tb - ta) * np.linspace(0, 1, 101)[:, None]).max(axis=0)
        assert np.all(bound[narrow] <= top[narrow] * (1 + 1e-6))


@pytest.mark.parametrize("overrides", VALLEY)
def test_valley_box_bound_holds_at_random_feasible_points(overrides):
    """Boxes about the valley's optimum (both slaves capped, d_min apart): the box bound is at
    most the exact inner optimum at every sampled point of the box."""
    sc = _problem("exact", overrides)
    rng = np.random.default_rng(3)
    n, per_box = 3000, 10
    centre = np.column_stack([rng.uniform(0.64, 0.73, n), rng.uniform(0.64, 0.86, n)])
    half = 10.0 ** rng.uniform(-5, -1.5, (n, 2))
    ta = np.clip(centre - half, sc.th_lo, sc.th_hi)
    tb = np.clip(centre + half, ta, sc.th_hi)
    r0a = sc.r0_lo + rng.uniform(0, 2.0, n) ** 2
    r0b = r0a + 10.0 ** rng.uniform(-4, 0, n)
    boxes = np.column_stack([r0a, r0b, ta[:, 0], tb[:, 0], ta[:, 1], tb[:, 1]])
    lb = slave_sets.box_lower_bound(sc, boxes)
    u = rng.uniform(size=(per_box, n, 3))
    r0s = r0a + (r0b - r0a) * u[:, :, 0]
    ths = ta + (tb - ta) * u[:, :, 1:]
    f, _ = slave_sets.ranges_for(sc, r0s.ravel(), ths.reshape(-1, 2))
    f = f.reshape(per_box, n)
    assert np.isfinite(f).sum() > 5000
    assert np.all(lb[None, :] <= f * (1 + 1e-12))
