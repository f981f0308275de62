"""Hostile and careless MAVLink input, bridge side, on real loopback UDP: values
that do not fit MAVLink's float32 going out, non-finite positions coming in, heartbeats for a
known sysid from a stranger. Each is dropped and counted, logged at a bounded rate, and the
I/O thread lives on."""
import time

import pytest
from mavlink_fakes import MAV, FakePeer, wait_until

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig

pytestmark = pytest.mark.timeout(60)
NAN, INF = float("nan"), float("inf")


def bridge_for(peers, sysids, **kw):
    cfg = dict(connections=tuple(f"udpout:127.0.0.1:{p.port}" for p in peers),
               target_sysids=tuple(sysids), speed_mps=0.0, capture_radius_m=0.0)
    cfg.update(kw)
    return Bridge(BridgeConfig(**cfg))


def key(peer):
    return f"udpout:127.0.0.1:{peer.port}"


@pytest.mark.parametrize("bad_pose", [(1e39, 0.0, 10.0), (0.0, -3.5e38, 10.0),
                                      (0.0, 0.0, 1e300)])
def test_a_setpoint_that_does_not_fit_float32_is_dropped_and_the_thread_lives(bad_pose):
    peers = [FakePeer(2, heartbeat_hz=5.0), FakePeer(3, heartbeat_hz=5.0)]
    try:
        with bridge_for(peers, (2, 3), setpoint_rate_hz=20.0) as bridge:
            bridge.set_formation([bad_pose, (1.0, 0.0, 10.0)])
            time.sleep(1.5)
            assert bridge.failure is None
            stats = bridge.link_stats()
            assert stats[key(peers[0])].unsendable >= 10  # 20 Hz for 1.5 s, every one dropped
            assert stats[key(peers[1])].unsendable == 0
            assert peers[0].messages("SET_POSITION_TARGET_LOCAL_NED") == []
            assert len(peers[1].messages("SET_POSITION_TARGET_LOCAL_NED")) >= 10
            # the next formation flies again: nothing was corrupted
            bridge.set_formation([(2.0, 0.0, 10.0), (1.0, 0.0, 10.0)])
            m = peers[0].wait_for("SET_POSITION_TARGET_LOCAL_NED", 2.0)
            assert (m.x, m.y, m.z) == (0.0, 2.0, -10.0)
            events = [e.text for e in bridge.drain_events() if "unsendable" in e.text]
        assert len(events) == 1, events  # rate-limited: one line for the whole burst
        assert "sysid 2" in events[0]
    finally:
        for p in peers:
            p.close()


def send_positions(peer, position, n=8, period=0.05):
    for _ in range(n):
        peer.mav.send(peer.mav.local_position_ned_encode(0, *position, 0.0, 0.0, 0.0))
        time.sleep(period)


@pytest.mark.parametrize("spoof", [(NAN, NAN, NAN), (0.0, INF, -10.0), (NAN, 0.0, -10.0)])
def test_non_finite_positions_are_no_telemetry_and_never_pass_the_capture_gate(spoof):
    """math.dist with a NaN is NaN, and NaN > r is False: the old gate let it through."""
    peer = FakePeer(2, heartbeat_hz=5.0)
    try:
        with bridge_for([peer], (2,), capture_radius_m=1.0) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])  # start point N, E, D = 0, 0, -10
            peer.wait_for("HEARTBEAT", 3.0)
            send_positions(peer, spoof, n=20)
            assert wait_until(lambda: bridge.link_stats()[key(peer)].bad_value == 20, 2.0)
            assert not bridge.track_started()
            assert bridge.status()[0].position_ned is None  # kept nothing
            assert bridge.failure is None
            send_positions(peer, (0.0, 0.0, -10.0))  # really there now
            assert wait_until(bridge.track_started, 2.0)
            texts = [e.text for e in bridge.drain_events()]
        assert sum("bad_value" in t for t in texts) == 1, texts
        assert any("formation established" in t for t in texts)
    finally:
        peer.close()


def test_heartbeats_from_another_address_do_not_keep_a_dead_vehicle_linked():
    """A stranger sending HEARTBEATs with the vehicle's sysid and compid from another UDP
    socket is counted as spoofed: the vehicle that stopped is reported lost on time."""
    vehicle = FakePeer(2, heartbeat_hz=5.0)
    spoofer = None
    try:
        with bridge_for([vehicle], (2,), heartbeat_timeout_s=1.0) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])
            assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
            spoofer = FakePeer(2, heartbeat_hz=10.0, dest=vehicle.dest)  # the bridge's socket
            vehicle.heartbeats_on = False  # the real vehicle dies
            assert wait_until(lambda: bridge.status()[0].link == "lost", 3.0), \
                "spoofed heartbeats kept the vehicle linked"
            time.sleep(0.5)
            assert bridge.status()[0].link == "lost"  # and they do not find it again
            assert bridge.link_stats()[key(vehicle)].spoofed >= 10
            vehicle.heartbeats_on = True
            assert wait_until(lambda: bridge.status()[0].link == "linked", 2.0)
    finally:
        vehicle.close()
        if spoofer is not None:
            spoofer.close()


def test_a_heartbeat_from_another_component_of_the_vehicle_sysid_is_ignored():
    vehicle = FakePeer(2, compid=1, heartbeat_hz=5.0)
    try:
        with bridge_for([vehicle], (2,)) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])
            assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
            other = MAV.MAVLink(vehicle.mav.file, srcSystem=2, srcComponent=42)
            for _ in range(5):  # from the vehicle's own address, claiming a GUIDED autopilot
                other.send(other.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR,
                                                  MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 9, 4))
            assert wait_until(lambda: bridge.link_stats()[key(vehicle)].spoofed == 5, 2.0)
            s = bridge.status()[0]
            assert s.compid == 1 and s.mode != "LAND"  # custom mode 9 was not taken
    finally:
        vehicle.close()


def free_udp_port():
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_on_udpin_the_first_address_heard_is_the_vehicle_until_it_is_lost():
    """udpin: the vehicle's address is not configured, so the first one heard is pinned;
    after a loss the pin is released (a restarted vehicle may use a new port), which is
    where signing is needed (docs/mavlink/bridge.md, "Bad values, strangers and signing")."""
    port = free_udp_port()
    bridge = Bridge(BridgeConfig(connections=(f"udpin:127.0.0.1:{port}",), target_sysids=(2,),
                                 capture_radius_m=0.0, speed_mps=0.0, heartbeat_timeout_s=1.0))
    vehicle = FakePeer(2, heartbeat_hz=5.0, dest=("127.0.0.1", port))
    spoofer = None
    try:
        with bridge:
            assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
            spoofer = FakePeer(2, heartbeat_hz=10.0, dest=("127.0.0.1", port))
            time.sleep(0.5)
            vehicle.heartbeats_on = False
            assert wait_until(lambda: bridge.status()[0].link == "lost", 3.0)
            assert bridge.link_stats()[f"udpin:127.0.0.1:{port}"].spoofed >= 5
    finally:
        vehicle.close()
        if spoofer is not None:
            spoofer.close()


def test_drop_log_says_the_first_drop_then_once_per_period_with_the_count():
    from uav_insar_planner.mavlink.guard import DropLog

    now = [0.0]
    log = DropLog(period_s=10.0, clock=lambda: now[0])
    said = []
    for i in range(100):
        now[0] = i * 0.25  # 4 drops a second for 25 s
        said.append(log.drop("bad_value", "x" * 500))
    lines = [s for s in said if s is not None]
    assert len(lines) == 3  # at 0 s, 10 s and 20 s
    assert lines[0] == "dropped bad_value: " + "x" * 160  # cut short
    assert lines[1].endswith("(40 since the last report, 41 in all)")
    assert log.counts == {"bad_value": 100}
    assert log.drop("spoofed", "y") is not None  # each kind has its own budget


def test_udpin_replies_only_to_valid_senders_and_to_a_bounded_number():
    import socket

    from uav_insar_planner.mavlink.link import MAX_UDPIN_PEERS, Link

    link = Link("udpin:127.0.0.1:0", 2, 1)
    senders = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(12)]
    try:
        where = ("127.0.0.1", link.local_port())
        junk = senders[0]
        junk.bind(("127.0.0.1", 0))
        junk.sendto(b"\xfd\x09garbage, not a frame", where)
        mav = MAV.MAVLink(None, srcSystem=9, srcComponent=1)
        frame = mav.heartbeat_encode(6, 8, 0, 0, 4).pack(mav)
        for s in senders[1:]:
            s.bind(("127.0.0.1", 0))
            s.sendto(frame, where)
            time.sleep(0.01)
            link.poll()
        clients = link.conn.clients
        assert len(clients) == MAX_UDPIN_PEERS
        assert junk.getsockname() not in clients  # garbage subscribes nobody
        assert {s.getsockname() for s in senders[-MAX_UDPIN_PEERS:]} == clients  # the latest
    finally:
        for s in senders:
            s.close()
        link.close()
