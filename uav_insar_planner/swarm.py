"""How many UAVs the swarm has and what they are called: the one home of both.

U0 is the master (it transmits and receives); U1..U(N-1) are the slaves, each forming one
interferogram with the master. Every array with a row per UAV (the formation, the power
schedules, the per-UAV parameters), every `uavK/...` topic and every per-UAV loop asks here.
"""
from __future__ import annotations

NUM_UAVS = 3  # Table I: one master, two slaves (the paper's dual baseline)
MASTER = 0
UAVS = range(NUM_UAVS)
SLAVES = range(1, NUM_UAVS)


def uav_name(k: int) -> str:
    """The name of UAV `k`, as in the topics `uavK/pose` and the agent node `agentK`."""
    return f"uav{k}"


def agent_name(k: int) -> str:
    """The node name of UAV `k`'s agent when several run on one graph (`-r __node:=agentK`)."""
    return f"agent{k}"


UAV_NAMES = tuple(uav_name(k) for k in UAVS)
