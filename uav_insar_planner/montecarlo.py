"""Monte-Carlo of the interferometric measurement of a formation (science layer, no ROS).

Per pair (U0, Uk), with the pair's total coherence gamma_k and h_amb,k from the checker
(evaluate.pair_metrics, eqs. 6-12), each sample is one pixel of n_L looks: complex circular
Gaussian pairs z1 = a, z2 = gamma a + sqrt(1 - gamma^2) b (a, b ~ CN(0, 1) per look), the
multilook phase psi = arg(sum_l z1_l conj(z2_l)) (true phase 0) and the height error
h_amb,k psi / (2 pi) (eq. 13). The fused DEM weights the pairs with the paper's w_k =
1/sigma_hk^2 of the model (model.fusion_weights, eq. 15). The pairs are drawn independently,
as eq. 15's weights assume (the shared master image would correlate them; the model defines
no slave-slave coherence to simulate that). `gaussian=True` draws psi ~ N(0, sigma_CR^2)
instead: the model's own assumption, the test of the fusion.

Ambiguities. psi is only known modulo 2 pi. The true height is drawn uniformly over one
ambiguity interval of the finest pair, h ~ U[a, b) = U[-h_min/2, h_min/2) (a prior DEM good to
+-h_min/2, the most a single pair can resolve), pair k measures wrap(2 pi h / h_amb,k + psi_k)
and reads the height y_k = h_amb,k wrap(.) / (2 pi) in its own interval
[-h_amb,k/2, h_amb,k/2). A pair has an ambiguity error when the true phase plus the phase error
leaves (-pi, pi]: its reading is then off by h_amb,k. Fused without resolution: the weighted
mean of the K readings (an error if any pair is off).

Resolution across the K pairs (multi-baseline phase unwrapping, the maximum-likelihood
multi-baseline height estimate, as in Ferretti, Monti Guarnieri, Prati and Rocca, IEEE TGRS
37(2), 1999, in its Gaussian form, with the uniform prior as a constraint): choose integer
cycles n in Z^K and a height h in [a, b] to minimise the weighted squared disagreement
    J(n, h) = sum_k w_k (y_k + n_k h_amb,k - h)^2,   w_k = 1/sigma_hk^2 (eq. 15's weights).
For fixed n the best h is the weighted mean h_hat(n) clipped to [a, b]. The candidates are
every pair's own cycles one either side, c = y_j + m h_amb,j (m in {-1, 0, 1}, j = 1..K;
every h_amb,k >= b - a, so the true unwrapped reading h + e_j is among them), each pair then
taking its cycle nearest to c, n_k = round((c - y_k)/h_amb,k): 3K candidate vectors, the least
J wins. A resolved sample is wrong if any n_k differs from the true cycle. The pairs' combined
unambiguous interval is where h_hat(n) repeats with zero disagreement: with equal h_amb,k
(C8 binding at every slave) that is h_amb itself, no longer than the prior interval:
resolution then only makes the pairs agree with each other (the fused phase wraps instead of
any single pair's). Diverse h_amb,k stretch it (to the least
common multiple of commensurate h_amb,k), so the noise, not the period, limits it.

Confidence intervals (95 %): for a standard deviation the large-sample, distribution-free
interval s^2 +- 1.96 sqrt((m_4 - s^4 (n-3)/(n-1)) / n) (m_4 the fourth central moment; the
phase errors are heavy-tailed, so the chi-square interval, exact only for Gaussian data, would
be too narrow), square-rooted; for a fraction the Wilson score interval.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uav_insar_planner import model, multilook
from uav_insar_planner.swarm import MASTER, slaves, uav_name

Z95 = 1.959963984540054
CHUNK = 1 << 16


@dataclass(frozen=True)
class Estimate:
    """A Monte-Carlo figure with its 95 % confidence interval."""

    value: float
    lo: float
    hi: float

    def to_dict(self) -> dict[str, float]:
        return {"value": self.value, "ci95": [self.lo, self.hi]}


def std_ci(x: np.ndarray) -> Estimate:
    """Sample standard deviation with the distribution-free interval (module docstring)."""
    n = len(x)
    d = x - x.mean()
    d2 = d * d
    s2 = float(d2.sum()) / (n - 1)
    m4 = float(d2 @ d2) / n
    half = Z95 * math.sqrt(max(m4 - s2 * s2 * (n - 3) / (n - 1), 0.0) / n)
    return Estimate(math.sqrt(s2), math.sqrt(max(s2 - half, 0.0)), math.sqrt(s2 + half))


def fraction_ci(hits: np.ndarray) -> Estimate:
    """Fraction of True with the Wilson score interval."""
    n, k = len(hits), int(np.count_nonzero(hits))
    p = k / n
    den = 1.0 + Z95**2 / n
    mid = (p + Z95**2 / (2 * n)) / den
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / den
    return Estimate(p, max(mid - half, 0.0), min(mid + half, 1.0))


def multilook_phase(rng: np.random.Generator, gamma: float, looks: int,
                    samples: int) -> np.ndarray:
    """`samples` multilook interferogram phases (true phase 0), drawn in chunks. With
    a = ar + i ai, b = br + i bi: sum a conj(gamma a + s b) = gamma sum |a|^2 + s sum a conj(b),
    written out in real arithmetic (the common factor 1/sqrt(2) of CN(0, 1) drops out of arg)."""
    out = np.empty(samples)
    s = math.sqrt(max(1.0 - gamma * gamma, 0.0))
    per = max(1, CHUNK // looks)
    for i in range(0, samples, per):
        n = min(per, samples - i)
        ar, ai, br, bi = rng.standard_normal((4, n, looks))
        re = gamma * np.sum(ar * ar + ai * ai, axis=1) + s * np.sum(ar * br + ai * bi, axis=1)
        im = s * np.sum(ai * br - ar * bi, axis=1)
        out[i:i + n] = np.arctan2(im, re)
    return out


def _wrap(phi: np.ndarray) -> np.ndarray:
    """phi wrapped to [-pi, pi)."""
    return np.remainder(phi + math.pi, 2.0 * math.pi) - math.pi


def _fused(readings: list[np.ndarray], weights: tuple) -> np.ndarray:
    """sum_k w_k h_k / sum_k w_k over the K pairs (eq. 15)."""
    return sum(w * h for w, h in zip(weights, readings, strict=True)) / sum(weights)


def resolve_ambiguities(readings: np.ndarray, h_amb: np.ndarray, weights: np.ndarray,
                        prior: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Multi-baseline ambiguity resolution: the integer cycles n (samples, K) that make the K
    readings agree best, and the height they give (module docstring). `readings` (samples, K)
    are y_k in [-h_amb,k/2, h_amb,k/2); `prior` = [a, b) the interval the true height is in.

    MAP under a uniform prior on [a, b] and Gaussian height errors of weights w_k:
    min over n in Z^K, h in [a, b] of sum_k w_k (y_k + n_k h_amb,k - h)^2. For fixed n the best
    h is clip(h_hat(n), a, b), h_hat(n) = sum_k w_k (y_k + n_k h_amb,k) / sum_k w_k, with cost
    J(n) = sum_k w_k (y_k + n_k h_amb,k - h_hat)^2 + (sum_k w_k) (h_hat - clip(h_hat))^2.
    Candidates: each pair's readings one cycle either side, c = y_j + m h_amb,j (m in {-1, 0,
    1}: every h_amb,k >= b - a, so the true unwrapped reading is among them); for each c every
    pair takes its nearest cycle n_k = round((c - y_k) / h_amb,k). 3K candidates, the least J
    wins (the first on a tie)."""
    lo, hi = prior
    w = weights / weights.sum()
    best_cost = np.full(readings.shape[0], np.inf)
    best_n = np.zeros(readings.shape, dtype=np.int64)
    for j in range(readings.shape[1]):
        for m in (-1, 0, 1):
            c = readings[:, j] + m * h_amb[j]
            n = np.rint((c[:, None] - readings) / h_amb)
            h = readings + n * h_amb
            est = h @ w
            cost = ((h - est[:, None]) ** 2) @ w + (est - np.clip(est, lo, hi)) ** 2
            better = cost < best_cost
            best_cost[better] = cost[better]
            best_n[better] = n[better]
    est = np.clip((readings + best_n * h_amb) @ w, lo, hi)
    return best_n, est


def _pair_row(name: str, pair: dict[str, float], r: np.random.Generator, truth: np.ndarray,
              looks: int, gaussian: bool) -> tuple[dict, np.ndarray, np.ndarray]:
    """One pair's table row, its height errors h_amb psi / (2 pi) and its wrapped readings."""
    samples = len(truth)
    g, h_amb = pair["coherence_total"], pair["h_amb_m"]
    crb = float(model.phase_error_crb(g, looks))
    psi = (r.normal(0.0, crb, samples) if gaussian
           else multilook_phase(r, g, looks, samples))
    err = h_amb * psi / (2 * math.pi)
    total = 2 * math.pi * truth / h_amb + psi
    reading = h_amb * _wrap(total) / (2 * math.pi)
    row = {"coherence": g, "h_amb_m": h_amb, "phase_std_crb_rad": crb,
           "phase_std_mc_rad": std_ci(psi).to_dict(),
           "beyond_half_pi": fraction_ci(np.abs(psi) > 0.5 * math.pi).to_dict(),
           "sigma_h_model_m": float(model.height_error(h_amb, crb)),
           "sigma_h_mc_m": std_ci(err).to_dict(),
           "ambiguity_rate": fraction_ci(np.abs(total) > math.pi).to_dict()}
    if looks <= multilook.MAX_LOOKS:
        s = float(multilook.phase_std(g, looks))
        row["phase_std_exact_rad"] = s
        row["sigma_h_exact_m"] = float(model.height_error(h_amb, s))
    return row, err, reading


def _fusion(rows: dict, err: dict, reading: dict, truth: np.ndarray,
            h_min: float) -> tuple[dict, np.ndarray]:
    """The fused figures of K >= 2 pairs: the model's and the Monte-Carlo's, and with the
    ambiguities without and with resolution across the pairs."""
    names = list(rows)
    sig = [rows[k]["sigma_h_model_m"] for k in names]
    weights = model.fusion_weights(*sig)
    fused_err = _fused([err[k] for k in names], weights)
    h_amb = np.array([rows[k]["h_amb_m"] for k in names])
    y = np.stack([reading[k] for k in names], axis=1)
    true_unwrapped = truth[:, None] + np.stack([err[k] for k in names], axis=1)
    wrong = np.any(np.abs(y - true_unwrapped) > 0.5 * h_amb, axis=1)
    n, resolved = resolve_ambiguities(y, h_amb, np.array(weights, dtype=float),
                                      (-0.5 * h_min, 0.5 * h_min))
    wrong_res = np.any(np.abs(y + n * h_amb - true_unwrapped) > 0.5 * h_amb, axis=1)
    fused = {"sigma_h_model_m": float(model.fused_height_error(*sig)),
             "sigma_h_mc_m": std_ci(fused_err).to_dict(),
             "ambiguity_rate": fraction_ci(wrong).to_dict(),
             "ambiguity_rate_resolved": fraction_ci(wrong_res).to_dict(),
             "sigma_h_with_ambiguities_m": std_ci(
                 _fused([reading[k] for k in names], weights) - truth).to_dict(),
             "sigma_h_resolved_m": std_ci(resolved - truth).to_dict()}
    if all("sigma_h_exact_m" in rows[k] for k in names):
        fused["sigma_h_exact_m"] = float(model.fused_height_error(
            *(rows[k]["sigma_h_exact_m"] for k in names)))
    return fused, fused_err


def simulate(pairs: dict[str, dict[str, float]], looks: int, samples: int = 100_000,
             seed: int = 0, gaussian: bool = False, keep_samples: bool = False) -> dict:
    """The Monte-Carlo table of a formation: `pairs` maps a pair name ("uav1", "uav2", ...,
    K of them) to the checker's metrics (needs coherence_total, h_amb_m). Returns per pair and,
    for K >= 2, fused: model and Monte-Carlo figures (see the module docstring);
    `keep_samples` adds the height errors."""
    if samples < 2:
        raise ValueError(f"samples: value {samples!r} is not allowed; expected >= 2")
    if not pairs:
        raise ValueError("pairs: value {} is not allowed; expected at least one pair")
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    rng_truth, *rng_pairs = rng.spawn(1 + len(pairs))
    names = list(pairs)
    h_min = min(pairs[k]["h_amb_m"] for k in names)
    truth = rng_truth.uniform(-0.5 * h_min, 0.5 * h_min, samples)
    out: dict = {"samples": samples, "seed": seed, "looks": looks,
                 "noise": "gaussian" if gaussian else "multilook", "pairs": {}}
    err, reading = {}, {}
    for name, r in zip(names, rng_pairs, strict=True):
        out["pairs"][name], err[name], reading[name] = _pair_row(
            name, pairs[name], r, truth, looks, gaussian)
    if len(names) >= 2:
        out["fused"], fused_err = _fusion(out["pairs"], err, reading, truth, h_min)
        if keep_samples:
            err["fused"] = fused_err
    if keep_samples:
        out["height_errors_m"] = err
    return out


def pairs_of_formation(p, formation: np.ndarray) -> dict[str, dict[str, float]]:
    """The checker's pair metrics for a (num_uavs, 2) formation, NaN rows not flown (its row
    count is the swarm's size)."""
    from uav_insar_planner.evaluate import pair_metrics

    q = np.asarray(formation, dtype=float)
    return {uav_name(k): pair_metrics(p, q[MASTER], q[k]) for k in slaves(len(q))
            if np.all(np.isfinite(q[k]))}


def format_table(result: dict) -> str:
    """The Monte-Carlo result as a terminal table."""
    def ci(e, scale=1.0, fmt="{:.4f}"):
        v, (lo, hi) = e["value"] * scale, e["ci95"]
        return (fmt + " [" + fmt + ", " + fmt + "]").format(v, lo * scale, hi * scale)

    lines = [f"Monte-Carlo: {result['samples']} samples per pair, seed {result['seed']}, "
             f"n_L = {result['looks']}, {result['noise']} phase noise; 95 % intervals",
             "  pair   coherence  h_amb_m  phase std rad: CR / exact / MC             "
             "beyond pi/2 %         ambiguity %"]
    for name, r in result["pairs"].items():
        exact = f"{r['phase_std_exact_rad']:.4f}" if "phase_std_exact_rad" in r else "  -   "
        lines.append(f"  U0-{name[-1]}  {r['coherence']:9.4f}  {r['h_amb_m']:7.3f}  "
                     f"{r['phase_std_crb_rad']:.4f} / {exact} / {ci(r['phase_std_mc_rad'])}  "
                     f"{ci(r['beyond_half_pi'], 100, '{:.2f}')}  "
                     f"{ci(r['ambiguity_rate'], 100, '{:.2f}')}")
    lines += ["", "  height error sigma_h m: model (Cramer-Rao) / exact multilook / Monte-Carlo"]
    rows = list(result["pairs"].items()) + ([("fused", result["fused"])]
                                            if "fused" in result else [])
    for name, r in rows:
        exact = f"{r['sigma_h_exact_m']:.5f}" if "sigma_h_exact_m" in r else "   -   "
        label = "fused" if name == "fused" else f"U0-{name[-1]}"
        lines.append(f"  {label:<6} {r['sigma_h_model_m']:.5f} / {exact} / "
                     f"{ci(r['sigma_h_mc_m'], 1.0, '{:.5f}')}")
    if "fused" in result:
        f = result["fused"]
        lines += ["", "  fused DEM with ambiguities (true height uniform over one h_amb):",
                  f"    without resolution: ambiguity {ci(f['ambiguity_rate'], 100, '{:.2f}')} %,"
                  f" sigma_h {ci(f['sigma_h_with_ambiguities_m'], 1.0, '{:.4f}')} m",
                  f"    resolved across the {len(result['pairs'])} pairs: ambiguity "
                  f"{ci(f['ambiguity_rate_resolved'], 100, '{:.2f}')} %, sigma_h "
                  f"{ci(f['sigma_h_resolved_m'], 1.0, '{:.4f}')} m"]
    return "\n".join(lines)
