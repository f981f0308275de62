"""Per-UAV stacks whose vehicles take off where the field allows (issue 26, item 1): in one
swarm, one behind the track start, one BESIDE it (at its formation point at y = 0, its
reported position jittering back and forth across the slot 0 line until it flies back to its
entry, the start of its run-in) and one ahead of it (it flies back); in another, all on the
ground at y = 0, armed and taken off by their bridges, climbing and crossing to their entries. Real
processes on localhost: the planner; per UAV a `uav-insar-vehicle` with GNSS-like position
noise and a light wind, a `mavlink_bridge` with `uav_id` K in /uavK, and an agent with
`position_source:=autopilot` in /uavK.

Asserted, for each take-off place: every agent flies every slot once, in order, and all at
the planned speed, slot 0 included (the run-in: issue 40); none starts slot 0 before the
planner's pass start (formation/start), and each starts it when its autopilot's track first
reaches the line after it, when the pass clock puts the target there (within a slot of lag);
each rate is the plan's power's FDMA rate where the autopilot was (its
uavK/mavlink/pose track: the first position at or past the slot's line after the start,
interpolated onto the line when the one before was behind it); every agent says "mission
complete".

Ports 29600-29699 (this file's own), a private ROS domain per run (conftest
`private_graph`); one swarm run per take-off place, shared by the checks, the runs flown side
by side.
"""
from __future__ import annotations

import re
import signal
import subprocess
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np
import process_group
import pytest
import yaml
from std_msgs.msg import Float64MultiArray, Header

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.demo.processes import executable, start_node, start_process
from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.start_msgs import decode_start
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.passes import run_in_m
from uav_insar_sim.mission import home_position

pytestmark = pytest.mark.timeout(120)
N = 6
SCENARIO = {"num_slots": N, "slot_duration_s": 1.0}
#: where each vehicle (uav0, uav1, uav2) is at the start of the run: along the track from its
#: start [m], and in the air at its formation point's x and z (True), or on the ground at its
#: home's x for the bridge to arm and take off (False), as the issue's copters did. One
#: swarm per case (each run costs 20-35 s of real flight).
STARTS = {"behind, beside, ahead": ((-10.0, True), (0.0, True), (10.0, True)),
          "takeoff beside": ((0.0, False), (0.0, False), (0.0, False))}
NOISE_STD_M = 0.3  # the reported position's error per axis, as GNSS under an EKF
NOISE_TAU_S = 1.0
WIND_NED = (0.0, 0.5, 0.0)  # across the track: each holds 0.33 m off its point (E = x)
BASE_PORT = 29600  # vehicle K of case c: BASE_PORT + 20 c + K
RUN_TIMEOUT_S = 60.0
CROSSING_TOL_S = 0.15  # a reading or two: the test's own subscription may miss one
SINCE_START = re.compile(r"slot 0 started at y = (-?[\d.]+) m .*, ([+-][\d.]+) s from the "
                         r"pass start")
PASS_START = re.compile(r"pass start (?:in|[\d.]+ s ago).*wall clock ([\d.]+)")


class Output:
    """A process's output lines, read as they come (a full pipe would stall it)."""

    def __init__(self, proc) -> None:
        self.proc, self.lines = proc, []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip())

    def text(self) -> str:
        return "\n".join(self.lines)


def stop_all(procs, grace_s: float = 8.0) -> None:
    """Ctrl-C every process group at once, then SIGKILL what is left after `grace_s`."""
    for proc in procs:
        process_group.kill_group(proc, signal.SIGINT)
    end = time.monotonic() + grace_s
    for proc in procs:
        try:
            proc.wait(max(0.0, end - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass
        process_group.kill_group(proc)


def _stamp(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


@pytest.fixture(scope="module")
def flights(tmp_path_factory) -> dict[str, Future]:
    """Every case's swarm run, flown side by side (each mostly waits for its vehicles, which
    fly in real time); case -> its future."""
    plan = solve(load_params(overrides=SCENARIO))
    with ThreadPoolExecutor(len(STARTS)) as pool:
        return {case: pool.submit(fly, case, plan, tmp_path_factory.mktemp(f"field-{case}"))
                for case in STARTS}


@pytest.fixture(scope="module", params=list(STARTS))
def flown(request, flights):
    """The run of case `param`, its exception if it failed."""
    seen = flights[request.param].result()
    print(f"\n{seen['case']}: run {seen['run_s']:.1f} s")
    return seen


def fly(case: str, plan, tmp) -> dict:
    """One swarm run with every vehicle starting STARTS[case] metres along the track from
    its formation point; what was seen of it."""
    from conftest import private_graph

    params = load_params(overrides=SCENARIO)
    params_file = tmp / "params.yaml"
    params_file.write_text(yaml.safe_dump({"/**": {"ros__parameters": {
        **SCENARIO, "velocity_feedforward": True,
        # one slot more than the mission, so every UAV crosses the line after its last slot
        "track_duration_s": float(N + 1)}}}))
    ros = ["--params-file", str(params_file)]
    uavs = range(plan.formation.shape[0])
    ports = [BASE_PORT + 20 * list(STARTS).index(case) + k for k in uavs]  # < 29680
    t_begin = time.monotonic()
    with private_graph() as (env, w):
        starts: list[Header] = []
        w.node.create_subscription(Header, "/" + topics.FORMATION_START, starts.append,
                                   topics.LATCHED)
        arrivals: dict[int, list[tuple[float, int]]] = {k: [] for k in uavs}
        for k in uavs:
            w.node.create_subscription(
                Float64MultiArray, "/" + topics.offload(k),
                lambda m, k=k: arrivals[k].append((time.time(), int(m.data[0]))),
                topics.RATE_DEPTH)
        out: dict[str, Output] = {}
        for k, port in zip(uavs, ports, strict=True):
            y, airborne = STARTS[case][k]  # (the plan's track start is y = 0)
            x, z = plan.formation[k] if airborne else (home_position(k)[0], 0.0)
            out[f"vehicle{k}"] = Output(start_process([
                *executable("uav-insar-vehicle"), "--sysid", str(FIRST_SYSID + k), "--listen",
                f"udpin:127.0.0.1:{port}", *(["--airborne"] if airborne else []),
                "--start-ned", str(y), str(x), str(-z),
                "--position-noise-std", str(NOISE_STD_M), "--position-noise-tau",
                str(NOISE_TAU_S), "--noise-seed", "26", "--wind-mps", *map(str, WIND_NED)],
                env))
            ns = ["-r", f"__ns:=/uav{k}", "-p", f"uav_id:={k}"]
            out[f"bridge{k}"] = Output(start_node("mavlink_bridge", [
                *ros, *ns, "-p", f"connections:=['udpout:127.0.0.1:{port}']",
                "-p", f"target_sysids:=[{FIRST_SYSID + k}]",
                "-p", f"arm_and_takeoff:={str(not airborne).lower()}"], env))
            out[f"agent{k}"] = Output(start_node("agent", [
                *ros, *ns, "-p", "position_source:=autopilot"], env))
        procs = [o.proc for o in out.values()]
        done = [f"uav{k}: mission complete" for k in uavs]
        try:
            assert w.spin_until(lambda: w.agents_matched() and all(w.mavlink_poses[k]
                                                                   for k in uavs),
                                30.0, procs), "agents or bridges did not come up"
            out["planner"] = Output(start_node("planner", ros, env))
            procs.append(out["planner"].proc)
            finished = w.spin_until(
                lambda: all(d in out[f"agent{k}"].text() for k, d in zip(uavs, done,
                                                                         strict=True)),
                RUN_TIMEOUT_S, procs)
            assert finished, "\n".join(f"== {n}\n{o.text()[-1500:]}" for n, o in out.items())
            w.spin_until(lambda: False, 0.5)  # the last slot's messages
        finally:
            stop_all(procs)
        seen = {
            "case": case, "params": params, "plan": plan, "starts": list(starts),
            "arrivals": arrivals, "rates": {k: list(w.rates[k]) for k in uavs},
            "offloads": {k: list(w.offloads[k]) for k in uavs},
            "tracks": {k: [(_stamp(m), m.pose.position.x, m.pose.position.y,
                            m.pose.position.z) for m in w.mavlink_poses[k]] for k in uavs},
            "logs": {n: o.text() for n, o in out.items()}, "uavs": list(uavs),
            "codes": {n: o.proc.returncode for n, o in out.items()},
            "run_s": time.monotonic() - t_begin}
    return seen


def pass_start(flown) -> float:
    assert flown["starts"], "no formation/start seen"
    _, t0, _ = decode_start(flown["starts"][0], time.time())
    return t0


def slot_line(flown, n: int) -> float:
    p = flown["params"]
    return n * p.speed * p.slot_duration_s  # the plan's track start is y = 0


def test_every_agent_flies_every_slot_once_in_order(flown):
    for k in flown["uavs"]:
        assert [int(o[0]) for o in flown["offloads"][k]] == list(range(N)), k
        assert len(flown["rates"][k]) == N, k
        # every slot at the planned speed, slot 0 too: the run-in brought it to v_y
        assert (f"uav{k}: mission complete: {N} slots flown, {N} at the planned speed"
                in flown["logs"][f"agent{k}"]), flown["logs"][f"agent{k}"][-1500:]
    bad = {n: [line for line in log.splitlines() if "ERROR" in line]
           for n, log in flown["logs"].items()}
    assert not any(bad.values()), bad


def line_crossing(track, t0: float, line: float) -> float:
    """When `track` [(t, x, y, z)] first reached `line` at or after `t0`, as the agent reads
    it (ObservedMission: interpolated from the reading before when that one was behind)."""
    before = None
    for t, _, y, _ in track:
        if t >= t0 and y >= line:
            if before is None or before[1] >= line:
                return t
            s = (line - before[1]) / (y - before[1])
            return max(before[0] + s * (t - before[0]), t0)
        before = (t, y)
    raise AssertionError(f"the track never reached y = {line} m after the pass start")


def test_no_slot_before_the_pass_start(flown):
    t0 = pass_start(flown)
    offsets = []
    for k in flown["uavs"]:
        first = flown["arrivals"][k][0]  # what reached the ground: slot 0, after the start
        assert first[1] == 0 and first[0] >= t0, (first, t0)
        log = flown["logs"][f"agent{k}"]
        assert log.count("no pass start yet") == 1, log
        heard = [float(m[1]) for m in PASS_START.finditer(log)]
        assert heard and heard[0] == pytest.approx(t0, abs=1e-3), (heard, t0)
        found = SINCE_START.search(log)
        assert found, log
        y0, since = float(found[1]), float(found[2])
        offsets.append(since)
        # slot 0 on the first position read at or past the line after the start, as the
        # track the test recorded tells it (interpolated onto the line from a reading behind)
        crossing = line_crossing(flown["tracks"][k], t0, slot_line(flown, 0))
        assert since == pytest.approx(crossing - t0, abs=CROSSING_TOL_S), (since, crossing - t0,
                                                                            log)
        # ... when the pass clock puts its target on the line, after the run-in from the
        # entry (three noise sigmas either way), within a slot of lag
        v = flown["params"].speed
        due = PassClock(0.0, v, -run_in_m(v)).time_at(0.0)
        assert due - 3 * NOISE_STD_M / v <= since < due + flown["params"].slot_duration_s, log
        assert y0 >= 0.0, log
    print(f"{flown['case']}: slot 0 at {np.round(offsets, 3)} s from the pass start")


def test_beside_the_start_the_uav_waited_at_its_entry_not_on_the_line(flown):
    """Beside the start (y = 0), where the reported position jitters across the slot 0 line,
    the UAV flew back to its entry: just before the pass start it stood a run-in behind the
    line, so slot 0 waits for the pass and is flown at v_y."""
    t0, v = pass_start(flown), flown["params"].speed
    for k in (k for k in flown["uavs"] if STARTS[flown["case"]][k][0] == 0.0):
        ys = [y for t, _, y, _ in flown["tracks"][k] if t0 - 1.0 <= t < t0]
        assert ys and max(ys) < -run_in_m(v) + 3 * NOISE_STD_M + 1.0, (k, ys)


def test_each_rate_is_where_the_autopilot_was_after_the_start(flown):
    params, plan, t0 = flown["params"], flown["plan"], pass_start(flown)
    for k in flown["uavs"]:
        where = []  # as the agent sees its autopilot's track (ObservedMission.observe)
        before = None
        for t, *here in flown["tracks"][k]:
            while t >= t0 and len(where) < N and here[1] >= slot_line(flown, len(where)):
                line = slot_line(flown, len(where))
                if before is not None and before[1] < line:
                    s = (line - before[1]) / (here[1] - before[1])
                    where.append([a + s * (b - a) for a, b in zip(before, here, strict=True)])
                else:
                    where.append(list(here))  # held ahead of the line at the start
            before = here
        assert len(where) == N, (k, len(where))
        for n, (rate, q) in enumerate(zip(flown["rates"][k], where, strict=True)):
            d = model.distance_to_station(*q, params.ground_station)
            expected = model.fdma_rate(plan.p_com_w[k, n], d, params.comm_bandwidth_hz,
                                       params.beta_c)
            assert rate == pytest.approx(float(expected), rel=1e-9), (k, n, q)
