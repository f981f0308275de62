"""Model functions against values worked by hand from the paper's equations.

Each expected number below was computed on paper (calculator) from the equation named in the
function's docstring; the arithmetic is written out in the comment beside it.
"""
import math

import numpy as np
import pytest

from uav_insar_planner import model
from uav_insar_planner.params import default_params

DEG = math.pi / 180


def test_geometry():
    # r = sqrt(74^2 + 74^2) = 74 * 1.414214 = 104.6518
    assert model.slant_range(-54.0, 74.0, 20.0) == pytest.approx(104.6518, abs=1e-4)
    # theta = atan(30 / 40) = 36.8699 deg
    assert model.look_angle(-10.0, 40.0, 20.0) == pytest.approx(36.8699 * DEG, abs=1e-6)
    # C2: x0 = 20 - 74 tan 45 = -54
    assert model.master_x(74.0, 20.0, 45 * DEG) == pytest.approx(-54.0)
    # S = 0.5 * 100 / cos 60 = 100
    assert model.swath_width(100.0, 60 * DEG, 0.5) == pytest.approx(100.0)
    # b = sqrt(3^2 + 4^2) = 5
    assert model.baseline(0.0, 0.0, 3.0, 4.0) == pytest.approx(5.0)


def test_perpendicular_baseline_general_and_closed_form():
    # master (-54, 74) on its 45 deg line, slave offset (3, 3): alpha = 45 deg = theta0, so
    # b_perp = b = 3 sqrt 2 = 4.2426; closed form |(20 + 51) - 77| / sqrt 2 = 6 / 1.4142 = 4.2426
    general = model.perpendicular_baseline(-54.0, 74.0, -51.0, 77.0, 45 * DEG)
    closed = model.perpendicular_baseline_fixed_look(-51.0, 77.0, 20.0, 45 * DEG)
    assert general == pytest.approx(4.2426, abs=1e-4)
    assert closed == pytest.approx(4.2426, abs=1e-4)
    # offset along the line of sight (sin 45, -cos 45) * 10 has no perpendicular component
    los = np.array([math.sin(45 * DEG), -math.cos(45 * DEG)]) * 10
    assert model.perpendicular_baseline(-54.0, 74.0, -54 + los[0], 74 + los[1],
                                        45 * DEG) == pytest.approx(0.0, abs=1e-9)


def test_gamma_m_table_one():
    # sigma0 0.1, P_t 0.3999 W, G_t G_r 3.1623^2 = 10, lambda^3 = 1.728e-3, c 2.9979e8,
    # tau_p PRF 1e-4: numerator = 0.1 * 0.3999 * 10 * 1.728e-3 * 2.9979e8 * 1e-4 = 20.717
    # denominator = 256 * 31.006 * 4.3 * 0.70711 * 1.3806e-23 * 400 * 3e9 * 3.1623 * 3.9811
    #             = 24133.6 * 2.0858e-10 = 5.0338e-6;  gamma_m = 20.717 / 5.0338e-6 = 4.1156e6
    assert model.gamma_m(default_params()) == pytest.approx(4.1156e6, rel=2e-4)


def test_snr_and_coherences():
    assert model.snr_monostatic(100.0, 4e6) == pytest.approx(4.0)  # 4e6 / 1e6
    assert model.snr_bistatic(100.0, 50.0, 4e6) == pytest.approx(8.0)  # 4e6 / (1e4 * 50)
    # 1 / sqrt((1 + 1/4)(1 + 1/4)) = 1 / 1.25 = 0.8
    assert model.coherence_snr(4.0, 4.0) == pytest.approx(0.8)
    # X(45, 45) = 2 sin45 / (2 sin45) = 1 and gamma_Rg(1) = ((2+Bp)/2 - (2-Bp)/2)/Bp = 1
    assert model.chi(45 * DEG, 45 * DEG) == pytest.approx(1.0)
    assert model.coherence_baseline(1.0, 1.2) == pytest.approx(1.0)
    # X(45, 30) = 1.414214 / (0.707107 + 0.5) = 1.171573;
    # gamma_Rg = (3.2/2.171573 - 0.8 * 1.171573/2.171573) / 1.2 = (1.473586 - 0.431603)/1.2
    #          = 0.868319
    assert model.chi(45 * DEG, 30 * DEG) == pytest.approx(1.171573, abs=1e-6)
    assert model.coherence_baseline(1.171573, 1.2) == pytest.approx(0.868319, abs=2e-6)
    # theta_k > theta_0 uses sin(theta_k): X(45, 60) = 2 * 0.866025 / (0.707107 + 0.866025)
    assert model.chi(45 * DEG, 60 * DEG) == pytest.approx(1.101021, abs=1e-6)
    assert model.coherence_total(0.9, 0.8, 0.6) == pytest.approx(0.432)


def test_baseline_coherence_inverse_roundtrip():
    for g in (0.7, 0.8, 0.95):
        x = model.coherence_baseline_inverse(g, 1.2)
        assert model.coherence_baseline(x, 1.2) == pytest.approx(g, abs=1e-12)


def test_height_errors():
    # h_amb = 0.12 * 100 * 0.707107 / 5 = 1.697056
    assert model.height_of_ambiguity(0.12, 100.0, 45 * DEG, 5.0) == pytest.approx(1.697056,
                                                                                 abs=1e-6)
    # CRB: sqrt((1 - 0.36) / 8) / 0.6 = 0.282843 / 0.6 = 0.471405
    assert model.phase_error_crb(0.6, 4) == pytest.approx(0.471405, abs=1e-6)
    assert model.height_error(2 * math.pi, 0.5) == pytest.approx(0.5)
    # inverse-variance fusion: 1 / sqrt(1/0.09 + 1/0.16) = 1 / 4.166667 = 0.24
    assert model.fused_height_error(0.3, 0.4) == pytest.approx(0.24)


def test_proposition_one_bound():
    # A = 0.8 * 0.8 * 0.6 = 0.384; per pair with b_perp = 5: h_amb = 1.697056,
    # sigma_Phi(A) = sqrt((1 - 0.147456)/8) / 0.384 = 0.326447 / 0.384 = 0.850122,
    # sigma_hk = 1.697056 * 0.850122 / 6.283185 = 0.229614;
    # two equal pairs fuse to 0.229614 / sqrt 2 = 0.162361
    bound = model.height_error_bound(0.12, 100.0, 45 * DEG, 50.0, 0.384, 4)
    assert bound == pytest.approx(0.162361, abs=2e-6)
    # and it is an upper bound on sigma_h whenever both coherences are >= A
    s = model.height_error(model.height_of_ambiguity(0.12, 100.0, 45 * DEG, 5.0),
                           model.phase_error_crb(0.5, 4))
    assert model.fused_height_error(s, s) <= bound


def test_rate_and_inverse():
    # B log2(1 + 1 * 100 / 10^2) = 1e9 * log2 2 = 1e9
    assert model.fdma_rate(1.0, 10.0, 1e9, 100.0) == pytest.approx(1e9)
    assert model.power_for_rate(1e9, 10.0, 1e9, 100.0) == pytest.approx(1.0)
    d = model.distance_to_station(0.0, 3.0, 4.0, (0.0, 0.0, 0.0))
    assert d == pytest.approx(5.0)
