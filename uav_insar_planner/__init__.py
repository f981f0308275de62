"""uav_insar_planner: plan and fly a three-UAV dual-baseline InSAR swarm (Lahmeri et al.).

Library use:
    >>> from uav_insar_planner import load_params, solve
    >>> plan = solve(load_params(), scheme="proposed")
"""
from uav_insar_planner.params import ParamError, Params
from uav_insar_planner.params_file import load_params
from uav_insar_planner.plan import Plan
from uav_insar_planner.solver import solve

__all__ = ["ParamError", "Params", "Plan", "load_params", "solve"]
