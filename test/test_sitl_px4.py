"""Three real PX4 SITL vehicles fly the pass (issue 41, item 1), one stack per UAV, taking off
from three places (test/sitl_px4.py starts them).

Asserted, from the agents' and bridges' output, what the watcher heard (uavK/mavlink/pose, the
bridges' /diagnostics) and SIH's physics truth:
- every agent flew its 20 slots, all at the planned speed, the first not before the pass
  start, with the rate met in at least MET_SHARE of them;
- every vehicle was in OFFBOARD throughout its pass (its bridge's `mode` on /diagnostics);
- the autopilot's estimate on the pass within ESTIMATE_M of the plan across track and in
  height, and the truth within TRUTH_M (the estimate's error and GNSS noise between them).

Skipped with the reason where the PX4 SITL is missing.
"""
from __future__ import annotations

import os
import re

import numpy as np
import process_group
import pytest
import sitl_px4 as px4

from uav_insar_planner import load_params, solve
from uav_insar_planner.published import formation_points
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs

UAVS = uavs(DEFAULT_NUM_UAVS)
N_SLOTS = 20
MET_SHARE = 0.9
ESTIMATE_M = 0.5
TRUTH_M = 1.5
pytestmark = [
    pytest.mark.timeout(300),
    pytest.mark.skipif(not px4.PX4.exists(), reason=f"PX4 SITL not found at {px4.PX4}: a "
                                                    "user's machine does not have it"),
]


def mode_of(watcher, k: int) -> list[tuple[float, str]]:
    """(stamp, mode) of every status of vehicle k's bridge heard."""
    out = []
    for msg in watcher.diagnostics:
        for s in msg.status:
            if s.name == f"mavlink_bridge: uav{k}":
                t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                out.append((t, {kv.key: kv.value for kv in s.values}.get("mode", "")))
    return out


def test_three_px4_vehicles_fly_every_slot_in_offboard_on_the_plan(watcher, tmp_path):
    plan = formation_points(solve(load_params()))  # what the planner will plan
    flight = px4.Px4Flight()
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    done = {k: re.compile(rf"uav{k}: mission complete: (\d+) slots flown, (\d+) at the planned "
                          r"speed.*rate met in (\d+)") for k in UAVS}

    def text(name: str) -> str:
        return flight.logs[name].read_text() if flight.logs[name].exists() else ""

    try:
        px4.start(flight, tmp_path, env, UAVS)
        procs = list(flight.procs.values())
        ok = watcher.spin_until(lambda: all(done[k].search(text(f"agent{k}")) for k in UAVS),
                                240.0, procs)
    finally:
        for proc in flight.procs.values():
            process_group.interrupt_group(proc)
        for truth in flight.truth.values():
            truth.stop()
    logs = {name: text(name) for name in flight.logs}
    assert ok, "\n".join(f"== {n}\n{t[-2500:]}" for n, t in logs.items())
    for k in UAVS:
        agent = logs[f"agent{k}"]
        flown, at_speed, met = (int(v) for v in done[k].search(agent).groups())
        assert (flown, at_speed) == (N_SLOTS, N_SLOTS), agent[-2000:]
        assert met >= MET_SHARE * N_SLOTS, agent[-2000:]
        since = re.search(r"slot 0 started .*?([+-]\d+\.\d+) s from the pass start", agent)
        assert since and float(since[1]) >= 0.0, agent[-2000:]
        # on the pass: poses between slot 0's line and the last slot's end
        x, y0, z = plan[k]
        y1 = y0 + N_SLOTS * 4.3
        rows = np.array([(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec,
                          m.pose.position.x, m.pose.position.y, m.pose.position.z)
                         for m in watcher.mavlink_poses[k]]).reshape(-1, 4)
        on = rows[(rows[:, 2] >= y0) & (rows[:, 2] <= y1)]
        assert len(on) > 50, len(on)
        across, height = np.abs(on[:, 1] - x).max(), np.abs(on[:, 3] - z).max()
        print(f"uav{k}: estimate on the pass: across {across:.3f} m, height {height:.3f} m")
        assert across <= ESTIMATE_M and height <= ESTIMATE_M, (across, height)
        t0, t1 = on[0, 0], on[-1, 0]
        modes = [m for t, m in mode_of(watcher, k) if t0 <= t <= t1]
        assert modes and all(m == "OFFBOARD" for m in modes), set(modes)
        truth = np.array(flight.truth[k].rows).reshape(-1, 4)
        true_on = truth[(truth[:, 0] >= t0) & (truth[:, 0] <= t1)]
        assert len(true_on) > 50, len(true_on)
        # truth (north, east, up) about the track origin: x = east, y = north (bearing 0)
        t_across = np.abs(true_on[:, 2] - x).max()
        t_height = np.abs(true_on[:, 3] - z).max()
        print(f"uav{k}: truth on the pass: across {t_across:.3f} m, height {t_height:.3f} m")
        assert t_across <= TRUTH_M and t_height <= TRUTH_M, (t_across, t_height)
