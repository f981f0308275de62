"""The paper's system model, one equation per function (SI units, angles in radians).

Equation numbers refer to Lahmeri et al., "Sensing Accuracy Optimization for
Communication-assisted Dual-baseline UAV-InSAR" (section II and Proposition 1). Positions in the
across-track plane are q = (x, z); the target line passes through (x_t, 0). Functions accept
numpy arrays and broadcast.
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner.params import BOLTZMANN, SPEED_OF_LIGHT, Params

ArrayLike = np.ndarray | float


def slant_range(x: ArrayLike, z: ArrayLike, x_t: float) -> ArrayLike:
    """r_k = sqrt((x_k - x_t)^2 + z_k^2)  (slant range to p_t, eq. 4)."""
    return np.hypot(np.subtract(x, x_t), z)


def look_angle(x: ArrayLike, z: ArrayLike, x_t: float) -> ArrayLike:
    """theta_k = arctan((x_t - x_k) / z_k), the beam-centring look angle (section II-A-1)."""
    return np.arctan2(np.subtract(x_t, x), z)


def master_x(z0: ArrayLike, x_t: float, theta0: float) -> ArrayLike:
    """C2: x_0 = x_t - z_0 tan(theta_0), the master on its fixed-look-angle line."""
    return x_t - np.multiply(z0, np.tan(theta0))


def swath_width(r: ArrayLike, theta: ArrayLike, beamwidth: float) -> ArrayLike:
    """S_k = Theta_3dB r_k / cos(theta_k)  (eq. 5)."""
    return beamwidth * np.asarray(r) / np.cos(theta)


def baseline(x0: ArrayLike, z0: ArrayLike, xk: ArrayLike, zk: ArrayLike) -> ArrayLike:
    """b_k = ||q_k - q_0||_2  (eq. 2)."""
    return np.hypot(np.subtract(xk, x0), np.subtract(zk, z0))


def perpendicular_baseline(x0: ArrayLike, z0: ArrayLike, xk: ArrayLike, zk: ArrayLike,
                           theta0: float) -> ArrayLike:
    """b_perp,k = b_k |cos(theta_0 - alpha_k)|  (eq. 3), alpha_k the baseline's elevation.

    Equivalently |dx cos(theta_0) + dz sin(theta_0)|, the baseline projected on the normal to
    the master's line of sight (sin theta_0, -cos theta_0).
    """
    dx, dz = np.subtract(xk, x0), np.subtract(zk, z0)
    alpha = np.arctan2(dz, dx)
    return np.hypot(dx, dz) * np.abs(np.cos(theta0 - alpha))


def perpendicular_baseline_signed(x0: ArrayLike, z0: ArrayLike, xk: ArrayLike, zk: ArrayLike,
                                  theta0: float) -> ArrayLike:
    """b_perp,k with its sign: dx cos(theta_0) + dz sin(theta_0), whose magnitude is eq. 3's
    `perpendicular_baseline`; positive for a receiver at a smaller look angle than the
    master's (a UAV at look angle theta and range r has r sin(theta_0 - theta)). The
    tomographic array factor needs the sign: receivers on both sides of the master's line of
    sight sample the elevation spectrum on both sides of zero."""
    return (np.subtract(xk, x0) * math.cos(theta0)
            + np.subtract(zk, z0) * math.sin(theta0))


def elevation_wavenumber(wavelength: float, r0: ArrayLike, theta0: float,
                         b_perp: ArrayLike) -> ArrayLike:
    """kappa_k = 1 / h_amb,k = b_perp,k / (lambda r_0 sin(theta_0)) [1/m], eq. 12 inverted
    (0 at b_perp = 0, signed with b_perp): a point at height h has phase 2 pi kappa_k h in
    receiver k, the tomographic array factor's wavenumber (tomography/array_factor.py)."""
    return 1.0 / height_of_ambiguity(wavelength, r0, theta0, b_perp)


def perpendicular_baseline_fixed_look(xk: ArrayLike, zk: ArrayLike, x_t: float,
                                      theta0: float) -> ArrayLike:
    """b_perp,k = |(x_t - x_k) - tan(theta_0) z_k| / sqrt(tan^2(theta_0) + 1)  (eq. 16),
    valid when the master satisfies C2 (it then depends on the slave alone)."""
    t = math.tan(theta0)
    return np.abs(np.subtract(x_t, xk) - t * np.asarray(zk)) / math.sqrt(t * t + 1.0)


def gamma_m(p: Params) -> float:
    """gamma_m = sigma_0 P_t G_t G_r lambda^3 c tau_p PRF /
    (4^4 pi^3 v_y sin(theta_0) k_b T_sys B_Rg F L)  (after eq. 8)."""
    num = (p.sigma0 * p.radar_power_w * p.gain_tx * p.gain_rx * p.wavelength**3
           * SPEED_OF_LIGHT * p.duty_cycle)
    den = (4.0**4 * np.pi**3 * p.speed * np.sin(p.theta0) * BOLTZMANN
           * p.system_temperature_k * p.radar_bandwidth_hz * p.noise_figure * p.losses)
    return float(num / den)


def snr_monostatic(r0: ArrayLike, gm: float) -> ArrayLike:
    """SNR_0 = gamma_m / r_0^3  (eq. 8)."""
    return gm / np.power(r0, 3)


def snr_bistatic(r0: ArrayLike, rk: ArrayLike, gm: float) -> ArrayLike:
    """SNR_k ~ gamma_m / (r_0^2 r_k)  (eq. 9, small bistatic angle)."""
    return gm / (np.power(r0, 2) * np.asarray(rk))


def slave_range_max(p: Params, r0: ArrayLike) -> ArrayLike:
    """C6 as a range limit: the largest r_k with gamma_SNR,k >= gamma_SNR^min at master range r_0,
    (1 + r_0^3/gamma_m)(1 + r_0^2 r_k/gamma_m) = 1/gamma_SNR^min^2 solved for r_k (eqs. 7-9):
    r_k,max = gamma_m / r_0^2 (1 / (gamma_SNR^min^2 (1 + r_0^3/gamma_m)) - 1).

    Exact, not a relaxation: gamma_SNR,k decreases in r_k (and in r_0, so the limit decreases
    in r_0). Negative when the master alone is too far.
    """
    gm = gamma_m(p)
    r0 = np.asarray(r0, dtype=float)
    with np.errstate(divide="ignore"):  # +inf at r0 = 0: no limit from a master on the target
        return gm / r0**2 * (1.0 / (p.coherence_snr_min**2 * (1.0 + r0**3 / gm)) - 1.0)


def coherence_snr_of_noise(nsr0: ArrayLike, nsrk: ArrayLike) -> ArrayLike:
    """gamma_SNR,k = 1/sqrt(1 + 1/SNR_0) * 1/sqrt(1 + 1/SNR_k)  (eq. 7), from the
    noise-to-signal ratios nsr = 1/SNR: the one place eq. 7 is written."""
    return 1.0 / np.sqrt((1.0 + np.asarray(nsr0)) * (1.0 + np.asarray(nsrk)))


def coherence_snr(snr0: ArrayLike, snrk: ArrayLike) -> ArrayLike:
    """gamma_SNR,k from the SNRs of eqs. 8-9 (eq. 7); the checker's form."""
    return coherence_snr_of_noise(1.0 / np.asarray(snr0), 1.0 / np.asarray(snrk))


def coherence_snr_at_ranges(r0: ArrayLike, rk: ArrayLike, gm: float) -> ArrayLike:
    """gamma_SNR,k from the ranges (eq. 7 with eqs. 8-9: 1/SNR_0 = r_0^3/gamma_m,
    1/SNR_k = r_0^2 r_k/gamma_m): decreasing in both r_0 and r_k; the ray model's form."""
    r0 = np.asarray(r0, dtype=float)
    return coherence_snr_of_noise(r0**3 / gm, r0**2 * np.asarray(rk) / gm)


def chi(theta0: float, thetak: ArrayLike) -> ArrayLike:
    """X = 2 (sin th0 1{th0 > thk} + sin thk 1{th0 <= thk}) / (sin th0 + sin thk)  (eq. 11)."""
    s0, sk = np.sin(theta0), np.sin(thetak)
    return 2.0 * np.where(theta0 > np.asarray(thetak), s0, sk) / (s0 + sk)


def coherence_baseline(x: ArrayLike, fractional_bandwidth: float) -> ArrayLike:
    """gamma_Rg,k = (1/B_p) [(2 + B_p)/(1 + X) - (2 - B_p)/(1 + 1/X)]  (eq. 10)."""
    bp = fractional_bandwidth
    x = np.asarray(x, dtype=float)
    return ((2.0 + bp) / (1.0 + x) - (2.0 - bp) * x / (x + 1.0)) / bp


def coherence_baseline_inverse(gamma: float, fractional_bandwidth: float) -> float:
    """h(gamma) = (gamma B_p - 2 - B_p) / (B_p - 2 - gamma B_p), the X at which gamma_Rg = gamma
    (Proposition 2's proof)."""
    bp = fractional_bandwidth
    return (gamma * bp - 2.0 - bp) / (bp - 2.0 - gamma * bp)


def coherence_total(g_rg: ArrayLike, g_snr: ArrayLike, g_other: float) -> ArrayLike:
    """gamma_k = gamma_Rg,k gamma_SNR,k gamma_other  (eq. 6)."""
    return np.asarray(g_rg) * np.asarray(g_snr) * g_other


def height_of_ambiguity(wavelength: float, r0: ArrayLike, theta0: float,
                        b_perp: ArrayLike) -> ArrayLike:
    """h_amb,k = lambda r_0 sin(theta_0) / b_perp,k  (eq. 12)."""
    with np.errstate(divide="ignore"):
        return wavelength * np.asarray(r0) * np.sin(theta0) / np.asarray(b_perp)


def h_amb_min_of(p: Params, k: int = 1) -> float:
    """C8's limit for slave k (1..K): h_amb,k^min = h_amb^min rho^(k-1), rho = h_amb_ratio.
    rho = 1 is the paper's common limit; rho > 1 a ladder of diverse heights of ambiguity,
    which lets the pairs resolve each other's phase ambiguities. The one home of the rung."""
    return p.h_amb_min * p.h_amb_ratio ** (k - 1)


def baseline_max(p: Params, r0: ArrayLike, k: int = 1) -> ArrayLike:
    """C8 as a baseline limit for slave k: h_amb,k >= h_amb,k^min with h_amb,k = lambda r_0
    sin(theta_0) / b_perp,k (eq. 12) is b_perp,k <= b_max,k(r_0) = lambda r_0 sin(theta_0) /
    h_amb,k^min (`h_amb_min_of`).

    Linear in r_0 (at r_0 = 1 it is the limit per metre of master range). Every back end's
    C8 asks here; `master_range_min_c8` is its inverse."""
    return p.wavelength * r0 * math.sin(p.theta0) / h_amb_min_of(p, k)


def master_range_min_c8(p: Params, b_perp: ArrayLike, k: int = 1) -> ArrayLike:
    """C8 as a master-range limit for slave k, the inverse of `baseline_max`: the least r_0
    with b_max,k(r_0) >= b_perp, r_0 >= h_amb,k^min b_perp / (lambda sin(theta_0)) (eq. 12)."""
    return h_amb_min_of(p, k) * b_perp / (p.wavelength * math.sin(p.theta0))


def phase_error_crb(gamma: ArrayLike, looks: int) -> ArrayLike:
    """sigma_Phi,k = (1/gamma_k) sqrt((1 - gamma_k^2) / (2 n_L))  (eq. 14, Cramer-Rao bound)."""
    g = np.asarray(gamma, dtype=float)
    return np.sqrt((1.0 - g * g) / (2.0 * looks)) / g


def height_error(h_amb: ArrayLike, sigma_phi: ArrayLike) -> ArrayLike:
    """sigma_h,k = h_amb,k sigma_Phi,k / (2 pi)  (eq. 13)."""
    return np.asarray(h_amb) * np.asarray(sigma_phi) / (2.0 * np.pi)


def fusion_weights(*sigma_hk: ArrayLike) -> tuple[ArrayLike, ...]:
    """w_k = 1/sigma_hk^2, the inverse-variance weights of the fused DEM
    h = sum_k w_k h_k / sum_k w_k over the K pairs (eq. 15 for K = 2)."""
    return tuple(1.0 / np.asarray(s, dtype=float) ** 2 for s in sigma_hk)


def fused_height_error(*sigma_hk: ArrayLike) -> ArrayLike:
    """sigma_h = sqrt(sum_k w_k^2 sigma_hk^2 / (sum_k w_k)^2) with w_k = 1/sigma_hk^2 over the
    K pairs (eq. 15 for K = 2), which simplifies to (sum_k sigma_hk^-2)^(-1/2); a single
    baseline's sigma_h is its pair's sigma_h1."""
    sig = [np.asarray(s, dtype=float) for s in sigma_hk]
    w = fusion_weights(*sig)
    return np.sqrt(sum(wk**2 * sk**2 for wk, sk in zip(w, sig, strict=True)) / sum(w) ** 2)


def worst_case_coherence(p: Params) -> float:
    """A = gamma_Rg^min gamma_SNR^min gamma_other  (Proposition 1)."""
    return p.coherence_rg_min * p.coherence_snr_min * p.coherence_other


def bound_constant(wavelength: float, theta0: float, worst_coherence: float,
                   looks: int) -> float:
    """C = sqrt(lambda^2 sin^2(theta_0) (1 - A^2) / (8 pi^2 A^2 n_L)), the constant of
    Proposition 1: sigma_h_bar = C r_0 / sqrt(sum_k b_perp,k^2)  (eq. 19 for two slaves)."""
    a = worst_coherence
    return math.sqrt(wavelength**2 * math.sin(theta0) ** 2 * (1.0 - a * a)
                     / (8.0 * math.pi**2 * a * a * looks))


def height_error_bound(wavelength: float, r0: ArrayLike, theta0: float, b_perp_sq_sum: ArrayLike,
                       worst_coherence: float, looks: int) -> ArrayLike:
    """Proposition 1 for K slaves: sigma_h <= sqrt(lambda^2 r_0^2 sin^2(theta_0) (1 - A^2) /
    (8 pi^2 A^2 n_L sum_k b_perp,k^2)) = C r_0 / sqrt(sum_k b_perp,k^2); +inf when every
    perpendicular baseline vanishes. Each sigma_hk <= C r_0 / b_perp,k at coherence >= A, and
    the fused (sum_k sigma_hk^-2)^(-1/2) is then at most C r_0 (sum_k b_perp,k^2)^(-1/2).

    Single-baseline (benchmark 1) is the same expression with one term, the bound on sigma_h1
    (eq. 27 of the appendix).
    """
    k = bound_constant(wavelength, theta0, worst_coherence, looks)
    with np.errstate(divide="ignore"):
        return k * np.asarray(r0, dtype=float) / np.sqrt(np.asarray(b_perp_sq_sum, dtype=float))


def distance_to_station(x: ArrayLike, y: ArrayLike, z: ArrayLike,
                        station: tuple[float, float, float]) -> ArrayLike:
    """d_k,n = ||q_k[n] - g||_2 with q_k[n] = (x_k, y[n], z_k)  (section II-B)."""
    gx, gy, gz = station
    return np.sqrt((np.asarray(x) - gx) ** 2 + (np.asarray(y) - gy) ** 2
                   + (np.asarray(z) - gz) ** 2)


def fdma_rate(p_w: ArrayLike, d_m: ArrayLike, bandwidth_hz: float, beta_c: float) -> ArrayLike:
    """R_k,n = B_c log2(1 + P_com,k[n] beta_c / d_k,n^2)  (eq. 17, free-space FDMA).

    Written with log1p: for a wide band the SNR needed is tiny and 1 + SNR would round to 1."""
    snr = np.asarray(p_w) * beta_c / np.asarray(d_m) ** 2
    return bandwidth_hz * np.log1p(snr) / np.log(2.0)


def power_for_rate(rate_bps: float, d_m: ArrayLike, bandwidth_hz: float,
                   beta_c: float) -> ArrayLike:
    """The least P_com meeting R_k,n >= rate: (2^(rate/B_c) - 1) d^2 / beta_c (C10 tight);
    +inf when 2^(rate/B_c) is beyond double precision (no power reaches that rate)."""
    with np.errstate(over="ignore"):
        return np.expm1(rate_bps / bandwidth_hz * np.log(2.0)) * np.asarray(d_m) ** 2 / beta_c
