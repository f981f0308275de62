"""The tomographic figures of a plan against an independent brute-force array factor: every
figure computed here from positions by its definition on a dense grid (no helper of the
package), for random formations of 4 to 6 UAVs, within 1 % (heights) and 0.1 dB."""
from __future__ import annotations

import json
import math
import sys

import numpy as np
import process_group
import pytest

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.tomography.array_factor import energy, tomography_figures

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]


def brute(b_perp: np.ndarray, scale: float, span: float, top: float) -> dict:
    """The figures by definition: AF on a grid of 2e6 heights in [0, top], the integrals by
    the trapezoid rule, the first minimum and the first AF >= 0.9 past it read off the grid."""
    h = np.linspace(0.0, top, 2_000_001)
    acc = np.zeros_like(h, dtype=complex)
    for b in b_perp:
        acc += np.exp(2j * np.pi * b * h / scale)
    af = np.abs(acc) / len(b_perp)
    i1 = next(i for i in range(1, h.size - 1) if af[i] <= af[i - 1] and af[i] < af[i + 1])
    h1 = h[i1]
    past = np.flatnonzero((h > h1) & (af >= 0.9))
    amb = h[past[0]] if past.size else None
    side = (h > h1) & (h <= span)
    main = np.trapezoid(af[:i1 + 1] ** 2, h[:i1 + 1])
    inside = h <= span
    total = np.trapezoid(af[inside] ** 2, h[inside])
    return {"resolution_m": scale / (b_perp.max() - b_perp.min()), "main_lobe_m": h1,
            "ambiguity_height_m": amb, "pslr_db": 20 * math.log10(af[side].max()),
            "islr_db": 10 * math.log10((total - main) / main)}


def random_formation(rng: np.random.Generator, n: int):
    """A formation of n UAVs about Table I's master: slaves at random look angles and ranges."""
    p = default_params()
    z0 = rng.uniform(40.0, 80.0)
    x0 = p.x_t - z0 * math.tan(p.theta0)
    r0 = math.hypot(x0 - p.x_t, z0)
    q = [(x0, z0)]
    for _ in range(n - 1):
        th = p.theta0 + math.radians(rng.uniform(-6.0, 6.0))
        r = r0 * rng.uniform(0.95, 1.1)
        q.append((p.x_t - r * math.sin(th), r * math.cos(th)))
    return p, np.array(q), r0


@pytest.mark.parametrize("seed", range(9))
def test_every_figure_agrees_with_a_brute_force_array_factor(seed):
    rng = np.random.default_rng(seed)
    n = 4 + seed % 3
    p, q, r0 = random_formation(rng, n)
    p = p.replace(num_uavs=n, rate_min_mbps=[1.0] * n, tomo_height_span_m=rng.uniform(2.0, 6.0))
    t = evaluate(p, q, np.zeros((n, p.num_slots)), "proposed").metrics["tomography"]
    # independent geometry: b_perp is the offset projected on the normal to the master's line
    # of sight, which points from the master to (x_t, 0)
    los = np.array([p.x_t - q[0, 0], -q[0, 1]]) / r0
    normal = np.array([-los[1], los[0]])
    b = (q - q[0]) @ normal
    scale = p.wavelength * r0 * abs(los[0])  # sin(theta0) = horizontal part of the unit LOS
    top = max(p.tomo_height_span_m, 1.05 * (t["ambiguity_height_m"] or p.tomo_height_span_m))
    want = brute(b, scale, p.tomo_height_span_m, top)
    assert t["height_span_m"] == p.tomo_height_span_m
    for key in ("resolution_m", "main_lobe_m", "ambiguity_height_m"):
        assert t[key] == pytest.approx(want[key], rel=0.01), key
    for key in ("pslr_db", "islr_db"):
        assert abs(t[key] - want[key]) <= 0.1, (key, t[key], want[key])


def test_the_sign_of_b_perp_is_kept_and_its_magnitude_is_eq_3():
    rng = np.random.default_rng(1)
    p, q, _ = random_formation(rng, 6)
    signed = model.perpendicular_baseline_signed(q[0, 0], q[0, 1], q[:, 0], q[:, 1], p.theta0)
    np.testing.assert_allclose(np.abs(signed), model.perpendicular_baseline(
        q[0, 0], q[0, 1], q[:, 0], q[:, 1], p.theta0), atol=1e-12)
    looks = model.look_angle(q[1:, 0], q[1:, 1], p.x_t)
    assert np.all(np.sign(signed[1:]) == np.sign(p.theta0 - looks))


def test_equal_spacing_has_the_textbook_figures():
    # N equal steps d: nulls at multiples of 1/(N d), grating lobe at 1/d, first sidelobe of
    # |sin(N x)/(N sin x)| (-13.26 dB as N grows; -12.04 dB at N = 5), checked by brute force
    kappa = np.arange(5) / 4.0
    f = tomography_figures(kappa, 3.0)
    assert f.resolution_m == pytest.approx(1.0)
    assert f.main_lobe_m == pytest.approx(4.0 / 5.0, rel=1e-9)
    x = np.linspace(math.pi / 5, 2 * math.pi / 5, 100_001)  # between the first two nulls
    dirichlet = np.abs(np.sin(5 * x) / (5 * np.sin(x)))
    assert f.pslr_db == pytest.approx(20 * math.log10(dirichlet.max()), abs=1e-3)
    assert f.ambiguity_height_m < 4.0 < f.ambiguity_height_m + 0.25


def test_energy_is_the_integral_of_af_squared():
    kappa = np.array([0.0, 0.13, 0.61, 1.0])
    h = np.linspace(-2.7, 2.7, 400_001)
    af2 = np.abs(np.exp(2j * np.pi * np.outer(h, kappa)).mean(axis=1)) ** 2
    assert energy(kappa, 2.7) == pytest.approx(np.trapezoid(af2, h), rel=1e-8)


def test_two_uavs_have_no_tomography_and_one_b_perp_no_aperture():
    p = default_params().replace(num_uavs=2, rate_min_mbps=[10.0, 16.95])
    q = np.array([[-27.0, 47.0], [-30.0, 48.0]])
    assert "tomography" not in evaluate(p, q, np.zeros((2, p.num_slots)), "proposed").metrics
    p3 = default_params()
    los = np.array([math.sin(p3.theta0), -math.cos(p3.theta0)])  # all on one line of sight
    q3 = np.array([-27.118, 47.118]) + np.outer([0.0, 5.0, -5.0], los)
    t = evaluate(p3, q3, np.zeros((3, p3.num_slots)), "proposed").metrics["tomography"]
    assert "no elevation aperture" in t["note"]


def test_solve_json_has_the_tomography_block_and_psf_plot(tmp_path):
    args = ["--set", "num_uavs=4", "--set", "rate_min_mbps=[10,16.95,1,1]"]
    proc = process_group.run([*CLI, "solve", "--json", *args], capture_output=True, text=True,
                             timeout=120)
    assert proc.returncode == 0, proc.stderr
    t = json.loads(proc.stdout)["metrics"]["tomography"]
    assert {"resolution_m", "ambiguity_height_m", "pslr_db", "islr_db", "height_span_m"} <= set(t)
    text = process_group.run([*CLI, "solve", *args], capture_output=True, text=True, timeout=120)
    assert "Rayleigh resolution" in text.stdout and "ISLR" in text.stdout
    png = tmp_path / "psf.png"
    proc = process_group.run([*CLI, "plot-formation", "--psf", "--out", str(png), *args],
                             capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and png.stat().st_size > 10_000, proc.stderr
    bad = process_group.run([*CLI, "plot-formation", "--psf", "--out", str(png), "--set",
                             "num_uavs=2", "--set", "rate_min_mbps=[10,16.95]"],
                            capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "--psf" in bad.stderr and len(bad.stderr.splitlines()) == 1
