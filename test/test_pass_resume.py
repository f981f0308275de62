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
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Header

from uav_insar_planner.demo.processes import stop_nodes
from uav_insar_planner.published import bridge_status_name
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import decode_formation
from uav_insar_planner.ros.start_msgs import decode_start
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs

pytestmark = pytest.mark.timeout(90)
SPEED = 4.3  # the scenario's v_y (Table I)


class FakeBridges:
    """FAULT INJECTION: the per-UAV bridges as the planner hears them. Each UAV holds its start
    point until the planner's pass start, then flies the pass at SPEED, except the `held`
    ones, which stop where they are and report `behind` on the flown plan."""

    def __init__(self, w) -> None:
        self.w, self.node = w, w.node
        self.starts: list[Header] = []
        self.points: list | None = None
        self.held: dict[int, float] = {}  # uav -> where it stopped (along track)
        self._poses = {k: self.node.create_publisher(PoseStamped, "/" + topics.mavlink_pose(k),
                                                     topics.DEPTH) for k in uavs(DEFAULT_NUM_UAVS)}
        self._diag = self.node.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, topics.DEPTH)
        self.node.create_subscription(Header, "/" + topics.FORMATION_START, self.starts.append,
                                      topics.LATCHED)
        self._timer = self.node.create_timer(0.1, self._tick)
        self._diag_timer = self.node.create_timer(1.0, self._report)

    def along(self, k: int) -> float:
        """How far UAV k is past its start line now."""
        if k in self.held:
            return self.held[k]
        if not self.starts:
            return 0.0
        _, t0, offset = decode_start(self.starts[0], time.time())
        return max(0.0, SPEED * (time.time() - t0))

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
        if not self.held or not self.starts:
            return
        label = self.starts[0].frame_id
        self._diag.publish(DiagnosticArray(status=[DiagnosticStatus(
            level=DiagnosticStatus.WARN, name=bridge_status_name(k),
            message="holding (LOITER): 9.00 m behind its target ...",
            values=[KeyValue(key="pass_plan", value=label),
                    KeyValue(key="behind", value="9.00 m behind its target, more than the "
                                                 "4.30 m it may catch up: cannot keep the "
                                                 "pass, keeps holding")])
            for k in self.held]))

    def hold(self, ks) -> None:
        for k in ks:
            self.held[k] = self.along(k)


def fly(w, procs):
    planner = procs("planner", "-p", "uav_timeout_s:=30.0")
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
    codes = stop_nodes([planner])
    assert codes == [0]
    log = planner.stdout.read()
    assert survivors[2] is None and survivors[0] is not None and survivors[1] is not None
    assert "uav2 lost at slot" in log and "cannot keep the pass" in log, log[-3000:]
    assert len(bridges.starts) >= 1 and " at " not in bridges.starts[-1].frame_id
    print(f"uav2 behind alone: re-planned without it {replanned_after:.1f} s later")
    assert replanned_after >= 4.0  # BEHIND_GRACE_S: a swarm held together says so within it


def test_every_uav_behind_resumes_the_pass_from_the_rearmost(watcher, procs):
    planner, bridges = fly(watcher, procs)
    bridges.hold([0, 1, 2])
    rear = min(bridges.held.values())
    assert watcher.spin_until(lambda: any(" at " in s.frame_id for s in bridges.starts), 10.0,
                              [planner]), [s.frame_id for s in bridges.starts]
    resumed = next(s for s in bridges.starts if " at " in s.frame_id)
    plan_id, t_start, offset = decode_start(resumed, time.time())
    watcher.spin_until(lambda: False, 1.0)  # its log line follows the start it sent
    codes = stop_nodes([planner])
    assert codes == [0]
    log = planner.stdout.read()
    assert offset == pytest.approx(rear, abs=0.3)  # (the pose read a tick before)
    assert t_start > time.time() - 5.0  # after start_delay_s from the decision: no sprint
    assert len(watcher.formations) == 1, "re-planned instead of resumed"
    assert "resuming the pass where the swarm is: every flown UAV holds behind" in log
    assert math.isfinite(offset) and plan_id.planner == "/planner"
