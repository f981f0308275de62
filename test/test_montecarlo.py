"""The Monte-Carlo of the interferometric measurement (montecarlo.py) and `uav-insar montecarlo`."""
import csv
import json
import math
import sys

import numpy as np
import process_group
import pytest

from uav_insar_planner import model
from uav_insar_planner.montecarlo import multilook_phase, simulate, std_ci
from uav_insar_planner.swarm import MAX_UAVS

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]


def pair(g, h_amb):
    return {"coherence_total": g, "h_amb_m": h_amb}


def test_monte_carlo_matches_cramer_rao_at_high_coherence_and_many_looks():
    r = simulate({"uav1": pair(0.95, 1.0)}, looks=256, samples=100_000, seed=3)
    lo, hi = r["pairs"]["uav1"]["phase_std_mc_rad"]["ci95"]
    assert lo <= model.phase_error_crb(0.95, 256) <= hi
    lo, hi = r["pairs"]["uav1"]["sigma_h_mc_m"]["ci95"]
    assert lo <= r["pairs"]["uav1"]["sigma_h_model_m"] <= hi


def test_direct_draw_matches_the_sufficient_statistic_draw():
    # sum_l z1 conj(z2) = gamma G + sqrt(1 - gamma^2) sqrt(G) c, G ~ Gamma(n_L), c ~ CN(0, 1):
    # an independent way to draw the same phase
    rng = np.random.default_rng(11)
    g, looks, n = 0.5, 4, 200_000
    big_g = rng.gamma(looks, 1.0, n)
    c = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * math.sqrt(0.5)
    other = np.angle(g * big_g + math.sqrt(1 - g * g) * np.sqrt(big_g) * c)
    a, b = std_ci(multilook_phase(rng, g, looks, n)), std_ci(other)
    assert a.lo <= b.hi and b.lo <= a.hi


def test_fusion_matches_eq15_when_the_pairs_are_gaussian():
    r = simulate({"uav1": pair(0.7, 1.0), "uav2": pair(0.5, 2.5)}, looks=4, samples=200_000,
                 seed=5, gaussian=True)
    f = r["fused"]
    lo, hi = f["sigma_h_mc_m"]["ci95"]
    s1, s2 = (r["pairs"][k]["sigma_h_model_m"] for k in ("uav1", "uav2"))
    assert lo <= model.fused_height_error(s1, s2) <= hi
    assert f["sigma_h_model_m"] == pytest.approx(float(model.fused_height_error(s1, s2)))
    # ambiguity with the true phase uniform over one cycle: P = E|psi| / (2 pi)
    crb = r["pairs"]["uav1"]["phase_std_crb_rad"]
    lo, hi = r["pairs"]["uav1"]["ambiguity_rate"]["ci95"]
    assert lo <= crb * math.sqrt(2 / math.pi) / (2 * math.pi) <= hi


def test_table_one_reproduces_the_issue_figures():
    # the issue: 0.750 rad vs CR 0.545, 5.2 % beyond pi/2, fused 0.101 m vs planned 0.0736 m
    r = simulate({"uav1": pair(0.5441, 1.2), "uav2": pair(0.5440, 1.2)}, 4, 100_000, seed=0)
    p1 = r["pairs"]["uav1"]
    assert abs(p1["phase_std_mc_rad"]["value"] - 0.750) < 0.01
    assert abs(p1["beyond_half_pi"]["value"] - 0.052) < 0.003
    assert abs(r["fused"]["sigma_h_mc_m"]["value"] - 0.101) < 0.002
    assert abs(r["fused"]["sigma_h_model_m"] - 0.0736) < 0.0002


def test_a_coarse_coherent_second_pair_resolves_the_first_pairs_ambiguities():
    r = simulate({"uav1": pair(0.5, 1.0), "uav2": pair(0.97, 5.0)}, 4, 100_000, seed=1)
    f = r["fused"]
    assert f["ambiguity_rate"]["value"] > 0.08
    assert f["ambiguity_rate_resolved"]["value"] < 0.2 * f["ambiguity_rate"]["value"]
    assert f["sigma_h_resolved_m"]["value"] < f["sigma_h_with_ambiguities_m"]["value"]


def test_k_pairs_fuse_by_inverse_variance_when_gaussian():
    pairs = {f"uav{k}": pair(g, h) for k, (g, h) in
             enumerate([(0.7, 1.0), (0.5, 2.5), (0.8, 1.3), (0.6, 4.0), (0.9, 1.1)], 1)}
    r = simulate(pairs, looks=4, samples=200_000, seed=8, gaussian=True)
    sig = [r["pairs"][k]["sigma_h_model_m"] for k in pairs]
    assert r["fused"]["sigma_h_model_m"] == pytest.approx(sum(s**-2 for s in sig) ** -0.5)
    lo, hi = r["fused"]["sigma_h_mc_m"]["ci95"]
    assert lo <= r["fused"]["sigma_h_model_m"] <= hi


def test_a_single_pair_has_no_fused_row():
    assert "fused" not in simulate({"uav1": pair(0.6, 1.0)}, 4, 1000, seed=0)


def test_equal_heights_of_ambiguity_resolve_only_to_a_wrap_of_the_fused_phase():
    # all h_amb equal: every integer shift of an agreeing vector agrees as well, so resolution
    # can only align the pairs. It still fails when the fused height (truth uniform over one
    # h_amb) wraps, with probability E|e_fused| / h_amb, and when one pair's error is more than
    # h_amb / 2 from the others' mean (it is then nearer a wrong cycle): no more, no less.
    pairs = {f"uav{k}": pair(0.55, 1.2) for k in range(1, 5)}
    r = simulate(pairs, 4, 100_000, seed=4, keep_samples=True)
    f, e = r["fused"], r["height_errors_m"]
    wraps = float(np.mean(np.abs(e["fused"]))) / 1.2
    each = np.stack([e[k] for k in pairs], axis=1)
    others = (each.sum(axis=1, keepdims=True) - each) / (len(pairs) - 1)
    outlier = float(np.mean(np.any(np.abs(each - others) > 0.6, axis=1)))
    assert wraps - 0.003 <= f["ambiguity_rate_resolved"]["value"] <= wraps + outlier + 0.003
    assert f["ambiguity_rate"]["value"] > 3 * f["ambiguity_rate_resolved"]["value"]


def test_diverse_coherent_pairs_resolve_the_fine_pairs_cycles_across_k():
    pairs = {"uav1": pair(0.5, 1.0), "uav2": pair(0.95, 3.0), "uav3": pair(0.95, 4.0),
             "uav4": pair(0.6, 1.0)}
    f = simulate(pairs, 4, 100_000, seed=2)["fused"]
    assert f["ambiguity_rate"]["value"] > 0.12
    assert f["ambiguity_rate_resolved"]["value"] < 0.1 * f["ambiguity_rate"]["value"]
    # resolved, the DEM is about as good as if there were no ambiguities at all
    assert f["sigma_h_resolved_m"]["value"] < 1.05 * f["sigma_h_mc_m"]["value"]
    assert f["sigma_h_resolved_m"]["value"] < 0.6 * f["sigma_h_with_ambiguities_m"]["value"]


def test_seeded_and_reproducible():
    pairs = {"uav1": pair(0.6, 1.0), "uav2": pair(0.6, 1.0)}
    a, b = simulate(pairs, 4, 1000, seed=9), simulate(pairs, 4, 1000, seed=9)
    assert a == b
    assert simulate(pairs, 4, 1000, seed=10) != a


def run(*args):
    return process_group.run([*CLI, *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("args,field", [
    (("--samples", "1"), "--samples"), (("--samples", "1e5"), "--samples"),
    (("--seed", "-1"), "--seed"), (("--formation", "1,2,3"), "--formation"),
    (("--formation", "0,10,5,nan"), "--formation"), (("--formation", "0,10,5,-3"), "--formation"),
    (("--formation", "0,10,0,10"), "--formation"),
    # one UAV more than the largest swarm (swarm.MAX_UAVS)
    (("--formation", ",".join(["-30,40"] + [f"{-40 - k},50" for k in range(MAX_UAVS)])),
     "--formation")])
def test_bad_input_is_one_line_exit_2(args, field):
    proc = run("montecarlo", *args)
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"uav-insar: error: {field}: value "), lines


def test_cli_plans_simulates_and_plots(tmp_path):
    png = tmp_path / "mc.png"
    proc = run("montecarlo", "--samples", "20000", "--json", "--plot", str(png))
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["source"] == "plan" and out["sigma_h_planned_m"] == pytest.approx(0.07364, 1e-3)
    assert out["montecarlo"]["fused"]["sigma_h_mc_m"]["value"] > 1.2 * out["sigma_h_planned_m"]
    assert png.stat().st_size > 10_000
    proc = run("montecarlo", "--formation=-27.118,47.118,-34.854,48.19", "--samples", "2000")
    assert proc.returncode == 0, proc.stderr
    assert "given formation" in proc.stdout and "U0-1" in proc.stdout and "fused" not in proc.stdout
    six = "-27.5,47.5,-42.1,68.8,-51.0,64.3,-30.0,56.7,-36.1,49.4,-40,30"
    proc = run("montecarlo", f"--formation={six}", "--samples", "2000", "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)["montecarlo"]
    assert list(out["pairs"]) == [f"uav{k}" for k in range(1, 6)] and "fused" in out


def test_cli_prints_the_table_for_four_slaves():
    proc = run("montecarlo", "--set", "num_uavs=5", "--set", "rate_min_mbps=[10,16.95,1,1,1]",
               "--samples", "5000")
    assert proc.returncode == 0, proc.stderr
    assert "U0-4" in proc.stdout and "resolved across the 4 pairs" in proc.stdout


def test_sweep_montecarlo_column_is_opt_in(tmp_path):
    plain, mc = tmp_path / "a.csv", tmp_path / "b.csv"
    args = ("sweep", "h_amb_min_m", "1.0", "1.2", "2", "--schemes", "proposed", "--no-progress")
    p1 = run(*args, "--csv", str(plain))
    p2 = run(*args, "--montecarlo", "--mc-samples", "20000", "--csv", str(mc))
    assert p1.returncode == p2.returncode == 0, p1.stderr + p2.stderr
    assert "mc_sigma_h" not in p1.stdout and "mc_sigma_h" in p2.stdout
    rows_plain = list(csv.DictReader(plain.read_text().splitlines()[1:]))
    rows_mc = list(csv.DictReader(mc.read_text().splitlines()[1:]))
    assert not any(k.startswith("mc_") for k in rows_plain[0])
    for r in rows_mc:
        assert float(r["mc_sigma_h_m"]) > 1.2 * float(r["sigma_h_m"])
        assert 0.05 < float(r["mc_ambiguity"]) < 0.3
