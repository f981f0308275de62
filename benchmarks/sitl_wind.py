"""How well ArduCopter holds the planned formation, with and without wind: three SITL
instances (../shared/sitl/) flown by mavlink_bridge, agents on position_source:=autopilot
(the mission of test/sitl_autopilot.py, 12 slots at Table I's 4.3 m/s), once per wind case.

Printed per case: the distance between the two slaves on the pass against the plan's 1.5 m
(Table I's d_min; mean, std, min, max), each UAV's across-track and height error on the pass
(mean, std, largest magnitude), and the report's sigma_h planned and flown (the bag's
positions, `uav-insar report`'s figures). Not a test; about 80 s per case on 2 cores.

Run: .venv/bin/python benchmarks/sitl_wind.py [--wind 5] [--turbulence 2] [--domain 211]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "test"))
import sitl_autopilot as sitl  # noqa: E402 - the mission lives beside the test that asserts it


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wind", type=float, default=5.0, help="SIM_WIND_SPD [m/s]")
    parser.add_argument("--turbulence", type=float, default=2.0, help="SIM_WIND_TURB")
    parser.add_argument("--domain", type=int, default=211, help="ROS_DOMAIN_ID")
    args = parser.parse_args()
    if not sitl.ARDUCOPTER.exists():
        print(f"no ArduCopter SITL at {sitl.ARDUCOPTER}", file=sys.stderr)
        return 1
    for wind, turbulence in ((0.0, 0.0), (args.wind, args.turbulence)):
        with tempfile.TemporaryDirectory() as tmp:
            print(sitl.table(sitl.fly(wind, turbulence, Path(tmp), args.domain)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
