"""`python -m uav_insar_sim.vehicle` (the `uav-insar-vehicle` command)."""
import sys

from uav_insar_sim.vehicle.cli import main

sys.exit(main())
