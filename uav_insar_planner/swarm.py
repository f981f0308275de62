"""How many UAVs a swarm may have and what they are called: the one home of both.

U0 is the master (it transmits and receives); U1..U(N-1) are the slaves, each forming one
interferogram with the master. N is the scenario parameter `num_uavs` (`Params.num_uavs`);
every array with a row per UAV (the formation, the power schedules, the per-UAV parameters),
every `uavK/...` topic and every per-UAV loop takes its length from there and its names from
here.
"""
from __future__ import annotations

DEFAULT_NUM_UAVS = 3  # Table I: one master, two slaves (the paper's dual baseline)
MIN_UAVS = 2  # one interferogram: the single-baseline benchmark
MAX_UAVS = 6  # five interferograms
MASTER = 0


def uavs(num_uavs: int) -> range:
    """U0..U(N-1)."""
    return range(num_uavs)


def slaves(num_uavs: int) -> range:
    """U1..U(N-1), the receivers that each form an interferogram with the master."""
    return range(1, num_uavs)


def uav_name(k: int) -> str:
    """The name of UAV `k`, as in the topics `uavK/pose` and the agent node `agentK`."""
    return f"uav{k}"


def agent_name(k: int) -> str:
    """The node name of UAV `k`'s agent when several run on one graph (`-r __node:=agentK`)."""
    return f"agent{k}"


def uav_names(num_uavs: int) -> tuple[str, ...]:
    """uav0..uav(N-1)."""
    return tuple(uav_name(k) for k in uavs(num_uavs))


# Table I's swarm, for the parts of the suite that do not yet take num_uavs from the scenario.
NUM_UAVS = DEFAULT_NUM_UAVS
UAVS = uavs(NUM_UAVS)
SLAVES = slaves(NUM_UAVS)
UAV_NAMES = uav_names(NUM_UAVS)
