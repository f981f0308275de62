"""`uav-insar` as a user runs it: exit codes, JSON shape, sweep CSV and plots."""
import csv
import json
import sys

import numpy as np
import process_group

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]


def run(*args, timeout=120):
    return process_group.run([*CLI, *args], capture_output=True, text=True, timeout=timeout)


def test_solve_json_matches_library_plan():
    proc = run("solve", "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("feasible", "scheme", "sigma_h_m", "sigma_h_bound_m", "formation", "p_com_w",
                "iterations", "solve_time_s", "constraints", "lower_bound_m",
                "optimality_gap"):
        assert key in out
    assert out["feasible"] and out["scheme"] == "proposed"
    assert set(out["constraints"]) == {f"C{i}" for i in range(1, 12)}
    assert all(c["ok"] for c in out["constraints"].values())
    assert len(out["p_com_w"]) == 3 and all(len(row) == 80 for row in out["p_com_w"])
    plan = solve(default_params())
    got = np.array([[out["formation"][f"uav{k}"]["x_m"], out["formation"][f"uav{k}"]["z_m"]]
                    for k in range(3)])
    np.testing.assert_allclose(got, plan.formation, rtol=1e-9)
    assert out["sigma_h_m"] <= out["sigma_h_bound_m"]


def test_solve_text_lists_every_constraint_and_scheme_option():
    proc = run("solve", "--scheme", "single-baseline", "--set", "h_amb_min_m=1.0")
    assert proc.returncode == 0, proc.stderr
    assert "uav2  (not flown by this scheme)" in proc.stdout
    for i in range(1, 12):
        assert f"  C{i} " in proc.stdout


def test_infeasible_exit_3_with_blocking_constraints():
    proc = run("solve", "--json", "--set", "z_max_m=30")
    assert proc.returncode == 3
    out = json.loads(proc.stdout)
    assert not out["feasible"]
    assert out["blocking_constraints"] == ["C1", "C5"]


def test_bad_choice_exit_2():
    proc = run("solve", "--scheme", "best")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1


def test_sweep_csv_and_plot(tmp_path):
    csv_path, png = tmp_path / "s.csv", tmp_path / "s.png"
    proc = run("sweep", "rate_min_mbps[1]", "17", "18.5", "4", "--schemes", "proposed",
               "static-power", "--set", "p_com_max_db=9", "--csv", str(csv_path),
               "--plot", str(png), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(line for line in csv_path.read_text().splitlines()
                               if not line.startswith("#")))
    assert len(rows) == 8
    feas = {(float(r["value"]), r["scheme"]): r["feasible"] == "True" for r in rows}
    assert feas[(17.0, "static-power")] and not feas[(17.5, "static-power")]
    assert not feas[(18.5, "proposed")]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sweep_rejects_unknown_name():
    proc = run("sweep", "rate_min_mbps", "1", "2", "3")
    assert proc.returncode == 2 and "needs an index" in proc.stderr


def test_plot_formation(tmp_path):
    png = tmp_path / "f.png"
    proc = run("plot-formation", "--out", str(png))
    assert proc.returncode == 0, proc.stderr
    assert png.stat().st_size > 10_000


def test_sweep_band_brackets_the_paper_solution_set(tmp_path):
    """The exact optimum is the least sigma_h of all; the paper's solution set (formations
    reaching the least bound) can only do as well or worse, and reaches the same bound."""
    csv_path = tmp_path / "b.csv"
    proc = run("sweep", "h_amb_min_m", "0.9", "1.2", "2", "--schemes", "proposed", "--band",
               "--csv", str(csv_path), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(line for line in csv_path.read_text().splitlines()
                               if not line.startswith("#")))
    for r in rows:
        sigma, lo, hi = float(r["sigma_h_m"]), float(r["band_lo_m"]), float(r["band_hi_m"])
        assert sigma <= lo * (1 + 1e-3) and lo < hi
        assert float(r["bound_opt_m"]) <= float(r["sigma_h_bound_m"]) * (1 + 1e-9)


def test_solve_warns_when_the_plan_needs_better_than_gnss():
    # Table I's optimum puts the slaves d_min = 1.5 m apart: below standard GNSS accuracy.
    proc = run("solve", "--json")
    warning = [line for line in proc.stderr.splitlines() if "warning" in line]
    assert len(warning) == 1 and "uav1 and uav2 are planned 1.50 m apart" in warning[0]
    assert json.loads(proc.stdout)["feasible"]  # stdout stays one JSON object
    wider = run("solve", "--set", "d_min_m=2.5")
    assert wider.returncode == 0 and "warning" not in wider.stderr, wider.stderr
    assert "warning" not in run("solve", "--min-separation-m", "0").stderr
    bad = run("solve", "--min-separation-m", "nan")
    assert bad.returncode == 2 and "--min-separation-m" in bad.stderr


PAPER_FIG4_EDGE = ("--set", "p_com_max_db=9", "--set", "rate_min_mbps=[10,18.3,1]")


def test_paper_switch_solves_the_papers_problem():
    """Issue 42: at Figure 4's 18.3 Mbit/s the paper's (P) is feasible; the field problem (the
    default, 5 % rate margin) is not, and says so once; an explicit --set wins over --paper."""
    paper = run("solve", "--paper", *PAPER_FIG4_EDGE, "--json")
    assert paper.returncode == 0, paper.stderr
    out = json.loads(paper.stdout)
    assert out["feasible"] and round(out["sigma_h_m"], 5) == 0.07844
    assert out["rate_margin"]["margin"] == 0.0
    field = run("solve", *PAPER_FIG4_EDGE)
    assert field.returncode == 3, field.stderr
    assert field.stdout.count("includes a 5 % rate margin") == 1, field.stdout
    assert "without it feasible at sigma_h 7.844 cm" in field.stdout
    explicit = run("solve", "--paper", *PAPER_FIG4_EDGE, "--set", "rate_margin=0.05", "--json")
    assert explicit.returncode == 3 and json.loads(explicit.stdout)["rate_margin"]["margin"] \
        == 0.05
    assert "wins over --paper" in json.loads(explicit.stdout)["rate_margin"]["text"]


def test_sweep_says_its_rate_margin_once():
    args = ("sweep", "rate_min_mbps[1]", "17.5", "18", "2", "--schemes", "proposed",
            "--set", "p_com_max_db=9", "--no-progress", "--jobs", "1")
    field, paper = run(*args), run(*args, "--paper")
    assert field.returncode == paper.returncode == 0, field.stderr + paper.stderr
    assert field.stdout.count("includes a 5 % rate margin") == 1, field.stdout
    assert paper.stdout.count("rate margin 0: C10 holds R_min exactly") == 1, paper.stdout
    assert "infeas." in field.stdout and "infeas." not in paper.stdout
