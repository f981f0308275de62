"""MAVLink 2 signing: the key file, and on real loopback UDP a signed vehicle that
obeys only correctly signed setpoints, with the bridge and the vehicle signed end to end."""
import os
import time

import pytest
from mavlink_fakes import MAV, FakePeer, wait_until

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.mavlink.signing import (
    SigningParser,
    read_key_file,
    signing_state,
    signing_timestamp,
)
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(60)
KEY = bytes(range(1, 33))
OTHER_KEY = bytes(range(101, 133))


def key_file(tmp_path, data: bytes, name="key", mode=0o600):
    path = tmp_path / name
    path.write_bytes(data)
    os.chmod(path, mode)
    return str(path)


@pytest.mark.parametrize("data", [KEY, KEY.hex().encode(), KEY.hex().upper().encode() + b"\n",
                                  b"  " + KEY.hex().encode() + b"\r\n"])
def test_key_file_raw_or_hex(tmp_path, data):
    assert read_key_file(key_file(tmp_path, data)) == (KEY, None)


@pytest.mark.parametrize("data, words", [
    (b"", "holds 0 bytes"), (KEY[:31], "holds 31 bytes"), (KEY + b"\n", "holds 33 bytes"),
    (b"zz" * 32, "64 hexadecimal"), (bytes(32), "all-zero"), (b"x" * 100000, "holds 4097"),
])
def test_bad_key_file_is_one_line(tmp_path, data, words):
    with pytest.raises(ValueError) as err:
        read_key_file(key_file(tmp_path, data))
    assert words in str(err.value) and "\n" not in str(err.value)


def test_missing_or_odd_key_file_is_one_line(tmp_path):
    for path, words in ((str(tmp_path / "none"), "cannot be read"),
                        (str(tmp_path), "cannot be read"), ("/dev/zero", "not a regular file")):
        with pytest.raises(ValueError) as err:
            read_key_file(path)
        assert words in str(err.value) and "\n" not in str(err.value)


def test_a_world_readable_key_file_is_warned_about(tmp_path):
    key, warning = read_key_file(key_file(tmp_path, KEY, mode=0o644))
    assert key == KEY and "chmod 600" in warning


def frames(key, link_id, sysid=255, compid=191, stamp=None):
    """An encoder that signs like a ground station with `key` (None: unsigned)."""
    mav = MAV.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    if key is not None:
        mav.signing = signing_state(key, link_id)
        if stamp is not None:
            mav.signing.timestamp = stamp
    return mav


def parser(key=KEY):
    p = SigningParser(None)
    p.signing = signing_state(key, 0)
    p.robust_parsing = True
    return p


def heartbeat(mav):
    return mav.heartbeat_encode(6, 8, 0, 0, 4).pack(mav)


def test_signature_checked_before_the_stream_timestamp():
    """A forged frame with a far-future timestamp on the real sender's stream must not lock
    the real sender out (pymavlink's own check records the timestamp before the signature)."""
    p = parser()
    forged = heartbeat(frames(OTHER_KEY, 3, stamp=2**48 - 2))
    assert p.parse_char(forged).get_type() == "BAD_DATA"
    real = heartbeat(frames(KEY, 3))
    assert p.parse_char(real).get_type() == "HEARTBEAT"
    assert p.parse_char(real).get_type() == "BAD_DATA"  # the same frame again: a replay


def test_timestamps_follow_the_2015_epoch_in_10_us_units():
    assert signing_timestamp(1420070400.0) == 0
    assert signing_timestamp(1420070401.5) == 150_000
    old = heartbeat(frames(KEY, 4, stamp=signing_timestamp() - 70 * 100_000))
    assert parser().parse_char(old).get_type() == "BAD_DATA"  # a new stream > 1 min old


@pytest.fixture
def signed_vehicle():
    vehicle = SimVehicle(5, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 0.0, -10.0),
                         airborne=True, signing_key=KEY)
    vehicle.start()
    yield vehicle
    vehicle.stop()


def send_setpoint(peer, n):
    peer.mav.send(peer.mav.set_position_target_local_ned_encode(
        0, 5, 1, MAV.MAV_FRAME_LOCAL_NED, 3576, n, 0.0, -10.0, 0, 0, 0, 0, 0, 0, 0, 0))


def test_the_signed_vehicle_obeys_only_correctly_signed_setpoints(signed_vehicle):
    vehicle = signed_vehicle
    dest = ("127.0.0.1", vehicle.port)
    unsigned = FakePeer(255, 191, dest=dest)
    wrong = FakePeer(255, 191, dest=dest)
    wrong.mav.signing = signing_state(OTHER_KEY, 1)
    right = FakePeer(255, 191, dest=dest)
    right.mav.signing = signing_state(KEY, 2)
    right.parser = parser()  # checks what the vehicle sends
    try:
        send_setpoint(unsigned, 40.0)
        send_setpoint(wrong, 40.0)
        assert wait_until(lambda: vehicle.stats.bad_signature == 2, 2.0)
        assert vehicle.setpoints_accepted == 0
        send_setpoint(right, 3.0)
        assert wait_until(lambda: vehicle.setpoints_accepted == 1, 2.0)
        replay = bytes(right.mav.set_position_target_local_ned_encode(
            0, 5, 1, MAV.MAV_FRAME_LOCAL_NED, 3576, 40.0, 0, -10, 0, 0, 0, 0, 0, 0, 0, 0
        ).pack(right.mav))
        right.send_raw(replay)
        right.send_raw(replay)  # the second copy is a replay
        assert wait_until(lambda: vehicle.stats.bad_signature == 3, 2.0)
        assert vehicle.setpoints_accepted == 2
        # what the vehicle sends is signed too (signing authenticates; it does not encrypt)
        m = right.wait_for("HEARTBEAT", 3.0)
        assert m.get_signed() and m.get_link_id() == 0
    finally:
        for p in (unsigned, wrong, right):
            p.close()


@pytest.mark.parametrize("bridge_key, linked", [(KEY, True), (OTHER_KEY, False), (None, False)])
def test_bridge_and_vehicle_signed_end_to_end(tmp_path, signed_vehicle, bridge_key, linked):
    vehicle = signed_vehicle
    path = "" if bridge_key is None else key_file(tmp_path, bridge_key.hex().encode())
    config = BridgeConfig(connections=(f"udpout:127.0.0.1:{vehicle.port}",),
                          target_sysids=(5,), capture_radius_m=0.0, speed_mps=0.0,
                          signing_key_file=path)
    with Bridge(config) as bridge:
        bridge.set_formation([(0.0, 2.0, 10.0)])  # N, E, D = 2, 0, -10
        if linked:
            assert wait_until(lambda: bridge.status()[0].link == "linked", 3.0)
            assert wait_until(lambda: vehicle.setpoints_accepted >= 5, 3.0)
            assert wait_until(lambda: abs(vehicle.position_ned[0] - 2.0) < 0.3, 6.0)
            assert vehicle.stats.bad_signature == 0
        else:
            time.sleep(2.0)
            assert bridge.status()[0].link == "waiting"  # its heartbeats do not verify
            assert vehicle.setpoints_accepted == 0 and vehicle.position_ned[0] == 0.0
            assert vehicle.stats.bad_signature >= 2  # its heartbeats (no setpoints: not linked)
            # and a udpin vehicle does not even answer a sender it cannot verify
            assert bridge.link_stats()[config.connections[0]].rx_bytes == 0


def test_a_signed_bridge_ignores_an_unsigned_vehicle(tmp_path):
    peer = FakePeer(2, heartbeat_hz=5.0)
    try:
        config = BridgeConfig(connections=(f"udpout:127.0.0.1:{peer.port}",),
                              target_sysids=(2,), capture_radius_m=0.0,
                              signing_key_file=key_file(tmp_path, KEY))
        with Bridge(config) as bridge:
            bridge.set_formation([(0.0, 0.0, 10.0)])
            assert wait_until(lambda: bridge.link_stats()[config.connections[0]]
                              .bad_signature >= 5, 3.0)
            assert bridge.status()[0].link == "waiting"
            assert peer.messages("SET_POSITION_TARGET_LOCAL_NED") == []
            assert all(m.get_header().incompat_flags & MAV.MAVLINK_IFLAG_SIGNED
                       for _, m in peer.messages("HEARTBEAT"))  # ours are signed
    finally:
        peer.close()
