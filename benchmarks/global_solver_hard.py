"""The certified global solver on its hard scenarios: does the certificate close within the
node limit?

Scenarios:
- five UAVs (rates [10, 16.95, 1, 1, 1] Mbit/s) at d_min 6 m with h_amb_ratio 1.25: the C8
  ladder puts U2..U4 on different rungs, so no symmetry cut orders them;
- random swarms of three or four slaves (num_uavs 4-5, rates [10, 16.95] + [1] * (K - 1)
  Mbit/s, d_min uniform in [4, 6] m, h_amb_min uniform in [0.8, 1.6] m, drawn with
  numpy.random.default_rng(seed)); the four-slave draws with small h_amb_min, which press the
  slaves against each other near theta_max and on a second common ray, are the hard ones;
- --distinct: as above but every added slave gets its own rate (uniform in [1, 12] Mbit/s,
  rng seed 1000 + seed) and h_amb_ratio 1 or 1.25: no two slaves are interchangeable.

Prints per scenario: boxes, solve time, sigma_h, certified gap and whether every box closed.
--baseline SRC runs the same list with the package under SRC (an export of main) first.

Run: .venv/bin/python benchmarks/global_solver_hard.py [--seeds 0-29] [--only-k 4]
     [--distinct] [--baseline SRC]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np

from uav_insar_planner.params import Params, default_params

FIVE = {"num_uavs": 5, "rate_min_mbps": [10, 16.95, 1, 1, 1]}


def five_ladder() -> Params:
    """The five-UAV d_min 6 m h_amb_ratio 1.25 scenario (docs/science/solvers.md)."""
    return default_params().replace(h_amb_ratio=1.25, d_min_m=6.0, **FIVE)


def random_swarm(seed: int) -> Params:
    """A random three- or four-slave scenario at d_min 4-6 m (module docstring)."""
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 5))
    return default_params().replace(num_uavs=k + 1, rate_min_mbps=[10, 16.95] + [1] * (k - 1),
                                    d_min_m=float(rng.uniform(4, 6)),
                                    h_amb_min_m=float(rng.uniform(0.8, 1.6)))


def random_distinct(seed: int) -> Params:
    """As random_swarm, every added slave with its own rate and h_amb_ratio 1 or 1.25."""
    rng = np.random.default_rng(1000 + seed)
    k = int(rng.integers(3, 5))
    rates = [10, 16.95] + [float(np.round(rng.uniform(1, 12), 2)) for _ in range(k - 1)]
    return default_params().replace(num_uavs=k + 1, rate_min_mbps=rates,
                                    d_min_m=float(rng.uniform(4, 6)),
                                    h_amb_min_m=float(rng.uniform(0.8, 1.6)),
                                    h_amb_ratio=float(rng.choice([1.0, 1.25])))


def seeds_of(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def run(args: argparse.Namespace) -> None:
    from uav_insar_planner.solver.global_opt.optimum import solve_global

    draw = random_distinct if args.distinct else random_swarm
    cases = [("five UAVs, d_min 6 m, rho 1.25", five_ladder())]
    cases += [(f"seed {s}", draw(s)) for s in seeds_of(args.seeds)]
    print("scenario                         K  d_min  h_min  rho     boxes   time [s]"
          "   sigma_h [m]      gap  closed")
    incomplete = []
    for name, p in cases:
        k = p.num_uavs - 1
        if args.only_k and k != args.only_k and not name.startswith("five"):
            continue
        start = time.perf_counter()
        res = solve_global(p, "proposed", "exact")
        dt = time.perf_counter() - start
        closed = not res.message
        if not closed:
            incomplete.append(name)
        print(f"{name:32s} {k}  {p.d_min:5.3f}  {p.h_amb_min:5.3f}  {p.h_amb_ratio:4.2f}  "
              f"{res.iterations:8d}  {dt:9.2f}  {res.lower_bound / (1 - res.gap):12.6f}  "
              f"{res.gap:.2e}  {'yes' if closed else 'NO'}", flush=True)
    print(f"\nincomplete certificates: {len(incomplete)} of {len(cases)}"
          + (f" ({', '.join(incomplete)})" if incomplete else ""))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-29", help="e.g. 0-29 or 16,20,22")
    ap.add_argument("--only-k", type=int, default=0, help="only random draws with K slaves")
    ap.add_argument("--distinct", action="store_true", help="distinct per-slave rates")
    ap.add_argument("--baseline", metavar="SRC", help="first the same list with SRC's package")
    args = ap.parse_args()
    if args.baseline:
        print(f"--- baseline {args.baseline}")
        env = dict(os.environ, PYTHONPATH=args.baseline, PYTHONDONTWRITEBYTECODE="1")
        cmd = [sys.executable, __file__, "--seeds", args.seeds, "--only-k", str(args.only_k)]
        subprocess.run(cmd + ["--distinct"] * args.distinct, env=env, cwd=args.baseline,
                       check=True)
        print("--- this checkout")
    run(args)


if __name__ == "__main__":
    main()
