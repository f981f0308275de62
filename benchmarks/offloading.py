"""Open- versus closed-loop offloading over seeded missions of the Table I plan under fading
and wind, without ROS (mission.Mission, its slot schedule and offload.ClosedLoopOffload driven
directly on the mission clock).

Per UAV and loop: the fraction of slots meeting R_min (within the checker's C10 tolerance),
the worst shortfall R_min - R over every slot of every mission, and the energy used per
mission (mean and max) against E_com^max. Both loops see the same seeds: the same shadowing,
Rician draws and gusts. Not a test: prints a table.

Run: .venv/bin/python benchmarks/offloading.py [--seeds 50] [--shadowing-db 4] [--corr-m 20]
     [--rician-k-db 6] [--wind 5 0 0] [--gust 2] [--gust-tau 2]
"""
from __future__ import annotations

import argparse

import numpy as np

from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.mission import Mission
from uav_insar_sim.offload import ClosedLoopOffload
from uav_insar_sim.wind import Wind

MAX_SPEED, MAX_ACCEL = 10.0, 3.0  # the agent's defaults
STEP_S = 0.5


def fly(k: int, plan, params, seed: int, closed: bool, args) -> list:
    """The slot samples of UAV k's mission for `seed`, open or closed loop."""
    wind = Wind(args.wind, args.gust, args.gust_tau, seed, k)
    fading = LinkFading(args.shadowing_db, args.corr_m, args.rician_k_db, seed, k)
    controller = ClosedLoopOffload(k, params) if closed else None
    m = Mission(k, params, MAX_SPEED, MAX_ACCEL, wind=wind, fading=fading,
                controller=controller)
    m.set_plan(tuple(plan.formation[k]), plan.p_com_w[k])
    t = 0.0
    while not m.all_flown and t < 1e4:
        t += STEP_S
        m.advance(t)
    return m.samples


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--shadowing-db", type=float, default=4.0)
    parser.add_argument("--corr-m", type=float, default=20.0)
    parser.add_argument("--rician-k-db", type=float, default=6.0)
    parser.add_argument("--wind", type=float, nargs=3, default=[5.0, 0.0, 0.0])
    parser.add_argument("--gust", type=float, default=2.0)
    parser.add_argument("--gust-tau", type=float, default=2.0)
    args = parser.parse_args()
    params = default_params()
    plan = solve(params)
    tol = rate_tolerance_bps(params.rate_min_bps)
    print(f"Table I plan, {params.num_slots} slots, {args.seeds} seeds; shadowing "
          f"{args.shadowing_db:g} dB / {args.corr_m:g} m, Rician K {args.rician_k_db:g} dB, "
          f"wind {args.wind} m/s + gusts {args.gust:g} m/s (tau {args.gust_tau:g} s)")
    print(f"{'uav':3} {'loop':6} {'R_min met':>9} {'worst short Mbit/s':>18} "
          f"{'E mean J':>9} {'E max J':>8} {'budget J':>8} {'max |dx| m':>10}")
    for k in range(3):
        for closed in (False, True):
            met = total = 0
            worst, energies, drift = 0.0, [], 0.0
            for seed in range(args.seeds):
                samples = fly(k, plan, params, seed, closed, args)
                short = np.array([s.rate_min_bps - s.rate_bps for s in samples])
                met += int(np.sum(short <= tol))
                total += len(samples)
                worst = max(worst, float(short.max()))
                energies.append(samples[-1].energy_used_j)
                drift = max(drift, max(abs(s.position[0] - plan.formation[k, 0])
                                       for s in samples))
            print(f"{k:3d} {'closed' if closed else 'open':6} {met / total:9.1%} "
                  f"{max(worst, 0.0) / 1e6:18.3f} {np.mean(energies):9.1f} "
                  f"{max(energies):8.1f} {params.e_max_j:8.1f} {drift:10.2f}")


if __name__ == "__main__":
    main()
