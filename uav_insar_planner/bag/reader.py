"""Read a recorded mission back from a rosbag2 bag (MCAP or SQLite storage) with rosbags; no
ROS import: the message types come from the definitions stored in the bag.

`read_mission(path)` -> MissionRecord, plain numpy data in SI units. Topics are matched by
the suite's names (ros/topics.py; a namespace in front is allowed): the last `formation` and
`formation/power` (the plan flown; a later plan replaces an earlier one), the planner's plan
status and per-UAV statuses (`planner: uavK`) on `/diagnostics`, and per UAV k
`uav{k}/achieved_rate` and `uav{k}/offload`, each with its receive time [s] in the bag, and
`uav{k}/pose` with its header stamp, when the position was taken (its receive time when the
stamp is unset).
"""
from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uav_insar_planner.published import PLAN_STATUS_NAME, uav_status_name
from uav_insar_planner.swarm import MAX_UAVS, uav_index

# uavK of any swarm (K < MAX_UAVS, checked by uav_index)
_UAV_TOPIC = re.compile(r"(?:^|/)(uav\d+)/(achieved_rate|offload|pose)$")
_UAV_STATUS = {uav_status_name(k): k for k in range(MAX_UAVS)}


class BagError(ValueError):
    """The bag cannot be read: one line naming the path and what is wrong."""


@dataclass
class MissionRecord:
    """What a bag holds about one mission (see the module docstring). Per UAV k:
    `rates[k]` (t_s, rate_bps) rows, `offloads[k]` (t_s, slot, power_w, energy_used_j,
    energy_left_j, strip) rows (strip -1 for a single pass and in bags of agents whose offload
    had no strip field yet: ros/topics.py OFFLOAD_FIELDS), `poses[k]` (t_s, x, y, z) rows;
    `formation` (num_uavs, 3) planned (x, y, z) with NaN rows for UAVs not flown and `power`
    (num_uavs, N) planned P_com [W], None when absent (num_uavs as the plan has it, checked by
    its reader); `plan_values` the plan status's key/values, `uav_values[k]` the latest
    `planner: uavK` status's; `counts` messages per topic."""

    formation: np.ndarray | None = None
    power: np.ndarray | None = None
    plan_values: dict[str, str] = field(default_factory=dict)
    uav_values: dict[int, dict[str, str]] = field(default_factory=dict)
    rates: dict[int, np.ndarray] = field(default_factory=dict)
    offloads: dict[int, np.ndarray] = field(default_factory=dict)
    poses: dict[int, np.ndarray] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)


def _kind(topic: str) -> tuple[str, int]:
    m = _UAV_TOPIC.search(topic)
    if m and (k := uav_index(m[1])) is not None:
        return m[2], k
    if topic == "/diagnostics":
        return "diagnostics", -1
    for name in ("formation/power", "formation"):
        if topic.endswith("/" + name):
            return name, -1
    return "", -1


_UNREADABLE = (OSError, KeyError, ValueError)  # and rosbags' AnyReaderError


def check_bag(path: str | Path) -> None:
    """BagError (one line) unless `path` is a bag folder whose metadata and storage files open:
    what can be known of a bag before its messages are read."""
    from rosbags.highlevel import AnyReader, AnyReaderError

    path = Path(path)
    shown = repr(str(path)[:200])
    expected = "expected a rosbag2 bag folder (as ros2 bag record / uav-insar record make)"
    if not path.exists():
        raise BagError(f"BAG: {shown} does not exist; {expected}")
    if not path.is_dir():
        raise BagError(f"BAG: {shown} is not a folder; {expected}")
    if not (path / "metadata.yaml").is_file():
        raise BagError(f"BAG: {shown} has no metadata.yaml; {expected}")
    try:
        with AnyReader([path]):
            pass
    except (AnyReaderError, *_UNREADABLE) as exc:
        raise BagError(f"BAG: {shown} cannot be read: {str(exc)[:200]}") from None


def read_mission(path: str | Path, progress: Callable[[int], None] | None = None,
                 total: Callable[[int], None] | None = None) -> MissionRecord:
    """The mission in bag `path` (a bag folder, as `ros2 bag record` makes). `total(n)` hears
    the number of messages to read, `progress(1)` each one read; BagError if unreadable."""
    from rosbags.highlevel import AnyReader, AnyReaderError

    path = Path(path)
    check_bag(path)
    record = MissionRecord()
    rows: dict[tuple[str, int], list] = {}
    try:
        with AnyReader([path]) as reader:
            wanted = [c for c in reader.connections if _kind(c.topic)[0]]
            if total is not None:
                total(sum(c.msgcount for c in wanted))
            for conn, stamp_ns, raw in reader.messages(connections=wanted):
                name, k = _kind(conn.topic)
                record.counts[conn.topic] = record.counts.get(conn.topic, 0) + 1
                msg = reader.deserialize(raw, conn.msgtype)
                _take(record, rows, name, k, stamp_ns * 1e-9, msg)
                if progress is not None:
                    progress(1)
    except (AnyReaderError, *_UNREADABLE) as exc:
        raise BagError(f"BAG: {str(path)[:200]!r} cannot be read: {str(exc)[:200]}") from None
    widths = {"achieved_rate": 2, "offload": 6, "pose": 4}
    for (name, k), found in rows.items():
        target = {"achieved_rate": record.rates, "offload": record.offloads,
                  "pose": record.poses}[name]
        target[k] = np.asarray(found, dtype=float).reshape(-1, widths[name])
    return record


def _take(record: MissionRecord, rows: dict, name: str, k: int, t: float, msg) -> None:
    if name == "formation":
        record.formation = np.array([[p.position.x, p.position.y, p.position.z]
                                     for p in msg.poses], dtype=float).reshape(-1, 3)
    elif name == "formation/power":
        dims = msg.layout.dim
        shape = (int(dims[0].size), int(dims[1].size)) if len(dims) >= 2 else (1, -1)
        record.power = np.asarray(msg.data, dtype=float).reshape(shape)
    elif name == "diagnostics":
        for status in msg.status:
            if status.name == PLAN_STATUS_NAME:
                record.plan_values = {v.key: v.value for v in status.values}
            elif status.name in _UAV_STATUS:
                record.uav_values[_UAV_STATUS[status.name]] = {v.key: v.value
                                                               for v in status.values}
    elif name == "achieved_rate":
        rows.setdefault((name, k), []).append((t, msg.data))
    elif name == "offload":
        data = list(msg.data)
        strip = data[4] if len(data) > 4 else -1.0  # an older agent's four fields: one pass
        rows.setdefault((name, k), []).append((t, *data[:4], strip))
    elif name == "pose":  # when the position was taken (a lossy radio delivers some late)
        p, stamp = msg.pose.position, msg.header.stamp
        taken = stamp.sec + 1e-9 * stamp.nanosec
        rows.setdefault((name, k), []).append((taken if taken > 0.0 else t, p.x, p.y, p.z))
