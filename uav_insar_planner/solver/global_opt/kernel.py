"""The global back end's kernel: what every part of its search evaluates at given angles.

The search (branch_bound), its inner solves (slave_ranges, slave_sets, chain_bound) and the
local solve (local_refine) meet here and nowhere else in each other's insides.

Contract. `sc` is the problem object (solver/problem.py) of one scenario, scheme and objective.
Lengths are metres (r0 the master's slant range, r a slave's, both from the target point
(x_t, 0)), angles radians (theta a slave's look angle, the ray it sits on). Every function
broadcasts over numpy arrays; where a quantity does not exist the result is nan or inf (or an
empty interval, lo > top), which the callers mask.

- `slave_weight(sc, r0, theta, r)`: w / r0^2, with w = b_perp^2 / sigma_Phi^2 slave k's weight in
  the objective (rays.weight), b_perp = r |sin(theta - theta_0)|. Non-decreasing in r for
  every objective (slave_ranges.py's docstring proves it), so each slave wants the top of its
  feasible range. nan at r0 = 0.
- `objective_from_normalised(sc, wn)`: the objective lambda r0 sin(theta_0) / (2 pi sqrt(w))
  from wn = sum_k w_k / r0^2 (free of r0); decreasing in wn, +inf at wn <= 0.
- `range_components(sc, k, r0, theta)`: slave k's feasible ranges on ray theta as two
  intervals ((lo, top) below and above the master's C4 hole), each exactly the set the ray
  model allows (C1, C5, C6, C8, C9-C11 and C4 to the master; rays.ray_limits, master_hole).
- `lower_crossing(t, c, d2)`: on the C4 ellipse r_1^2 + r_2^2 - 2 c r_1 r_2 = d2 of two slaves
  (c the cosine of their angle difference, d2 = d_min^2), the smaller r_2 at r_1 = t; nan where
  the line r_1 = t misses the ellipse (the Pareto argument of slave_ranges.py and
  chain_bound.py places a pressed slave there).
"""
from __future__ import annotations

import numpy as np

from uav_insar_planner.solver import rays
from uav_insar_planner.solver.problem import Problem


def slave_weight(sc: Problem, r0, theta, r, g_rg=None):
    """w / r0^2 (module docstring), formed from b_perp / r0 so that centimetre ranges do not
    underflow b_perp^2 into denormals (which once made a formation at r0 = 1e-161 look
    optimal). g_rg: gamma_Rg(theta) when the caller has it."""
    with np.errstate(divide="ignore", invalid="ignore"):
        b = r / r0 * np.abs(np.sin(theta - sc.th0))
    g_rg = rays.coherence_rg(sc, theta) if g_rg is None else g_rg
    return rays.weight(sc, b, g_rg, rays.snr_factor(sc, r0, r))


def objective_from_normalised(sc: Problem, wn):
    """The objective lambda r0 sin(theta_0) / (2 pi sqrt(w)) written with wn = w / r0^2."""
    return rays.objective_from_weights(sc, 1.0, np.maximum(wn, 0.0))


def range_components(sc: Problem, k: int, r0, theta):
    """Slave k's feasible ranges on the ray as two intervals (below / above the master hole);
    an interval is empty when lo > top."""
    lo, up = rays.ray_limits(sc, k, r0, theta)
    h1, h2 = rays.master_hole(sc, r0, theta)
    return ((lo, np.minimum(up, h1)), (np.maximum(lo, h2), up))


def lower_crossing(t, c, d2):
    """y_lo(t): the smaller r_2 with (t, r_2) on the boundary of the C4 ellipse; nan if the
    line misses it."""
    disc = d2 - t * t * (1.0 - c * c)
    with np.errstate(invalid="ignore"):
        return np.where(disc > 0.0, t * c - np.sqrt(disc), np.nan)
