"""FAULT INJECTION for tests, not a fake of anything real: run a program of the suite whose
MAVLink links start raising after a delay, to kill its I/O thread the way a bug would.

    python test/fault_injection.py SECONDS MODULE [ARGS...]

patches `Link.poll_sources` (which `Link.poll` uses too) to raise RuntimeError once SECONDS
have passed since start-up, then runs `MODULE.main()` with sys.argv = [MODULE, *ARGS] and
exits with its code.
"""
import importlib
import sys
import time

from uav_insar_planner.mavlink.link import Link

if __name__ == "__main__":
    delay, module, args = float(sys.argv[1]), sys.argv[2], sys.argv[3:]
    deadline = time.monotonic() + delay
    healthy = Link.poll_sources

    def failing(self):
        if time.monotonic() > deadline:
            raise RuntimeError("fault injection: the link raised")
        return healthy(self)

    Link.poll_sources = failing
    sys.argv = [module, *args]
    sys.exit(importlib.import_module(module).main())
