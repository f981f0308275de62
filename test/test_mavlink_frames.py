"""Track frame <-> NED, against hand-worked cases (docs/mavlink/bridge.md, "Frames")."""
import math

import pytest

from uav_insar_planner.track.frame import TrackFrame


def close(a, b, tol=1e-9):
    return all(abs(x - y) <= tol for x, y in zip(a, b, strict=True))


def test_bearing_0_is_mavros_convention():
    f = TrackFrame.from_degrees(0.0)
    # (N, E, D) = (y, x, -z)
    assert close(f.to_ned(-54.0, 10.0, 74.0), (10.0, -54.0, -74.0))
    assert close(f.from_ned(10.0, -54.0, -74.0), (-54.0, 10.0, 74.0))


def test_bearing_90_track_points_east_range_points_south():
    f = TrackFrame.from_degrees(90.0)
    # N = y cos90 - x sin90 = -x ; E = y sin90 + x cos90 = y ; D = -z
    assert close(f.to_ned(3.0, 5.0, 20.0), (-3.0, 5.0, -20.0))
    assert close(f.from_ned(-3.0, 5.0, -20.0), (3.0, 5.0, 20.0))


def test_origin_offset_is_added_after_rotation():
    f = TrackFrame.from_degrees(90.0, (100.0, -50.0, 2.0))
    assert close(f.to_ned(3.0, 5.0, 20.0), (97.0, -45.0, -18.0))
    assert close(f.from_ned(97.0, -45.0, -18.0), (3.0, 5.0, 20.0))
    assert close(f.to_ned(0.0, 0.0, 0.0), (100.0, -50.0, 2.0))


def test_bearing_45_by_hand():
    f = TrackFrame.from_degrees(45.0)
    h = math.sqrt(0.5)
    # along-track 1 m goes north-east; range 1 m goes south-east
    assert close(f.to_ned(0.0, 1.0, 0.0), (h, h, 0.0))
    assert close(f.to_ned(1.0, 0.0, 0.0), (-h, h, 0.0))


def test_vectors_ignore_origin():
    f = TrackFrame.from_degrees(90.0, (100.0, -50.0, 2.0))
    assert close(f.vector_to_ned(0.0, 4.3, 0.0), (0.0, 4.3, 0.0), 1e-12)
    assert close(f.vector_from_ned(0.0, 4.3, 0.0), (0.0, 4.3, 0.0), 1e-12)


@pytest.mark.parametrize("bearing", [-170.0, 0.0, 33.0, 90.0, 271.5])
def test_round_trip(bearing):
    f = TrackFrame.from_degrees(bearing, (12.0, -7.0, 3.0))
    for p in [(0.0, 0.0, 0.0), (-54.0, 120.0, 74.0), (1e3, -2e3, 5.0)]:
        assert close(f.from_ned(*f.to_ned(*p)), p, 1e-9)
