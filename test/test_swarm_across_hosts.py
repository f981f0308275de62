"""The swarm across hosts: a ground station and one computer per UAV, each a Linux network
namespace (uav_insar_sim/netlab: a port each on a user-space switch that loses, delays and
cuts frames as a bad radio does), DDS between them, MAVLink only inside each UAV.

- ground: the planner and the recorder (`uav-insar record`);
- uavK: the vehicle simulator (`uav-insar-vehicle`, its autopilot on the UAV's own loopback),
  the bridge flying that one UAV and the agent reading its autopilot's position, both in the
  namespace /uavK (`-r __ns:=/uavK -p uav_id:=K`), as a stack on the UAV's computer runs.
  Each vehicle takes off beside the track start (its home moved to y = 0), its reported
  position jittering as under GNSS noise, so it climbs and crosses to its formation point on
  the slot 0 line: no agent may start slot 0 before the planner's pass start.

The lossy-radio swarm is judged by how it flew too (issue 27's late pass start, which made a
bridge join 1-4 s late and its UAV catch up): every bridge heard the planner's pass start
before its instant, and from the bag (swarm_track.py) the swarm's along-track spread and
each UAV's slot durations stay within what the position noise allows.

Everything observed crosses the lossy links: the bag is written on the ground, from what
reached it. Skipped with the lab's reason where namespaces or TAP devices are not permitted.
"""
from __future__ import annotations

import re
import time

import numpy as np
import pytest
from netlab_swarm import (
    FAST_DDS_HEARTBEAT_S,
    RADIO,
    UAVS,
    lab_fixture,
    read_bag,
    start_swarm,
    stop_recorder,
    wait_for,
)
from swarm_track import Pass

from uav_insar_planner import load_params
from uav_insar_planner.swarm import uav_name

pytestmark = pytest.mark.timeout(240)

NUM_SLOTS = 8
UAV_TIMEOUT_S = 3.0
GCS_TIMEOUT_S = 3.0
CUT = UAVS[-1]  # the UAV whose link is cut
V_Y = load_params().speed  # the scenario's speed along the track [m/s]
# The reported positions wander by 0.3 m per axis (tau 2 s; a 2 s moving average hardly
# narrows it) and the truth is not in the bag: measured, the noise-free swarm's 0.5 m spread
# reads 1.1-1.2 m here, its 0.8-1.2 s slots 0.8-1.4 s. So the formation's 1 m and 0.9-slot
# bounds (held by the noise-free swarms of test_field_faults.py) widen here; a late pass
# start made 0.46 s slots and 15 m of spread (issue 27): still far outside.
SMOOTH_S = 2.0
SPREAD_MAX_M = 2.0
SLOT_MIN_S = 0.6
SLOT0 = re.compile(r"slot 0 started at y = (-?[\d.]+) m .*, ([+-][\d.]+) s from the pass start")

lab = lab_fixture(RADIO)


def test_a_lossy_radio_loses_no_slot_and_no_plan(lab, ros_domain, tmp_path):
    out = start_swarm(lab, ros_domain, tmp_path, "subnet", num_slots=NUM_SLOTS,
                      uav_timeout_s=UAV_TIMEOUT_S, gcs_timeout_s=GCS_TIMEOUT_S).out
    procs = [o.proc for o in out.values()]
    done = [f"{uav_name(k)}: mission complete: {NUM_SLOTS} slots" for k in UAVS]
    assert wait_for(lambda: all(out[f"agent{k}"].first(done[k]) for k in UAVS), 150.0, procs), \
        "\n".join(f"== {n}\n{o.text()[-1500:]}" for n, o in out.items())
    # The last slot's messages cross the radio. A lost sample is resent after the writer's
    # next heartbeat (Fast DDS: every 3 s), and its NACK may be lost too: three periods. A
    # 2 s wait lost uav1's last rate in one CI run (the bag showed 3 s recovery gaps).
    time.sleep(3 * FAST_DDS_HEARTBEAT_S + 1.0)
    stop_recorder(out)
    bag = read_bag(tmp_path / "bag")
    plans = {m.layout.dim[2].label for _, m in bag["/formation/power"]}
    assert len(plans) == 1, plans
    for k in UAVS:
        name = uav_name(k)
        assert len(bag[f"/{name}/achieved_rate"]) == NUM_SLOTS, name
        assert [m.data for _, m in bag[f"/{name}/plan"]][-1] in plans
        flown = {(m.pose.position.x, m.pose.position.y, m.pose.position.z)
                 for _, m in bag[f"/{name}/pose"]}
        autopilot = {(m.pose.position.x, m.pose.position.y, m.pose.position.z)
                     for _, m in bag[f"/{name}/mavlink/pose"]}
        # the agent reports only where its autopilot was (both crossed the radio: lossless
        # as DDS reliable is, some of either may still be queued when the bag closes)
        assert len(flown & autopilot) >= 0.9 * len(flown), name
    ys = np.array([[m.pose.position.y for _, m in bag[f"/{uav_name(k)}/pose"]][-1]
                   for k in UAVS])
    assert np.all(ys > 0.0)
    assert_slot0_on_the_pass_start(out)
    assert_every_bridge_before_the_instant(out)
    flown = Pass(bag, UAVS, NUM_SLOTS, V_Y, 1.0, smooth_s=SMOOTH_S)
    print(flown.text())
    assert flown.spread() < SPREAD_MAX_M, flown.text()
    for durations in flown.durations().values():
        assert len(durations) == NUM_SLOTS, flown.text()
        assert durations.min() >= SLOT_MIN_S, flown.text()


def assert_every_bridge_before_the_instant(out: dict) -> None:
    """Every bridge heard the planner's pass start before its instant: none joined late."""
    for k in UAVS:
        log = out[f"bridge{k}"].text()
        ahead = re.findall(r"pass start from the planner \(.*\): in ([\d.]+) s", log)
        assert ahead and "joining the pass" not in log, log[-2000:]


def assert_slot0_on_the_pass_start(out: dict) -> None:
    """Each agent started slot 0 at or after the planner's pass start (the one it logged)."""
    planned = re.findall(r"the pass starts in .* wall clock ([\d.]+)", out["planner"].text())
    assert planned, out["planner"].text()[-2000:]
    offsets = {}
    for k in UAVS:
        log = out[f"agent{k}"].text()
        heard = re.findall(r"pass start (?:in|[\d.]+ s ago).*wall clock ([\d.]+)", log)
        assert heard and heard[0] == planned[0], (heard, planned)
        found = SLOT0.search(log)
        assert found, log[-2000:]
        offsets[uav_name(k)] = float(found[2])
        # at or after it (the slot starts on the first position read at or after the instant)
        assert float(found[2]) >= -0.05 and float(found[1]) >= 0.0, found[0]
    print(f"slot 0 from the pass start: {offsets} s")


def test_a_cut_link_loses_the_uav_on_the_ground_and_holds_it_in_the_air(lab, ros_domain,
                                                                          tmp_path):
    out = start_swarm(lab, ros_domain, tmp_path, "static", num_slots=NUM_SLOTS,
                      uav_timeout_s=UAV_TIMEOUT_S, gcs_timeout_s=GCS_TIMEOUT_S).out
    procs = [o.proc for o in out.values()]
    assert wait_for(lambda: all(out[f"agent{k}"].first(r"slot 0 started") for k in UAVS),
                    150.0, procs), \
        "\n".join(f"== {n}\n{o.text()[-1500:]}" for n, o in out.items())
    assert_slot0_on_the_pass_start(out)
    time.sleep(2.0)
    cut_at = time.time()
    lab.switch(f"cut {uav_name(CUT)}")
    lost = rf"{uav_name(CUT)} lost at slot"
    assert wait_for(lambda: out["planner"].first(lost, cut_at), UAV_TIMEOUT_S + 10.0), \
        out["planner"].text()[-3000:]
    assert wait_for(lambda: out[f"bridge{CUT}"].first(r"commanding LOITER", cut_at),
                    GCS_TIMEOUT_S + 10.0), out[f"bridge{CUT}"].text()[-3000:]
    time.sleep(2.0)
    stop_recorder(out)
    bag = read_bag(tmp_path / "bag")
    replans = [(t, m) for t, m in bag["/formation"] if t > cut_at]
    assert replans, "no plan after the cut"
    t_plan, plan = replans[0]
    assert np.isnan(plan.poses[CUT].position.x), "the new plan still flies the cut UAV"
    assert all(np.isfinite(plan.poses[k].position.x) for k in UAVS if k != CUT)
    hold = out[f"bridge{CUT}"].first(r"commanding LOITER", cut_at)
    print(f"cut {uav_name(CUT)}: two-UAV plan after {t_plan - cut_at:.2f} s (uav_timeout_s "
          f"{UAV_TIMEOUT_S:g}), hold commanded after {hold - cut_at:.2f} s (gcs_timeout_s "
          f"{GCS_TIMEOUT_S:g})")
    assert t_plan - cut_at <= UAV_TIMEOUT_S + 1.0, t_plan - cut_at
    assert hold - cut_at <= GCS_TIMEOUT_S + 1.0, hold - cut_at
