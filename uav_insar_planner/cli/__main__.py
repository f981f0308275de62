"""`python -m uav_insar_planner.cli` (the `uav-insar` command)."""
import sys

from uav_insar_planner.cli import main

sys.exit(main())
