"""The independent checker flags each constraint C1..C11 when, and only when, it is violated.

The reference formation is built by hand: master at slant range 90 m on its 45 deg line,
slave 1 at 90 m / 41 deg, slave 2 at 90 m / 48.5 deg, with the cheapest power schedules.
Each test changes one limit just past the reference value and expects exactly that
constraint to fail.
"""
import math

import numpy as np
import pytest

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.schemes import planned_rate_bps, static_power_w
from uav_insar_planner.solver.power import power_schedule, schedules, station_radius_sq

DEG = math.pi / 180


def polar(r: float, theta_deg: float, x_t: float = 20.0) -> tuple[float, float]:
    return x_t - r * math.sin(theta_deg * DEG), r * math.cos(theta_deg * DEG)


FORMATION = np.array([polar(90, 45), polar(90, 41), polar(90, 48.5)])


def check(scheme="proposed", formation=FORMATION, power=None, **changes):
    p = default_params().replace(**changes)
    power = schedules(p, formation, scheme) if power is None else power
    return evaluate(p, formation, power, scheme)


def test_reference_formation_is_feasible():
    ev = check()
    assert ev.feasible, ev.violated
    # slave 1: b_perp = 90 sin 4 deg = 6.278 m; h_amb = 0.12 * 90 * 0.7071 / 6.278 = 1.2164 m
    assert ev.metrics["pairs"]["uav1"]["b_perp_m"] == pytest.approx(6.278, abs=1e-3)
    assert ev.metrics["pairs"]["uav1"]["h_amb_m"] == pytest.approx(1.2164, abs=1e-3)
    assert ev.sigma_h <= ev.sigma_h_bound


@pytest.mark.parametrize("name, changes", [
    ("C1", {"z_max_m": 65.0}),                       # slave 1 flies at z = 67.9 m
    ("C3", {"slave_look_angle_max_deg": 48.0}),      # slave 2 looks at 48.5 deg
    ("C4", {"d_min_m": 6.5}),                        # master-slave 1 chord 2*90*sin 2 = 6.28 m
    ("C5", {"swath_min_m": 72.0}),                   # slave 1 swath 0.5836*90/cos 41 = 69.6 m
    ("C6", {"coherence_snr_min": 0.86}),             # gamma_SNR = 1/(1 + 1/5.646) = 0.8495
    ("C7", {"coherence_rg_min": 0.98}),              # gamma_Rg(41 deg) = 0.969
    ("C8", {"h_amb_min_m": 1.25}),                   # h_amb 1 = 1.2164 m
])
def test_geometry_constraint_violation_detected(name, changes):
    ev = check(**changes)
    assert ev.violated == [name]
    assert ev.constraints[name].slack < 0


def test_c2_master_off_its_line():
    moved = FORMATION.copy()
    moved[0, 0] += 0.5
    ev = check(formation=moved)
    assert "C2" in ev.violated
    assert ev.constraints["C2"].slack == pytest.approx(-0.5)


def test_c9_peak_power():
    peak = float(schedules(default_params(), FORMATION, "proposed").max())
    ev = check(p_com_max_db=10 * math.log10(peak * 0.99))
    assert ev.violated == ["C9"]


def test_c9_negative_power():
    power = schedules(default_params(), FORMATION, "proposed")
    power[2, 5] = -0.1
    power[2, 6] += 0.2  # keep the rate and energy of U2 fine elsewhere
    ev = check(power=power)
    assert "C9" in ev.violated


def test_c10_rate():
    power = schedules(default_params(), FORMATION, "proposed") * 0.9
    ev = check(power=power)
    assert ev.violated == ["C10"]


def test_c11_energy():
    energy = float(schedules(default_params(), FORMATION, "proposed")[1].sum())
    ev = check(e_com_max_j=energy * 0.99)
    assert ev.violated == ["C11"]


def test_static_power_scheme_requires_constant_schedule():
    p = default_params()
    # E_max = 800 J spreads 10 W per slot, enough for slave 1 at 117 m from the station
    p = p.replace(e_com_max_j=800.0)
    flat = np.full((3, p.num_slots), static_power_w(p))
    assert check("static-power", power=flat, e_com_max_j=800.0).feasible
    cheap = schedules(p, FORMATION, "proposed")
    assert "C9" in check("static-power", power=cheap, e_com_max_j=800.0).violated
    # with Table I's 594 J (7.4 W per slot) slave 1 at 117 m misses its rate
    assert "C10" in check("static-power").violated


def test_single_baseline_ignores_uav2():
    formation = FORMATION.copy()
    formation[2] = np.nan
    ev = check("single-baseline", formation=formation, slave_look_angle_max_deg=48.0)
    assert ev.feasible, ev.violated
    assert set(ev.metrics["pairs"]) == {"uav1"}


@pytest.mark.parametrize("scheme", ["proposed", "static-power"])
def test_station_disk_is_exact(scheme):
    """On the disk boundary UAV k's cheapest schedule is just feasible; just beyond, C9, C10 or
    C11 fails: judged by the checker (E_max = 800 J, 1 % beyond) and straight from eq. 17 and
    C9-C11 (Table I, 1e-4 beyond)."""
    p = default_params().replace(e_com_max_j=800.0)
    gx, _, gz = p.ground_station
    for k in range(3):
        rho = math.sqrt(station_radius_sq(p, k, scheme))
        for scale, ok in ((1.0 - 1e-9, True), (1.01, False)):
            formation = FORMATION.copy()
            formation[k] = (gx, gz + rho * scale)
            power = schedules(p, formation, scheme)
            ev = evaluate(p, formation, power, scheme)
            comm_ok = all(ev.constraints[c].ok for c in ("C9", "C10", "C11"))
            assert comm_ok == ok, (k, scale, scheme)
    p = default_params()
    gx, _, gz = p.ground_station
    for k in range(3):
        rad = math.sqrt(station_radius_sq(p, k, scheme))
        for scale, ok in ((1 - 1e-6, True), (1 + 1e-4, False)):
            x, z = gx - rad * scale * 0.6, gz + rad * scale * 0.8
            sched = power_schedule(p, k, x, z, scheme)
            d = model.distance_to_station(x, p.y_track, z, p.ground_station)
            rate = model.fdma_rate(sched, d, p.comm_bandwidth_hz, p.beta_c)
            met = (sched.max() <= p.p_max_w and sched.sum() * p.slot_duration_s
                   <= p.e_max_j * (1 + 1e-12)
                   and rate.min() >= planned_rate_bps(p, k, scheme) * (1 - 1e-9))
            assert met == ok, (k, scale, scheme)


@pytest.mark.parametrize("z_max", [100.0, 1e6])
@pytest.mark.parametrize("below_m", [5.0, 1e-3, 2e-6])
def test_c1_tolerance_is_absolute_whatever_z_max(z_max, below_m):
    """A UAV below z_min fails C1 by any margin above 1e-6 m; with z_max = 1e9 the old relative
    tolerance (1e-6 z_max) let a UAV at z = -5 m pass."""
    low = FORMATION.copy()
    low[1, 1] = 1.0 - below_m  # z_min = 1 m
    ev = check(formation=low, z_max_m=z_max)
    assert "C1" in ev.violated
    low[1, 1] = 1.0 - 5e-7  # within the stated 1e-6 m
    assert "C1" not in check(formation=low, z_max_m=z_max).violated


@pytest.mark.parametrize("d_min", [0.5, 6.0, 1e4])
def test_c4_tolerance_is_absolute_whatever_d_min(d_min):
    """Two UAVs 2e-6 m closer than d_min fail C4, whatever d_min is (relative: 1e-2 m at 1e4)."""
    q = np.array([polar(90, 45), polar(90, 45), [np.nan, np.nan]])  # U0 and U1 only
    q[1, 0] = q[0, 0] - (d_min - 2e-6)  # the master-slave 1 distance is d_min - 2 um
    ev = check("single-baseline", formation=q, d_min_m=d_min)
    assert not ev.constraints["C4"].ok
    q[1, 0] = q[0, 0] - (d_min - 5e-7)
    assert check("single-baseline", formation=q, d_min_m=d_min).constraints["C4"].ok
