"""Test helper: records a PX4 SITL vehicle's physics truth (SIH's HIL_STATE_QUATERNION, sent
to UDP 127.0.0.1:19410 + instance) to a CSV file, from inside the UAV's network namespace where
that loopback is (sitl_px4.Truth, run here as a process of its own).

    python px4_truth_recorder.py INSTANCE OUT.csv

One row per message, flushed as it is written: `t_wall_s,north_m,east_m,up_m`, time.time() at
arrival (the clock of the ROS stamps on this machine), the position about sitl_px4.HOME (the
track origin). Runs until killed.
"""
from __future__ import annotations

import argparse

import sitl_px4

HEADER = "t_wall_s,north_m,east_m,up_m"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("instance", type=int, help="the PX4 SITL instance (its -i)")
    parser.add_argument("out", help="CSV file to write")
    args = parser.parse_args()
    with open(args.out, "w", buffering=1) as out:
        out.write(HEADER + "\n")
        sitl_px4.Truth(args.instance, sink=out).run()


if __name__ == "__main__":
    main()
