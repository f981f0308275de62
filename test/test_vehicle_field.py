"""The vehicle simulator in field conditions: a reported position that wanders as an EKF's does
under GNSS noise (`--position-noise-std`, `--position-noise-tau`, `--noise-seed`) and a steady
wind its position controller fights (`--wind-mps`). The process model on its own, then the
`uav-insar-vehicle` process and an in-process vehicle against a pymavlink ground station on
loopback UDP."""
from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest
from mavlink_fakes import MAV, FakePeer, wait_until
from process_group import kill_group

from uav_insar_planner.demo.processes import start_vehicle
from uav_insar_sim.physics.gauss_markov import GaussMarkov
from uav_insar_sim.vehicle.autopilot import KP
from uav_insar_sim.vehicle.cli import main
from uav_insar_sim.vehicle.estimate_error import EstimateError
from uav_insar_sim.vehicle.simulator import SimVehicle
from uav_insar_sim.vehicle.telemetry import EARTH_RADIUS_M, SITL_HOME

pytestmark = pytest.mark.timeout(60)


def test_the_error_has_its_std_and_wanders_over_its_correlation_time():
    sigma, tau, h = 0.5, 2.0, 0.1
    process = GaussMarkov(sigma, tau, np.random.default_rng(7))
    x = np.array([process.step(h).copy() for _ in range(40000)])  # 4000 s, ~1000 tau
    assert x.std(axis=0) == pytest.approx([sigma] * 3, rel=0.1)
    lag = round(tau / h)  # one correlation time apart: exp(-1)
    corr = [np.corrcoef(x[:-lag, i], x[lag:, i])[0, 1] for i in range(3)]
    assert corr == pytest.approx([math.exp(-1.0)] * 3, abs=0.06)
    # one step apart it barely moves: sigma sqrt(2 (1 - exp(-h / tau))), not white noise's
    # sigma sqrt(2)
    steps = np.diff(x, axis=0).std(axis=0)
    assert steps == pytest.approx([sigma * math.sqrt(2 * -math.expm1(-h / tau))] * 3, rel=0.05)


def test_the_error_is_seeded_per_vehicle_and_none_without_noise():
    def run(seed: int, sysid: int, std: float = 0.3) -> list[tuple[float, float, float]]:
        error = EstimateError(std, 2.0, seed, sysid)
        out = []
        for _ in range(50):
            error.step(0.02)
            out.append(error.ned)
        return out

    assert run(4, 2) == run(4, 2)
    assert run(4, 2) != run(4, 3) and run(4, 2) != run(5, 2)
    assert set(run(4, 2, std=0.0)) == {(0.0, 0.0, 0.0)}
    assert EstimateError().reported((1.0, 2.0, -3.0)) == (1.0, 2.0, -3.0)


def _ned_of(gpi, home=SITL_HOME) -> tuple[float, float, float]:
    lat0, lon0, alt0 = home
    n = math.radians(gpi.lat * 1e-7 - lat0) * EARTH_RADIUS_M
    e = math.radians(gpi.lon * 1e-7 - lon0) * EARTH_RADIUS_M * math.cos(math.radians(lat0))
    return n, e, alt0 - gpi.alt * 1e-3


def test_a_hovering_vehicle_reports_a_wandering_position():
    """The process, as a user starts it: hovering still, it reports positions that wander
    about where it is by about the std, smoothly, the same error in LOCAL_POSITION_NED and
    GLOBAL_POSITION_INT, and velocities without it."""
    sigma, truth = 0.4, np.array([3.0, 4.0, -10.0])
    proc, port = start_vehicle(["--sysid", "5", "--airborne", "--start-ned", *map(str, truth),
                                "--position-noise-std", str(sigma), "--noise-seed", "3"],
                               "127.0.0.1", 0, dict(os.environ), "[vehicle5]")
    assert port is not None, "the vehicle did not start"
    gcs = FakePeer(255, 191, dest=("127.0.0.1", port), heartbeat_hz=2.0,
                   mav_type=MAV.MAV_TYPE_GCS, autopilot=MAV.MAV_AUTOPILOT_INVALID)
    try:
        gcs.wait_for("LOCAL_POSITION_NED", 10.0)
        t0 = time.monotonic()
        time.sleep(4.0)
        local = [m for _, m in gcs.messages("LOCAL_POSITION_NED", t0)]
        gpi = [m for _, m in gcs.messages("GLOBAL_POSITION_INT", t0)]
    finally:
        gcs.close()
        kill_group(proc)
    assert len(local) >= 30 and len(gpi) >= 15, (len(local), len(gpi))
    error = np.array([(m.x, m.y, m.z) for m in local]) - truth
    rms = float(np.sqrt(np.mean(error ** 2)))
    step_rms = float(np.sqrt(np.mean(np.diff(error, axis=0) ** 2)))
    print(f"reported error rms {rms:.3f} m (std {sigma}), per 0.1 s {step_rms:.3f} m")
    assert 0.25 * sigma < rms < 3.0 * sigma and np.abs(error).max() < 5.0 * sigma
    assert step_rms < 0.6 * rms  # white noise at 10 Hz: about 1.4 rms
    assert {(m.vx, m.vy, m.vz) for m in local} == {(0.0, 0.0, 0.0)}
    ms = np.array([m.time_boot_ms for m in local], dtype=float)
    for m in gpi:
        if ms[0] <= m.time_boot_ms <= ms[-1]:
            at = [np.interp(m.time_boot_ms, ms, error[:, i] + truth[i]) for i in range(3)]
            assert _ned_of(m) == pytest.approx(at, abs=0.05), m.time_boot_ms


@pytest.mark.parametrize("wind", [(2.0, -1.0, 0.0), (0.0, 3.0, 0.0)])
def test_wind_pushes_a_holding_vehicle_off_its_target(wind):
    """The controller sees only the position error the wind causes: it holds downwind, where
    its approach speed min(KP d, sqrt(a d)) matches the wind; it reports its ground velocity,
    zero once held. On the ground, disarmed, the wind does not move it."""
    w, accel = np.array(wind), 5.0
    speed = float(np.linalg.norm(w))
    offset = max(speed / KP, speed ** 2 / accel)
    with SimVehicle(5, "udpin:127.0.0.1:0", start_ned=(0.0, 0.0, -10.0), airborne=True,
                    max_accel=accel, wind_ned=wind) as flying, \
            SimVehicle(6, "udpin:127.0.0.1:0", wind_ned=wind) as parked:
        assert wait_until(lambda: np.linalg.norm(flying.velocity_ned) < 0.01
                          and np.linalg.norm(flying.position_ned[:2]) > 0.5, 10.0)
        time.sleep(0.5)
        held = np.array(flying.position_ned)
        assert held == pytest.approx([0.0, 0.0, -10.0] + w / speed * offset, abs=0.03)
        assert np.linalg.norm(flying.velocity_ned) < 0.01
        assert parked.position_ned == (0.0, 0.0, 0.0) and parked.velocity_ned == (0.0,) * 3


@pytest.mark.parametrize("args, field", [
    (["--position-noise-std", "nan"], "position_noise_std"),
    (["--position-noise-std", "-0.1"], "position_noise_std"),
    (["--position-noise-std", "1e3"], "position_noise_std"),
    (["--position-noise-tau", "0"], "position_noise_tau"),
    (["--noise-seed", "-1"], "noise_seed"),
    (["--wind-mps", "0", "12", "0"], "wind_mps"),  # faster than --speed 10: blown away
    (["--wind-mps", "1", "inf", "0"], "wind_mps"),
    (["--wind-mps", "1", "2"], "--wind-mps"),
])
def test_bad_field_options_are_one_line_and_exit_2(args, field, capsys):
    try:  # argparse's own errors (a missing value) end by SystemExit, ours by return
        code = main(["--sysid", "2", "--listen", "udpin:127.0.0.1:0", *args])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0], err
