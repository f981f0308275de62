"""`python -m uav_insar_planner.demo` (what `make demo` runs)."""
import sys

from uav_insar_planner.demo.mission import main

sys.exit(main())
