"""`python -m uav_insar_planner.ros.tools.record OUT ...`: `uav-insar record` by this module's
name, which the demo and the benchmarks start the recorder with. The command is cli/record.py,
its node ros/tools/bag_recorder.py."""
import sys

from uav_insar_planner.cli import main

if __name__ == "__main__":
    sys.exit(main(["record", *sys.argv[1:]]))
