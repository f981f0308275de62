"""Faults of the field across hosts (issue 27, item 5): the swarm of test_swarm_across_hosts.py
(netlab_swarm.py: the planner and the recorder on the ground, per UAV a vehicle simulator,
its bridge and its autopilot-position agent, each UAV's radio lossy) flying a 40-slot pass
of 1 s slots, judged by how it flew, not only by its ending: from the bag written on the
ground, the along-track spread of the swarm, each UAV's fastest speed and its slot durations
(swarm_track.py; the vehicles report their true position, noise is not the point here).

- The planner SIGKILLed mid-pass (slot 10) and started again 4 s later, at 10 % loss: the
  bridges hold while the ground is silent; the new planner resumes the pass with a published
  start. No UAV ever flies faster than the planned speed v_y + 1 m/s (issue 27's first fault:
  a sprint at the vehicles' 10 m/s to the dead planner's clock), the mission completes, the
  swarm flies in formation after the resume.
- 30 % loss on every UAV link from launch for the whole mission (its third and fourth
  faults): it starts, no bridge holds for a lost heartbeat, every agent completes every slot,
  in formation (along-track spread under 1 m), no slot shorter than 0.9 of its duration.

The late pass start at 10 % loss (its second fault) is checked by test_swarm_across_hosts.py's
lossy-radio test. Each test prints its figures. Skipped with the lab's reason where network
namespaces or TAP devices are not permitted.
"""
from __future__ import annotations

import re
import time

import process_group
import pytest
from netlab_swarm import (
    FAST_DDS_HEARTBEAT_S,
    RADIO,
    UAVS,
    Swarm,
    lab_fixture,
    radio,
    read_bag,
    start_swarm,
    timeline,
    wait_for,
)
from swarm_track import Pass, agent_durations

from uav_insar_planner import load_params
from uav_insar_planner.swarm import uav_name

pytestmark = pytest.mark.timeout(300)

NUM_SLOTS = 40
SLOT_S = 1.0
V_Y = load_params().speed  # the scenario's speed along the track [m/s]
SPEED_MAX_MPS = V_Y + 1.0
SPREAD_MAX_M = 1.0
SLOT_MIN = 0.9  # of SLOT_S
KILL_AT_SLOT = 10
RESTART_AFTER_S = 4.0
STARTUP_S = 60.0  # discovery, plan, climb and capture at 30 % loss, on a busy 2-core host
FINISH_S = 30.0  # the pass's end after its last slot's instant: hold, replan, resume
PLANNED = re.compile(r"the pass starts in .* wall clock ([\d.]+)")
# what each test prints of its processes' logs, against its first pass start
EVENTS = (r"(?i)pass start|resum|rejoin|cannot keep|lost|silent|heard again|LOITER|GUIDED|"
          r"hold|mission complete|overdue|joining|\]: plan |ERROR")

lab = lab_fixture(RADIO)
lossy_lab = lab_fixture(radio(0.3), name="lossy_lab")


def _started(swarm: Swarm) -> float:
    """The planner's pass start (wall clock), once it logged it; AssertionError with the
    story if it did not within STARTUP_S."""
    planner = swarm.out["planner"]
    assert wait_for(lambda: PLANNED.search(planner.text()), STARTUP_S, swarm.procs()), \
        _story(swarm)
    return float(PLANNED.search(planner.text())[1])


def _complete(swarm: Swarm, procs) -> bool:
    """Every agent said "mission complete" within FINISH_S of its last slot's instant."""
    return wait_for(lambda: all(swarm.out[f"agent{k}"].first(r"mission complete")
                                for k in UAVS), NUM_SLOTS * SLOT_S + FINISH_S, procs)


def _story(swarm: Swarm) -> str:
    """The events of every process (EVENTS) from the planner's pass start, and each tail."""
    planned = PLANNED.search(swarm.out["planner"].text())
    t0 = float(planned[1]) if planned else time.time()
    return f"{timeline(swarm.out, EVENTS, t0)}\n{swarm.logs(600)}"


def _flown(swarm: Swarm) -> Pass:
    """Closes the bag once the last positions crossed the radio; the pass flown."""
    # a lost reliable sample is repaired at the writer's next heartbeat (NACK lost too: two)
    time.sleep(2 * FAST_DDS_HEARTBEAT_S)
    swarm.stop_recorder()
    flown = Pass(read_bag(swarm.tmp_path / "bag"), UAVS, NUM_SLOTS, V_Y, SLOT_S)
    print(timeline(swarm.out, EVENTS, flown.start))
    print(flown.text())
    return flown


def _assert_every_slot(swarm: Swarm, flown: Pass, shortest_s: float,
                       since: float | None = None) -> None:
    """Every agent flew every slot; none that began at or after `since` shorter than
    `shortest_s` in the bag's track, nor in the agent's own account (its last line) when
    `since` is None."""
    short = flown.short_slots(shortest_s, since)
    for k in UAVS:
        log = swarm.out[f"agent{k}"].text()
        assert f"{uav_name(k)}: mission complete: {NUM_SLOTS} slots" in log, log[-2000:]
        assert len(flown.crossed[k]) == NUM_SLOTS + 1, flown.text()
        assert not any(short.values()), f"(slot, s) shorter than {shortest_s:.2f} s: {short}"
        said = agent_durations(log)
        assert since is not None or said is None or said[0] >= shortest_s, (uav_name(k), said)


def test_a_planner_restarted_mid_pass_resumes_it_at_the_planned_speed(lab, ros_domain,
                                                                       tmp_path):
    swarm = start_swarm(lab, ros_domain, tmp_path, "subnet", num_slots=NUM_SLOTS,
                        noise_std_m=0.0)
    out = swarm.out
    pass_start = _started(swarm)
    time.sleep(max(0.0, pass_start + KILL_AT_SLOT * SLOT_S - time.time()))
    process_group.kill_group(out["planner"].proc)  # SIGKILL to its group: the ground is gone
    killed_at = time.time()
    time.sleep(RESTART_AFTER_S)
    restarted_at = time.time()
    swarm.start_planner("planner again")
    alive = [o.proc for name, o in out.items() if name != "planner"]
    assert _complete(swarm, alive), _story(swarm)
    resumed = out["planner again"].first(r"(?i)resum")
    flown = _flown(swarm)
    print(f"planner killed {killed_at - pass_start:.1f} s into the pass, started again after "
          f"{restarted_at - killed_at:.1f} s; "
          + (f"resumed {resumed - restarted_at:.1f} s later" if resumed else "no resume"))
    print(flown.text(killed_at))
    for k, (_, ground) in flown.speeds(killed_at).items():
        assert ground <= SPEED_MAX_MPS, (uav_name(k), flown.text(killed_at))
    assert resumed, out["planner again"].text()[-3000:]
    # in formation from the resumed pass's instant on; before it each UAV came back to the
    # rearmost's line from where its bridge held on the silence (a CI run: 1.1 m apart, the
    # bridges' gcs timeouts a quarter second apart at 4.3 m/s)
    # (the last instant: moved later while a bridge had not confirmed the start)
    instant = float(re.findall(r"(?:resuming the pass where the swarm is|the resumed pass "
                               r"waits).*wall clock ([\d.]+)", out["planner again"].text())[-1])
    assert flown.spread(instant) < SPREAD_MAX_M, flown.text(instant)
    # flown at most V_Y + 1 m/s, a slot lasts at least V_Y / (V_Y + 1) of its duration
    _assert_every_slot(swarm, flown, SLOT_S * V_Y / SPEED_MAX_MPS, killed_at)


def test_a_whole_mission_at_30_percent_loss_flies_in_formation(lossy_lab, ros_domain,
                                                               tmp_path):
    swarm = start_swarm(lossy_lab, ros_domain, tmp_path, "subnet", num_slots=NUM_SLOTS,
                        noise_std_m=0.0)
    _started(swarm)
    assert _complete(swarm, swarm.procs()), _story(swarm)
    flown = _flown(swarm)
    for k in UAVS:
        log = swarm.out[f"bridge{k}"].text()
        assert "ground station silent" not in log, log[-3000:]  # no hold for lost heartbeats
    assert flown.spread() < SPREAD_MAX_M, flown.text()
    _assert_every_slot(swarm, flown, SLOT_MIN * SLOT_S)


SILENT_SLOTS = 30
SHORT_CUT_S = 3.5  # gcs_timeout_s 3 s: a hold, then the ground heard again at once
LONG_CUT_S = 7.0  # 4 s of a 4.3 m/s pass held: 17 m behind, far more than 1 s of it


def test_a_ground_heard_again_soon_is_rejoined_and_late_replans_the_uav_out(lab, ros_domain,
                                                                           tmp_path):
    """The radio to uav2 only (ground -> UAV) cut twice: its bridge holds on the silence
    while the planner still hears its poses (issue 27's third fault: it held to the end, and
    nothing was said). Back after a short cut it rejoins the pass; after a long one it says it
    cannot keep the pass, and the planner re-plans without it (on that word, or on the silence
    of its stalled writers, whichever comes first) while the others fly on."""
    swarm = start_swarm(lab, ros_domain, tmp_path, "subnet", num_slots=SILENT_SLOTS,
                        noise_std_m=0.0)
    out, cut = swarm.out, uav_name(UAVS[-1])
    pass_start = _started(swarm)
    time.sleep(max(0.0, pass_start + 4 * SLOT_S - time.time()))
    lab.switch(f"cut {cut} dir=out")
    time.sleep(SHORT_CUT_S)
    lab.switch(f"restore {cut} dir=out")
    bridge = out[f"bridge{UAVS[-1]}"]
    assert wait_for(lambda: bridge.first(r"rejoins the pass"), 5.0, swarm.procs()), \
        _story(swarm)
    time.sleep(4.0)
    lab.switch(f"cut {cut} dir=out")
    long_at = time.time()
    time.sleep(LONG_CUT_S)
    lab.switch(f"restore {cut} dir=out")
    planner = out["planner"]
    # Either the bridge's word reaches the planner first, or the silence does: a CI run's bag
    # showed uav2's poses stop reaching the ground for 3.3 s of the one-way cut (DDS gets no
    # acknowledgement back), past uav_timeout_s. Both re-plan the UAV out.
    assert wait_for(lambda: planner.first(
        rf"{cut} lost at slot \d+ \(.*(cannot keep the pass|no pose, rate or offload).*re-planned "
        rf"from slot \d+ without {cut}", long_at), 15.0, swarm.procs()), _story(swarm)
    others = [k for k in UAVS if k != UAVS[-1]]
    assert wait_for(lambda: all(out[f"agent{k}"].first(r"mission complete") for k in others),
                    SILENT_SLOTS * SLOT_S + FINISH_S, swarm.procs()), _story(swarm)
    flown = _flown(swarm)
    text = bridge.text()
    assert text.count("ground station silent for") == 2, text[-3000:]
    assert "cannot keep the pass, keeps holding" in text, text[-3000:]
    assert "no target in the new plan" in text or "no target in the plan flown" in text, \
        text[-3000:]
    assert "ground station silent" not in "".join(out[f"bridge{k}"].text() for k in others)
    for k in others:
        assert f"mission complete: {SILENT_SLOTS} slots" in out[f"agent{k}"].text()
    # the others flew on in formation, at the planned speed, through both cuts and the re-plan
    survivors = Pass(read_bag(swarm.tmp_path / "bag"), others, SILENT_SLOTS, V_Y, SLOT_S)
    print(survivors.text())
    assert survivors.spread() < SPREAD_MAX_M, survivors.text()
    assert not any(survivors.short_slots(SLOT_MIN * SLOT_S).values()), survivors.text()
    assert len(flown.crossed[UAVS[-1]]) < SILENT_SLOTS + 1  # it stayed where it held
