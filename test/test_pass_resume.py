"""The planner's side of the mission clock, with a real planner process: what it does when
bridges report their UAVs `behind` on /diagnostics (held, too far behind their targets to
rejoin). The bridges are played by this test (FAULT INJECTION: it publishes each UAV's
uavK/mavlink/pose, flying the pass, and the `behind` statuses a held bridge publishes); the
real bridges' side is test_gcs_processes.py and the network lab's test_field_faults.py.

- one UAV behind while the others fly on: declared lost (`cannot keep the pass`) and the
  others re-planned without it, as a lost UAV;
- every flown UAV behind (the ground was gone for all of them): one resumed start, with the
  offset of the rearmost UAV, no re-plan."""
from __future__ import annotations

import math
import time

import pytest
from clean_stop import stop_cleanly
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Header

from uav_insar_planner.published import bridge_status_name
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import decode_formation
from uav_insar_planner.ros.start_msgs import decode_start
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs
from uav_insar_planner.track.passes import run_in_m

pytestmark = pytest.mark.timeout(90)
SPEED = 4.3  # the scenario's v_y (Table I)
RUN_IN = run_in_m(SPEED)  # the UAVs wait at their entries, this far before the start line


def offset_of(start: Header) -> float:
    """Where a start's targets wait (m past the start line): less than 0 for a pass from the
    hover at the entries, more for one resumed mid-track."""
    return decode_start(start, time.time())[2]


class FakeBridges:
    """FAULT INJECTION: the per-UAV bridges as the planner hears them. Each UAV holds its entry
    (RUN_IN before its start point) until the planner's pass start, then flies the pass at
    SPEED from where the start puts it, except the `held`
    ones, which stop where they are and report `behind` on the flown plan until a resumed
    start comes (as a real bridge rejoins on it), then fly on from its offset. Each reports on
    /diagnostics, once a second, the start it flies (`pass_start`, `pass_plan`), as the real
    bridge does. A `deaf` UAV's bridge takes no new start until a wall-clock time (one whose
    DDS reader matched a restarted planner late, or whose radio lost them all)."""

    def __init__(self, w) -> None:
        self.w, self.node = w, w.node
        self.starts: list[Header] = []
        self.flying: dict[int, Header] = {}  # uav -> the start its bridge took last
        self.deaf: dict[int, float] = {}  # uav -> no start taken before this (wall clock)
        self.points: list | None = None
        self.held: dict[int, float] = {}  # uav -> where it stopped (along track)
        self._poses = {k: self.node.create_publisher(PoseStamped, "/" + topics.mavlink_pose(k),
                                                     topics.DEPTH) for k in uavs(DEFAULT_NUM_UAVS)}
        self._diag = self.node.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, topics.DEPTH)
        self.node.create_subscription(Header, "/" + topics.FORMATION_START, self._on_start,
                                      topics.LATCHED)
        self._timer = self.node.create_timer(0.1, self._tick)
        self._diag_timer = self.node.create_timer(1.0, self._report)

    def _on_start(self, msg: Header) -> None:
        self.starts.append(msg)
        for k in uavs(DEFAULT_NUM_UAVS):
            if time.time() >= self.deaf.get(k, 0.0):
                self.flying[k] = msg

    def resumed(self, k: int) -> bool:
        """Whether UAV k's bridge took a resumed start (one with an offset)."""
        return k in self.flying and offset_of(self.flying[k]) > 0.0

    def along(self, k: int) -> float:
        """How far UAV k is past its start line now."""
        if k in self.held and not self.resumed(k):
            return self.held[k]
        if k not in self.flying:
            return -RUN_IN
        _, t0, offset = decode_start(self.flying[k], time.time())
        return offset + max(0.0, SPEED * (time.time() - t0))

    def _tick(self) -> None:
        if self.points is None and self.w.formations:
            self.points = list(decode_formation(self.w.formations[0]).points)
        if self.points is None:
            return
        for k, pub in self._poses.items():
            x, y, z = self.points[k]
            msg = PoseStamped()
            msg.header.stamp = self.node.get_clock().now().to_msg()
            msg.header.frame_id = topics.FRAME_ID
            msg.pose.position.x, msg.pose.position.y = x, y + self.along(k)
            msg.pose.position.z = z
            pub.publish(msg)

    def _report(self) -> None:
        self._diag.publish(DiagnosticArray(status=[self._status(k) for k in self.flying]))

    def _status(self, k: int) -> DiagnosticStatus:
        start = self.flying[k]
        label = start.frame_id.split(" at ")[0]
        values = [KeyValue(key="pass_plan", value=label),
                  KeyValue(key="pass_start", value=f"{decode_start(start, time.time())[1]:.3f}")]
        if k in self.held and not self.resumed(k):
            values.append(KeyValue(key="behind", value="9.00 m behind its target, more than "
                                   "the 4.30 m it may catch up: cannot keep the pass, keeps "
                                   "holding"))
        return DiagnosticStatus(level=DiagnosticStatus.WARN, name=bridge_status_name(k),
                                message="holding (LOITER): 9.00 m behind its target ...",
                                values=values)

    def hold(self, ks) -> None:
        for k in ks:
            self.held[k] = self.along(k)


def fly(w, procs, *args: str):
    planner = procs("planner", "-p", "uav_timeout_s:=30.0", *args)
    bridges = FakeBridges(w)
    assert w.spin_until(lambda: bridges.starts and bridges.along(0) > 8.0, 30.0, [planner]), \
        "no pass start"
    return planner, bridges


def test_one_uav_behind_alone_is_replanned_out_as_a_lost_uav(watcher, procs):
    planner, bridges = fly(watcher, procs)
    bridges.hold([2])
    held_at = time.monotonic()
    assert watcher.spin_until(lambda: len(watcher.formations) >= 2, 20.0, [planner])
    replanned_after = time.monotonic() - held_at
    survivors = decode_formation(watcher.formations[-1]).points
    log, = stop_cleanly([planner])
    assert survivors[2] is None and survivors[0] is not None and survivors[1] is not None
    assert "uav2 lost at slot" in log and "cannot keep the pass" in log, log[-3000:]
    assert len(bridges.starts) >= 1 and offset_of(bridges.starts[-1]) < 0.0  # none resumed
    print(f"uav2 behind alone: re-planned without it {replanned_after:.1f} s later")
    assert replanned_after >= 4.0  # BEHIND_GRACE_S: a swarm held together says so within it


def test_every_uav_behind_resumes_the_pass_from_the_rearmost(watcher, procs):
    planner, bridges = fly(watcher, procs)
    bridges.hold([0, 1, 2])
    rear = min(bridges.held.values())
    assert watcher.spin_until(lambda: any(offset_of(s) > 0.0 for s in bridges.starts), 10.0,
                              [planner]), [s.frame_id for s in bridges.starts]
    resumed = next(s for s in bridges.starts if offset_of(s) > 0.0)
    plan_id, t_start, offset = decode_start(resumed, time.time())
    watcher.spin_until(lambda: False, 1.0)  # its log line follows the start it sent
    log, = stop_cleanly([planner])
    assert offset == pytest.approx(rear, abs=0.3)  # (the pose read a tick before)
    assert t_start > time.time() - 5.0  # after start_delay_s from the decision: no sprint
    assert len(watcher.formations) == 1, "re-planned instead of resumed"
    assert "resuming the pass where the swarm is: every flown UAV holds behind" in log
    assert math.isfinite(offset) and plan_id.planner == "/planner"


def _instant(start: Header) -> float:
    return decode_start(start, time.time())[1]


def test_a_resumed_start_a_bridge_has_not_confirmed_is_moved_later_until_it_has(watcher,
                                                                                 procs):
    """Every UAV behind, and uav2's bridge hears no start for 5 s (FAULT INJECTION: a CI run's
    bridge matched a restarted planner's start writer 7 s late over a lossy radio): the planner
    moves the start later until uav2's bridge confirms it, and the whole swarm resumes on one
    instant, uav2 kept."""
    planner, bridges = fly(watcher, procs)
    bridges.deaf[2] = time.time() + 5.0
    bridges.hold([0, 1, 2])

    def settled() -> bool:  # uav2 took a resumed start, and the latest one's instant is past
        return bridges.resumed(2) and time.time() > _instant(bridges.starts[-1]) + 1.5

    assert watcher.spin_until(settled, 25.0, [planner]), [s.frame_id for s in bridges.starts]
    log, = stop_cleanly([planner])
    resumed = [s for s in bridges.starts if offset_of(s) > 0.0]
    first, last = _instant(resumed[0]), _instant(resumed[-1])
    print(f"the resumed start moved {last - first:.1f} s later, "
          f"{log.count('the resumed pass waits')} times")
    assert "the resumed pass waits for the bridge of uav2, which has not confirmed" in log, \
        log[-3000:]
    assert "bridge of uav0" not in log and "bridge of uav1" not in log, log[-3000:]
    assert last > first and time.time() > last
    for k in range(3):  # one instant for the whole swarm, the last one published
        assert _instant(bridges.flying[k]) == pytest.approx(last, abs=1e-3), k
    assert len(watcher.formations) == 1, "uav2 was re-planned out"
    assert log.count("resuming the pass where the swarm is") == 1


WAIT_S = 5.0  # start_confirm_wait_s (default 20 s)


def test_a_bridge_that_never_confirms_the_resumed_start_is_left_behind(watcher, procs):
    """uav2's bridge never hears the resumed start (FAULT INJECTION): the planner waits
    start_confirm_wait_s for it, says so, lets the others fly on, and re-plans without uav2."""
    planner, bridges = fly(watcher, procs, "-p", f"start_confirm_wait_s:={WAIT_S}")
    bridges.deaf[2] = time.time() + 600.0
    bridges.hold([0, 1, 2])
    held_at = time.monotonic()
    assert watcher.spin_until(lambda: len(watcher.formations) >= 2, 20.0, [planner])
    waited = time.monotonic() - held_at
    log, = stop_cleanly([planner])
    print(f"uav2 never confirmed: re-planned without it {waited:.1f} s after the hold")
    assert "the resumed pass starts without its start confirmed by the bridge of uav2" in log, \
        log[-3000:]
    assert "uav2 lost at slot" in log and "cannot keep the pass" in log, log[-3000:]
    assert decode_formation(watcher.formations[-1]).points[2] is None
    assert waited >= WAIT_S
    assert bridges.resumed(0) and bridges.resumed(1) and not bridges.resumed(2)
