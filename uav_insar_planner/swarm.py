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
MAX_UAVS = 10  # nine interferograms
MASTER = 0
# One colour per UAV in every plot and marker: matplotlib's tab10, reordered so Table I's U0 is
# red, U1 blue, U2 green; the slaves of larger swarms take the rest, then it starts again.
_PALETTE = ("#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
            "#7f7f7f", "#bcbd22", "#17becf")


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


def uav_color(k: int) -> str:
    """UAV `k`'s colour as `#rrggbb`, for any k >= 0 (distinct for k < 10)."""
    return _PALETTE[k % len(_PALETTE)]


def uav_rgb(k: int) -> tuple[float, float, float]:
    """`uav_color(k)` as (red, green, blue) in 0..1, as a marker's ColorRGBA takes it."""
    code = uav_color(k)
    return (int(code[1:3], 16) / 255, int(code[3:5], 16) / 255, int(code[5:7], 16) / 255)


def uav_index(name: str) -> int | None:
    """K of the name `uavK` of a UAV any swarm may have (K in 0..MAX_UAVS - 1), else None."""
    if name.startswith("uav") and name[3:].isdigit() and str(int(name[3:])) == name[3:]:
        k = int(name[3:])
        return k if k < MAX_UAVS else None
    return None


def count_problem(field: str, count: int) -> str | None:
    """One line when `count` UAVs is not a swarm's size (MIN_UAVS..MAX_UAVS), else None."""
    if MIN_UAVS <= count <= MAX_UAVS:
        return None
    return (f"{field}: value {count} UAVs is not allowed; expected {MIN_UAVS} to {MAX_UAVS} "
            f"(the master and 1 to {MAX_UAVS - 1} slaves)")
