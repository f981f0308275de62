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
ambiguity interval of the finer pair, h ~ U[-h_min/2, h_min/2) (a prior DEM good to +-h_min/2,
the most a single pair can resolve), pair k measures wrap(2 pi h / h_amb,k + psi_k) and reads
the height in its own interval [-h_amb,k/2, h_amb,k/2). A sample has an ambiguity error when
the true phase plus the phase error leaves (-pi, pi]: the height is then off by h_amb,k.
Fused without resolution: the weighted mean of both readings (an error if either is off).
Dual-baseline resolution: the second pair's reading h_2 picks the first pair's ambiguity
number m = round((h_2 - h_1) / h_amb,1), h_1 -> h_1 + m h_amb,1; then fused as before.

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


def _fused(h1, h2, w1, w2):
    return (w1 * h1 + w2 * h2) / (w1 + w2)


def simulate(pairs: dict[str, dict[str, float]], looks: int, samples: int = 100_000,
             seed: int = 0, gaussian: bool = False, keep_samples: bool = False) -> dict:
    """The Monte-Carlo table of a formation: `pairs` maps a pair name ("uav1", "uav2") to the
    checker's metrics (needs coherence_total, h_amb_m). Returns per pair and fused: model and
    Monte-Carlo figures (see the module docstring); `keep_samples` adds the height errors."""
    if samples < 2:
        raise ValueError(f"samples: value {samples!r} is not allowed; expected >= 2")
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    rng_truth, *rng_pairs = rng.spawn(1 + len(pairs))
    names = list(pairs)
    h_min = min(pairs[k]["h_amb_m"] for k in names)
    truth = rng_truth.uniform(-0.5 * h_min, 0.5 * h_min, samples)
    out: dict = {"samples": samples, "seed": seed, "looks": looks,
                 "noise": "gaussian" if gaussian else "multilook", "pairs": {}}
    err, reading, model_sig = {}, {}, {}
    for name, r in zip(names, rng_pairs, strict=True):
        g, h_amb = pairs[name]["coherence_total"], pairs[name]["h_amb_m"]
        crb = float(model.phase_error_crb(g, looks))
        psi = (r.normal(0.0, crb, samples) if gaussian
               else multilook_phase(r, g, looks, samples))
        err[name] = h_amb * psi / (2 * math.pi)
        model_sig[name] = float(model.height_error(h_amb, crb))
        total = 2 * math.pi * truth / h_amb + psi
        reading[name] = h_amb * _wrap(total) / (2 * math.pi)
        row = {"coherence": g, "h_amb_m": h_amb, "phase_std_crb_rad": crb,
               "phase_std_mc_rad": std_ci(psi).to_dict(),
               "beyond_half_pi": fraction_ci(np.abs(psi) > 0.5 * math.pi).to_dict(),
               "sigma_h_model_m": model_sig[name],
               "sigma_h_mc_m": std_ci(err[name]).to_dict(),
               "ambiguity_rate": fraction_ci(np.abs(total) > math.pi).to_dict()}
        if looks <= multilook.MAX_LOOKS:
            s = float(multilook.phase_std(g, looks))
            row["phase_std_exact_rad"] = s
            row["sigma_h_exact_m"] = float(model.height_error(h_amb, s))
        out["pairs"][name] = row
    if len(names) == 2:
        a, b = names
        w1, w2 = model.fusion_weights(model_sig[a], model_sig[b])
        fused_err = _fused(err[a], err[b], w1, w2)
        wrong = [np.abs(reading[k] - truth - err[k]) > 0.5 * pairs[k]["h_amb_m"] for k in names]
        h_amb1 = pairs[a]["h_amb_m"]
        m = np.round((reading[b] - reading[a]) / h_amb1)
        resolved = reading[a] + m * h_amb1
        wrong_res = np.abs(resolved - truth - err[a]) > 0.5 * h_amb1
        fused = {"sigma_h_model_m": float(model.fused_height_error(model_sig[a], model_sig[b])),
                 "sigma_h_mc_m": std_ci(fused_err).to_dict(),
                 "ambiguity_rate": fraction_ci(wrong[0] | wrong[1]).to_dict(),
                 "ambiguity_rate_resolved": fraction_ci(wrong_res | wrong[1]).to_dict(),
                 "sigma_h_with_ambiguities_m": std_ci(
                     _fused(reading[a], reading[b], w1, w2) - truth).to_dict(),
                 "sigma_h_resolved_m": std_ci(
                     _fused(resolved, reading[b], w1, w2) - truth).to_dict()}
        if all("sigma_h_exact_m" in out["pairs"][k] for k in names):
            fused["sigma_h_exact_m"] = float(model.fused_height_error(
                *(out["pairs"][k]["sigma_h_exact_m"] for k in names)))
        out["fused"] = fused
        if keep_samples:
            err["fused"] = fused_err
    if keep_samples:
        out["height_errors_m"] = err
    return out


def pairs_of_formation(p, formation: np.ndarray) -> dict[str, dict[str, float]]:
    """The checker's pair metrics for a (num_uavs, 2) formation, NaN rows not flown."""
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
                  f"    U0-2 picks U0-1's ambiguity number: ambiguity "
                  f"{ci(f['ambiguity_rate_resolved'], 100, '{:.2f}')} %, sigma_h "
                  f"{ci(f['sigma_h_resolved_m'], 1.0, '{:.4f}')} m"]
    return "\n".join(lines)
