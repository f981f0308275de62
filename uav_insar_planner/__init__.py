"""uav_insar_planner: plan and fly a multi-baseline InSAR swarm of 2 to 10 UAVs (swarm.py), after
Lahmeri et al.'s dual-baseline three.

Library use:
    >>> from uav_insar_planner import load_params, solve
    >>> plan = solve(load_params(), scheme="proposed")
"""
from uav_insar_planner.params import ParamError, Params
from uav_insar_planner.params_file import load_params
from uav_insar_planner.plan import Plan
from uav_insar_planner.solver import solve

__all__ = ["ParamError", "Params", "Plan", "load_params", "solve"]
