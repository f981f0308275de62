"""FAULT INJECTION for tests, not a fake of anything real: run the planner whose second
published plan raises inside the solve worker's result callback, killing the worker thread
the way a bug would.

    python test/fault_solve_callback.py [ARGS...]

patches `PlannerNode._publish_plan` to raise RuntimeError from its second call on (the first
plan is published as usual), then runs the planner's `main()` with sys.argv = [planner,
*ARGS] and exits with its code.
"""
import sys

from uav_insar_planner.ros import planner

if __name__ == "__main__":
    healthy, calls = planner.PlannerNode._publish_plan, []

    def failing(self, plan):
        calls.append(plan)
        if len(calls) > 1:
            raise RuntimeError("fault injection: publishing the plan raised")
        return healthy(self, plan)

    planner.PlannerNode._publish_plan = failing
    sys.argv = ["planner", *sys.argv[1:]]
    sys.exit(planner.main())
