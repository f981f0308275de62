"""The bridge against bare pymavlink peers on loopback UDP: setpoint content and rate,
our heartbeat, heartbeat loss and return, malformed traffic, configuration errors."""
import struct
import time

import pytest
from mavlink_fakes import MAV, FakePeer, wait_until

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.mavlink.setpoints import MASK_POSITION, MASK_POSITION_VELOCITY
from uav_insar_planner.track.speed_profile import BRAKE_MPS2, braked_pass

pytestmark = pytest.mark.timeout(60)
SYSIDS = (2, 3, 4)
FORMATION = [(-5.0, 0.0, 12.0), (0.0, 0.0, 15.0), (5.0, 0.0, 12.0)]


@pytest.fixture
def peers():
    made = [FakePeer(s, compid=1, heartbeat_hz=5.0) for s in SYSIDS]
    yield made
    for p in made:
        p.close()


def make_bridge(peers, **kw):
    cfg = dict(connections=tuple(f"udpout:127.0.0.1:{p.port}" for p in peers),
               target_sysids=SYSIDS[:len(peers)], speed_mps=0.0, capture_radius_m=0.0)
    cfg.update(kw)
    return Bridge(BridgeConfig(**cfg))


@pytest.mark.parametrize("rate", [10.0, 4.0])
def test_setpoints_content_and_rate(peers, rate):
    origin = (100.0, -50.0, 2.0)
    with make_bridge(peers, setpoint_rate_hz=rate, track_bearing_deg=90.0,
                     origin_ned_m=origin, velocity_feedforward=False) as bridge:
        bridge.set_formation(FORMATION)
        t0 = time.monotonic()
        time.sleep(3.2)
    for peer, sysid, (x, y, z) in zip(peers, SYSIDS, FORMATION, strict=True):
        sps = [m for t, m in peer.messages("SET_POSITION_TARGET_LOCAL_NED")]
        assert sps
        for m in sps:
            assert (m.target_system, m.target_component) == (sysid, 1)
            assert m.get_srcSystem() == 255 and m.get_srcComponent() == 191
            assert m.coordinate_frame == MAV.MAV_FRAME_LOCAL_NED
            assert m.type_mask == MASK_POSITION == 3576
            # bearing 90: N = -x + N0, E = y + E0, D = -z + D0
            assert m.x == pytest.approx(-x + 100.0, abs=1e-4)
            assert m.y == pytest.approx(y - 50.0, abs=1e-4)
            assert m.z == pytest.approx(-z + 2.0, abs=1e-4)
        window = [t for t, _ in peer.messages("SET_POSITION_TARGET_LOCAL_NED", t0 + 1.0)
                  if t < t0 + 3.0]
        assert len(window) == pytest.approx(2.0 * rate, rel=0.2)
        hbs = [m for _, m in peer.messages("HEARTBEAT")]
        assert 2 <= len(hbs) <= 5  # 1 Hz over ~3.2 s
        assert all(m.get_srcSystem() == 255 and m.get_srcComponent() == 191
                   and m.type == MAV.MAV_TYPE_ONBOARD_CONTROLLER for m in hbs)


def test_component_follows_the_vehicle_heartbeat():
    peer = FakePeer(7, compid=42, heartbeat_hz=5.0)
    try:
        with make_bridge([peer], target_sysids=(7,)) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])
            assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
            since = time.monotonic() + 0.2
            m = peer.wait_for("SET_POSITION_TARGET_LOCAL_NED", 3.0, since)
            assert (m.target_system, m.target_component) == (7, 42)
    finally:
        peer.close()


def test_velocity_feedforward_moves_along_the_track(peers):
    with make_bridge(peers, velocity_feedforward=True, speed_mps=3.0,
                     track_bearing_deg=90.0) as bridge:
        bridge.set_formation(FORMATION)
        time.sleep(2.8)  # the ramp from the hover (3 m/s at RAMP_MPS2: 2 s), then cruise
    sps = [(t, m) for t, m in peers[1].messages("SET_POSITION_TARGET_LOCAL_NED")]
    assert all(m.type_mask == MASK_POSITION_VELOCITY == 3520 for _, m in sps)
    assert sps[-1][1].vx == pytest.approx(0.0, abs=1e-6)
    assert sps[-1][1].vy == pytest.approx(3.0, abs=1e-6)  # along-track = east at 90 deg
    cruise = [(t, m) for t, m in sps if t >= sps[-1][0] - 0.6]
    (t1, a), (t2, b) = cruise[0], cruise[-1]
    assert (b.y - a.y) / (t2 - t1) == pytest.approx(3.0, rel=0.15)
    assert b.x == pytest.approx(0.0, abs=1e-4) and b.z == pytest.approx(-15.0, abs=1e-4)


def test_heartbeat_loss_and_return_of_one_vehicle(peers):
    with make_bridge(peers, heartbeat_timeout_s=1.0) as bridge:
        bridge.set_formation(FORMATION)
        assert wait_until(lambda: all(s.link == "linked" for s in bridge.status()), 3.0)
        peers[1].heartbeats_on = False
        t_off = time.monotonic()
        assert wait_until(lambda: bridge.status()[1].link == "lost", 3.0)
        assert time.monotonic() - t_off >= 0.9
        assert [s.link for s in bridge.status()] == ["linked", "lost", "linked"]
        t_lost = time.monotonic()
        time.sleep(1.0)
        for peer in peers:  # nobody stops receiving setpoints, the lost one included
            window = [t for t, _ in peer.messages("SET_POSITION_TARGET_LOCAL_NED", t_lost)]
            assert len(window) >= 8
        peers[1].heartbeats_on = True
        assert wait_until(lambda: bridge.status()[1].link == "linked", 3.0)
        texts = [(e.uav, e.level, e.text) for e in bridge.drain_events()]
    assert any(u == 1 and lv == "warn" and "lost" in t for u, lv, t in texts)
    assert any(u == 1 and "found again" in t for u, _, t in texts)
    assert not any(u in (0, 2) and "lost" in t for u, _, t in texts)


def test_default_loss_timeout_is_five_seconds():
    assert BridgeConfig(connections=("udpout:127.0.0.1:9",),
                        target_sysids=(2,)).heartbeat_timeout_s == 5.0


def test_malformed_traffic_is_counted_and_ignored(peers):
    with make_bridge(peers) as bridge:
        bridge.set_formation(FORMATION)
        peer = peers[0]
        peer.wait_for("HEARTBEAT", 3.0)  # the bridge's socket address is now known
        assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
        good = peer.mav.heartbeat_encode(2, 3, 0, 0, 4).pack(peer.mav)
        bad_crc = good[:-2] + struct.pack("<H", (struct.unpack("<H", good[-2:])[0] ^ 0xFFFF))
        unknown = bytearray(good)
        unknown[7:10] = (60000).to_bytes(3, "little")  # a message id no dialect has
        foreign = FakePeer(99)
        foreign_hb = foreign.mav.heartbeat_encode(2, 3, 0, 0, 4).pack(foreign.mav)
        foreign.close()
        before = bridge.link_stats()[f"udpout:127.0.0.1:{peer.port}"]
        for _ in range(5):
            peer.send_raw(b"\x00garbage\xff" * 3)
            peer.send_raw(good[:9])  # truncated frame, its own datagram
            peer.send_raw(bad_crc)
            peer.send_raw(bytes(unknown))
            peer.send_raw(foreign_hb)
            peer.send_raw(good)  # still understood right after the junk
        key = f"udpout:127.0.0.1:{peer.port}"
        assert wait_until(lambda: bridge.link_stats()[key].foreign - before.foreign >= 5, 3.0)
        after = bridge.link_stats()[key]
        assert after.truncated - before.truncated == 5
        assert after.bad_data - before.bad_data >= 10  # garbage + bad CRC
        assert after.unknown_msgid - before.unknown_msgid == 5
        assert bridge.status()[0].link == "linked"
        since = time.monotonic()
        time.sleep(0.6)
        assert len(peer.messages("SET_POSITION_TARGET_LOCAL_NED", since)) >= 4


@pytest.mark.parametrize("change, words", [
    (dict(setpoint_rate_hz=1.0), "setpoint_rate_hz"),
    (dict(setpoint_rate_hz=float("nan")), "setpoint_rate_hz"),
    (dict(target_sysids=(2, 2, 4)), "repeats"),
    (dict(target_sysids=(2, 3)), "connections"),
    (dict(target_sysids=(2, 3, 256)), "1..255"),
    (dict(source_sysid=3), "source_sysid"),
    (dict(autopilot="inav"), "autopilot"),
    (dict(speed_mps=-1.0), "speed_mps"),
    (dict(origin_ned_m=(0.0, 1.0)), "origin_ned_m"),
    (dict(connections=("udpout:nowhere",) * 3), "HOST:PORT"),
    (dict(connections=("flight.tlog",) * 3), "log file"),
    (dict(connections=("udpout:no.such.host.invalid:14550",) * 3), "does not resolve"),
    (dict(track_bearing_deg=1e308), "track_bearing_deg"),
    (dict(origin_ned_m=(1e39, 0.0, 0.0)), "origin_ned_m"),
    (dict(capture_radius_m=float("inf")), "capture_radius_m"),
    (dict(signing_key_file="/no/such/key"), "signing_key_file"),
    (dict(speed_mps=1000.0, track_duration_s=1e6), "1e+09 m pass"),
])
def test_bad_configuration_is_one_line(change, words):
    cfg = dict(connections=("udpout:127.0.0.1:9",) * 3, target_sysids=SYSIDS)
    cfg.update(change)
    with pytest.raises(ValueError) as err:
        Bridge(BridgeConfig(**cfg))
    assert words in str(err.value) and "\n" not in str(err.value)


def test_braked_pass_target_brakes_to_the_pass_end():
    """Cruise, then a constant deceleration that stops exactly at speed * duration."""
    v, d = 4.3, 5.0
    assert braked_pass(1.0, v, 0.0) == (4.3, 4.3)  # endless pass: pure cruise
    assert braked_pass(2.0, v, d) == pytest.approx((8.6, 4.3))  # cruising
    t_brake = d - v / BRAKE_MPS2 / 2
    ts = [t_brake + i * 0.01 for i in range(400)]
    pts = [braked_pass(t, v, d) for t in ts]
    steps = list(zip(pts[:-1], pts[1:], strict=True))
    assert all(b[0] >= a[0] for a, b in steps)  # never backwards
    assert all(abs(b[1] - a[1]) <= BRAKE_MPS2 * 0.01 + 1e-9 for a, b in steps)
    assert pts[-1] == pytest.approx((v * d, 0.0))  # stops at the pass end
    # a pass too short to brake at BRAKE_MPS2 brakes harder and still ends at speed * d
    assert braked_pass(10.0, 3.0, 1.0) == pytest.approx((3.0, 0.0))


def test_type_masks_are_the_named_ignore_bits_mavros_uses():
    """Built from MAV_POSITION_TARGET_TYPEMASK bits; the values autopilots expect."""
    assert MASK_POSITION == 3576
    assert MASK_POSITION_VELOCITY == 3520


class BootingCopter:
    """Scripts a FakePeer like a cold-booting ArduCopter: the first GUIDED request is
    ACCEPTED but does not stick, the first `refusals` arm requests fail with a PreArm
    STATUSTEXT and FAILED; NAV_TAKEOFF is accepted and the position jumps to its altitude."""

    def __init__(self, refusals: int = 2):
        self.refusals, self.mode_requests, self.commands = refusals, 0, []
        self.down = 0.0

    def __call__(self, peer, msg) -> None:
        if msg.get_type() != "COMMAND_LONG":
            return
        self.commands.append(msg.command)
        result = MAV.MAV_RESULT_ACCEPTED
        if msg.command == MAV.MAV_CMD_DO_SET_MODE:
            self.mode_requests += 1
            if self.mode_requests > 1:
                peer.custom_mode = int(msg.param2)
        elif msg.command == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
            if self.refusals > 0:
                self.refusals -= 1
                peer.mav.send(peer.mav.statustext_encode(
                    MAV.MAV_SEVERITY_CRITICAL, b"PreArm: Need Position Estimate"))
                result = MAV.MAV_RESULT_FAILED
            else:
                peer.armed = True
        elif msg.command == MAV.MAV_CMD_NAV_TAKEOFF:
            self.down = -msg.param7
        peer.mav.send(peer.mav.command_ack_encode(msg.command, result))
        peer.mav.send(peer.mav.local_position_ned_encode(0, 0.0, 0.0, self.down, 0, 0, 0))


def test_cold_start_readiness_retries_arming_and_resets_a_dropped_mode():
    script = BootingCopter()
    peer = FakePeer(2, heartbeat_hz=5.0, custom_mode=0, respond=script)
    try:
        with make_bridge([peer], target_sysids=(2,), arm_and_takeoff=True) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])
            t0 = time.monotonic()
            phases = set()

            def done() -> bool:
                phases.add(bridge.status()[0].phase)
                return bridge.status()[0].sequence == "done"

            assert wait_until(done, 20.0), bridge.drain_events()
            events = [e.text for e in bridge.drain_events()]
            took = time.monotonic() - t0
            since = time.monotonic()
            assert peer.wait_for("SET_POSITION_TARGET_LOCAL_NED", 2.0, since)
        assert script.mode_requests == 2 and script.refusals == 0
        assert script.commands.count(MAV.MAV_CMD_COMPONENT_ARM_DISARM) == 3
        assert MAV.MAV_CMD_NAV_TAKEOFF in script.commands
        assert "prearm: PreArm: Need Position Estimate" in phases, phases
        assert any("sysid 2 PreArm: Need Position Estimate" in t for t in events), events
        assert any("arm: FAILED" in t and "retrying" in t for t in events), events
        assert took < 15.0
    finally:
        peer.close()


def test_no_setpoints_to_a_disarmed_copter_outside_guided():
    peer = FakePeer(2, heartbeat_hz=5.0, custom_mode=0)  # STABILIZE
    try:
        with make_bridge([peer], target_sysids=(2,)) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])
            assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
            time.sleep(1.0)
            assert not peer.messages("SET_POSITION_TARGET_LOCAL_NED")
            assert bridge.status()[0].phase.startswith("waiting for position")
            peer.custom_mode = 4  # the pilot switches to GUIDED: the stream starts
            assert peer.wait_for("SET_POSITION_TARGET_LOCAL_NED", 2.0)
    finally:
        peer.close()


def test_separation_below_the_safety_distance_is_warned(peers):
    with make_bridge(peers, min_separation_m=2.0) as bridge:
        bridge.set_formation([(-0.75, 0.0, 12.0), (0.75, 0.0, 12.0), (10.0, 0.0, 12.0)])
        status = bridge.status()
        events = bridge.drain_events()
    assert status[0].separation == "1.50 m from uav1" and status[1].separation
    assert status[2].separation == ""
    assert any(e.level == "warn" and "uav0 and uav1" in e.text and "1.50 m" in e.text
               for e in events)


def test_a_dead_tcp_link_does_not_stall_the_others(peers):
    import socket
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    port = closed.getsockname()[1]
    closed.close()  # nobody listens there: every connect is refused
    t0 = time.monotonic()
    bridge = Bridge(BridgeConfig(
        connections=(f"tcp:127.0.0.1:{port}",) + tuple(
            f"udpout:127.0.0.1:{p.port}" for p in peers[1:]),
        target_sysids=SYSIDS, speed_mps=0.0, capture_radius_m=0.0))
    assert time.monotonic() - t0 < 0.5  # the constructor never waits for TCP
    with bridge:
        bridge.set_formation(FORMATION)
        since = time.monotonic() + 1.0
        time.sleep(3.0)
        status = bridge.status()
    assert status[0].link == "waiting" and not status[0].link_up
    for peer in peers[1:]:
        window = [t for t, _ in peer.messages("SET_POSITION_TARGET_LOCAL_NED", since)]
        assert len(window) == pytest.approx(20, rel=0.2)
