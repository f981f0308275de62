"""The bridge against a real autopilot: three ArduCopter SITL instances (../shared/sitl/, see its
README), cold-started together with the planner and the bridge node (arm_and_takeoff:=true).

Asserted: all three armed and airborne, within 0.5 m of the planned across-track position
and height (bridge's uavK/mavlink/pose vs /formation), moving along the pass; then one
instance is killed mid-pass and its /diagnostics status says "lost" within
heartbeat_timeout_s (5 s) + margin while the other two keep reporting poses. Skipped when the
SITL binary is absent (a user's machine does not have it). Every SITL and node process is
killed when the flight ends. Flown side by side with the suite's other SITL flights
(test/side_by_side.py), on a private ROS domain of its own.

Time scale: SITL runs its physics SPEEDUP times faster than wall time, the bridge runs in wall
time. Both ends tolerate it: ArduPilot's heartbeats come SPEEDUP times as often and the
vehicles move faster, so the bridge's 5 s loss timeout and its pass clock stay wall-clock.
"""
from __future__ import annotations

import math
import subprocess
import threading
import time
from pathlib import Path

import process_group
import pytest
from side_by_side import flight

REPO = Path(__file__).resolve().parent.parent
SITL_DIR = REPO.parent / "shared" / "sitl"
ARDUCOPTER = SITL_DIR / "arducopter"
SPEEDUP = 2  # stable with three instances on a 2-core machine; see the report in the issue
HOME = "-35.363261,149.165230,584,353"
SYSIDS = (2, 3, 4)
PORTS = (5760, 5770, 5780)
SPEED_MPS = 2.0
START_DELAY_S = 2.0  # the planner's start_delay_s: the pass starts this long after it is said
PASS_S = 14.0
HEARTBEAT_TIMEOUT_S = 5.0
LOST_MARGIN_S = 2.0  # one diagnostics period (1 s) plus scheduling

pytestmark = [
    pytest.mark.timeout(240),
    pytest.mark.skipif(not ARDUCOPTER.exists(),
                       reason=f"ArduCopter SITL not found at {ARDUCOPTER}: a user's machine "
                              "does not have it"),
]


def start_sitl(k: int, workdir) -> subprocess.Popen:
    """Instance k in its own directory (it writes eeprom.bin, logs/, terrain/ there)."""
    log = open(workdir / "sitl.log", "w")  # noqa: SIM115 - closed with the process
    return subprocess.Popen(
        [str(ARDUCOPTER), "--model", "+", "--speedup", str(SPEEDUP), f"-I{k}",
         "--sysid", str(SYSIDS[k]), "--defaults", str(SITL_DIR / "copter.parm"),
         "--home", HOME], cwd=workdir, stdout=log, stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL, start_new_session=True)


kill = process_group.kill_group


def read_lines(proc: subprocess.Popen, into: list[str]) -> None:
    """Drain a node's output (so its pipe never fills) into a list, in a daemon thread."""
    def pump() -> None:
        for line in proc.stdout:
            into.append((time.monotonic(), line.rstrip()))

    threading.Thread(target=pump, daemon=True).start()


def uav_status(watcher, k: int):
    for msg in reversed(watcher.diagnostics):
        for s in msg.status:
            if s.name == f"mavlink_bridge: uav{k}":
                return s, {kv.key: kv.value for kv in s.values}
    return None, {}


@flight("sitl-cold-start", "sitl")
def fly_cold_start(workdir: Path, domain: int) -> dict:
    """The flight and its checks (module doc), on a private domain of its own; the figures."""
    from conftest import private_graph

    sitls: list[subprocess.Popen] = []
    nodes: list[subprocess.Popen] = []
    try:
        with private_graph(domain=domain) as (env, watcher):
            return _fly(workdir, env, watcher, sitls, nodes)
    finally:
        for proc in sitls + nodes:
            kill(proc)


@pytest.mark.side_by_side("sitl-cold-start")
def test_three_arducopters_cold_start_fly_the_pass_and_one_is_lost(side_by_side):
    figures = side_by_side.result("sitl-cold-start")
    print("SITL figures:", {k: v for k, v in figures.items() if k != "bridge_log"})
    print("bridge log:\n" + figures["bridge_log"])


def _fly(tmp_path: Path, env: dict, watcher, sitls: list, nodes: list) -> dict:
    """fly_cold_start's flight; the SITL and node processes it starts go to `sitls` and
    `nodes`."""
    from uav_insar_planner.demo.processes import start_node

    t0 = time.monotonic()
    for k in range(3):
        workdir = tmp_path / f"copter{k}"
        workdir.mkdir()
        sitls.append(start_sitl(k, workdir))
    connections = ", ".join(f"'tcp:127.0.0.1:{p}'" for p in PORTS)
    bridge_out: list[tuple[float, str]] = []
    bridge = start_node("mavlink_bridge", [
        "-p", f"connections:=[{connections}]", "-p", "target_sysids:=[2, 3, 4]",
        "-p", "arm_and_takeoff:=true", "-p", f"speed_mps:={SPEED_MPS}",
        "-p", f"track_duration_s:={PASS_S}", "-p", f"heartbeat_timeout_s:={HEARTBEAT_TIMEOUT_S}"],
        env)
    nodes.append(bridge)
    read_lines(bridge, bridge_out)
    # the bridge's speed: the entries, a run-in before the start line, are the speed's
    planner = start_node("planner", ["-p", f"speed_mps:={SPEED_MPS}"], env)
    nodes.append(planner)
    read_lines(planner, [])
    figures: dict[str, object] = {}

    def log() -> str:
        return "\n".join(line for _, line in bridge_out[-60:])

    def planned(k: int) -> tuple[float, float, float]:
        p = watcher.formations[-1].poses[k].position
        return p.x, p.y, p.z

    def pose(k: int) -> tuple[float, float, float] | None:
        if not watcher.mavlink_poses[k]:
            return None
        p = watcher.mavlink_poses[k][-1].pose.position
        return p.x, p.y, p.z

    def cross_error(k: int) -> float:
        """Distance from the planned across-track position and height (x, z)."""
        x, _, z = planned(k)
        p = pose(k)
        return math.inf if p is None else math.hypot(p[0] - x, p[2] - z)

    def all_armed() -> bool:
        return all(uav_status(watcher, k)[1].get("armed") == "True" for k in range(3))

    def started() -> bool:
        return any("pass start from the planner" in line for _, line in bridge_out)

    assert watcher.spin_until(lambda: watcher.formations, 60.0, nodes), "no /formation"
    assert watcher.spin_until(all_armed, 150.0, nodes), log()
    figures["armed_s"] = time.monotonic() - t0
    assert watcher.spin_until(started, 90.0, nodes), log()
    figures["formation_s"] = time.monotonic() - t0
    # The bridge's log line can overtake the poses still queued for the watcher on a loaded
    # machine (seen once: uav0 1.8 m short, on its way in, at y = 0.05): take those first.
    watcher.spin_until(lambda: False, 0.3, nodes)
    for k in range(3):
        assert pose(k)[2] > 0.5, f"uav{k} not airborne: {pose(k)}"
        assert cross_error(k) < 0.5 + 1.0, (k, pose(k), planned(k))  # capture radius 1 m
    y_start = [pose(k)[1] for k in range(3)]
    worst = [0.0] * 3

    def track(until: float) -> None:
        def step() -> bool:
            for k in range(3):
                if sitls[k].poll() is None:
                    worst[k] = max(worst[k], cross_error(k))
            return time.monotonic() > until

        watcher.spin_until(step, until - time.monotonic() + 1.0, nodes)

    t_pass = time.monotonic() + START_DELAY_S  # the bridges move then, ramping up from the hover
    track(t_pass + 4.0)
    for k in range(3):
        assert pose(k)[1] - y_start[k] > 0.5 * SPEED_MPS * 4.0 - 2.0, "not moving along"
        assert cross_error(k) < 0.5, (k, pose(k), planned(k))
    # kill uav2 mid-pass
    dead = 2
    kill(sitls[dead])
    t_kill = time.monotonic()
    counts = [len(watcher.mavlink_poses[k]) for k in range(3)]

    def reported_lost() -> bool:
        s, values = uav_status(watcher, dead)
        return s is not None and values.get("phase") == "lost" and s.message.startswith("lost")

    assert watcher.spin_until(reported_lost, HEARTBEAT_TIMEOUT_S + LOST_MARGIN_S, nodes), \
        uav_status(watcher, dead)
    figures["lost_after_s"] = time.monotonic() - t_kill
    track(t_pass + PASS_S + 3.0)
    for k in (0, 1):
        assert len(watcher.mavlink_poses[k]) > counts[k] + 50, "the others stalled"
        assert uav_status(watcher, k)[1].get("link") == "linked"
        assert pose(k)[1] - y_start[k] > 0.8 * SPEED_MPS * PASS_S, (k, pose(k), y_start[k])
        assert cross_error(k) < 0.5, (k, pose(k), planned(k))
    figures["max_error_m"] = [round(w, 3) for w in worst]
    figures["final_error_m"] = [round(cross_error(k), 3) for k in (0, 1)]
    figures["bridge_log"] = "\n".join(line for _, line in bridge_out)
    return figures
