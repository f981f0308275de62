"""Property-based tests (Hypothesis, fixed seed via derandomize, bounded examples) of the
MAVLink layers: frames (track <-> NED), guard and setpoints (what may go out as float32),
link (tolerant parsing over real loopback UDP) and signing (no tampered frame verifies)."""
import math
import struct
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mavlink_fakes import MAV

from uav_insar_planner.mavlink.guard import FLOAT32_MAX, fits_float32
from uav_insar_planner.mavlink.link import Link
from uav_insar_planner.mavlink.setpoints import (
    MASK_POSITION,
    MASK_POSITION_VELOCITY,
    setpoint_message,
    used_values,
)
from uav_insar_planner.mavlink.signing import SigningParser, signing_state
from uav_insar_planner.track.frame import TrackFrame

pytestmark = pytest.mark.timeout(120)
SETTINGS = settings(max_examples=60, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
metres = st.floats(-1e5, 1e5, allow_nan=False)
vec = st.tuples(metres, metres, metres)
bearing = st.floats(-360.0, 360.0, allow_nan=False)
any_float = st.floats(allow_nan=True, allow_infinity=True)


@SETTINGS
@given(bearing, vec, vec)
def test_frames_round_trip_and_keep_lengths(bearing_deg, origin, point):
    frame = TrackFrame.from_degrees(bearing_deg, origin)
    back = frame.from_ned(*frame.to_ned(*point))
    assert all(abs(a - b) <= 1e-9 * (1.0 + abs(a) + abs(o)) * 10
               for a, b, o in zip(point, back, origin, strict=True))
    rotated = frame.vector_to_ned(*point)
    assert math.hypot(*rotated) == pytest.approx(math.hypot(*point), rel=1e-12, abs=1e-9)


@SETTINGS
@given(any_float)
def test_fits_float32_means_it_packs_as_a_finite_float32(x):
    if fits_float32([x]):
        assert math.isfinite(struct.unpack("<f", struct.pack("<f", x))[0])
    else:
        assert not math.isfinite(x) or abs(x) > FLOAT32_MAX


@SETTINGS
@given(st.tuples(any_float, any_float, any_float), st.tuples(any_float, any_float, any_float),
       bearing, st.booleans())
def test_a_setpoint_is_sent_whole_and_exact_or_not_at_all(position, velocity, bearing_deg,
                                                          feedforward):
    frame = TrackFrame.from_degrees(bearing_deg)
    mav = MAV.MAVLink(None, srcSystem=255, srcComponent=191)
    msg = setpoint_message(mav, frame, (position, velocity), 0, 2, 1, feedforward)
    n, e, d = frame.to_ned(*position)
    vn, ve, vd = frame.vector_to_ned(*velocity) if feedforward else (0.0, 0.0, 0.0)
    if msg is None:
        assert not fits_float32((n, e, d, vn, ve, vd))
        return
    decoded = MAV.MAVLink(None).decode(bytearray(msg.pack(mav)))  # packing never raises
    assert decoded.type_mask == (MASK_POSITION_VELOCITY if feedforward else MASK_POSITION)
    for sent, want in zip((decoded.x, decoded.y, decoded.z, decoded.vx, decoded.vy,
                           decoded.vz), (n, e, d, vn, ve, vd), strict=True):
        assert math.isfinite(sent)
        assert sent == struct.unpack("<f", struct.pack("<f", want))[0]  # float32 rounding only


@SETTINGS
@given(st.integers(0, 0xFFFF), st.tuples(any_float, any_float, any_float),
       st.tuples(any_float, any_float, any_float))
def test_used_values_are_the_fields_whose_ignore_bit_is_clear(mask, position, velocity):
    used = used_values(mask, position, velocity)
    assert len(used) == sum(not mask & (1 << bit) for bit in range(6))
    if mask & 0b111 == 0b111 and mask & 0b111000 == 0b111000:
        assert used == ()


@pytest.fixture(scope="module")
def udp_pair():
    rx = Link("udpin:127.0.0.1:0", 2, 1)
    tx = Link(f"udpout:127.0.0.1:{rx.local_port()}", 255, 191)
    yield tx, rx
    tx.close()
    rx.close()


def received(rx, kind, timeout=1.0):
    deadline = time.monotonic() + timeout
    got = []
    while time.monotonic() < deadline:
        got += [m for m in rx.poll() if m.get_type() == kind]
        if got:
            return got
        time.sleep(0.002)
    return got


@SETTINGS
@given(st.lists(st.binary(min_size=0, max_size=300), min_size=1, max_size=4),
       st.integers(0, 2**32 - 1))
def test_garbage_datagrams_never_raise_nor_hide_the_next_valid_one(udp_pair, junk, mode):
    tx, rx = udp_pair
    for datagram in junk:
        if datagram:
            tx.send_raw(datagram)
    tx.send(tx.mav.heartbeat_encode(6, 8, 0, mode, 4))
    heartbeats = received(rx, "HEARTBEAT")
    assert [m.custom_mode for m in heartbeats][-1:] == [mode]  # the valid one, decoded
    rx.poll()  # drain whatever a junk datagram happened to contain


@SETTINGS
@given(st.integers(0, 300), st.integers(0, 7))
def test_no_frame_with_a_flipped_bit_verifies(position, bit):
    key = bytes(range(32))
    mav = MAV.MAVLink(None, srcSystem=255, srcComponent=191)
    mav.signing = signing_state(key, 1)
    frame = bytearray(mav.set_position_target_local_ned_encode(
        0, 2, 1, 1, 3576, 1.0, 2.0, -3.0, 0, 0, 0, 0, 0, 0, 0, 0).pack(mav))
    parser = SigningParser(None)
    parser.signing = signing_state(key, 0)
    parser.robust_parsing = True
    frame[position % len(frame)] ^= 1 << bit
    msgs = parser.parse_buffer(bytes(frame)) or []
    # (a flipped message id decodes as UNKNOWN_<id>, which Link drops as unknown_msgid)
    assert all(m.get_type() == "BAD_DATA" or m.get_type().startswith("UNKNOWN_")
               for m in msgs)
