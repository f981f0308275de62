"""Parameter files: Table I defaults, SI conversion in one place, and one clear line per error."""
import dataclasses
import math
import sys
from pathlib import Path

import process_group
import pytest

from uav_insar_planner.params import PAPER_VALUES, PARAM_SPECS, ParamError, default_params
from uav_insar_planner.params_file import load_params, read_params_file

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "config" / "params.yaml"


def test_config_file_holds_table_one_defaults():
    values = read_params_file(CONFIG)
    assert set(values) == {s.name for s in PARAM_SPECS}
    for spec in PARAM_SPECS:
        assert values[spec.name] == spec.default, spec.name
    assert load_params(CONFIG) == default_params()


# The paper's problem (P) at Table I, read off the paper (section V, Table I; C1-C11 as (P)
# states them), for every scenario parameter that is part of the problem. Not here: `solver`
# and `time_budget_s` (how it is solved, not what), and the tomographic objective's own
# settings (TOMOGRAPHY: the paper has no such objective).
PAPER_PROBLEM = {
    "num_uavs": 3, "num_slots": 80, "slot_duration_s": 1.0, "z_min_m": 1.0, "z_max_m": 100.0,
    "h_amb_min_m": 1.2, "h_amb_ratio": 1.0, "target_x_m": 20.0,
    "ground_station_m": [70.0, 149.37, 25.0], "d_min_m": 1.5, "swath_min_m": 55.0,
    "speed_mps": 4.3, "p_com_max_db": 10.1, "e_com_max_j": 594.0,
    "rate_min_mbps": [10.0, 16.95, 1.0], "rate_margin": 0.0, "comm_bandwidth_hz": 1e9,
    "ref_snr_db": 18.69, "coherence_rg_min": 0.8, "coherence_snr_min": 0.8,
    "coherence_other": 0.6, "sigma0_db": -10.0, "radar_power_dbm": 26.02, "gain_tx_dbi": 5.0,
    "gain_rx_dbi": 5.0, "wavelength_m": 0.12, "duty_cycle": 1e-4, "look_angle_deg": 45.0,
    "system_temperature_k": 400.0, "radar_bandwidth_hz": 3e9, "noise_figure_db": 5.0,
    "losses_db": 6.0, "center_frequency_hz": 2.5e9, "beamwidth_deg": 33.44,
    "slave_look_angle_min_deg": 37.24, "slave_look_angle_max_deg": 48.7, "looks": 4,
    "tolerance": 1e-2, "master_fixed_xz_m": [-54.0, 74.0], "nav_error_m": 0.0,
    "scheme": "proposed", "objective": "exact"}

TOMOGRAPHY = ("tomo_height_span_m", "tomo_resolution_m", "tomo_ambiguity_min_m")


def test_every_default_is_the_papers_but_the_declared_field_only_ones():
    """A default that departs from the paper's problem says so (ParamSpec.paper), so that
    `--paper` sets it back; rate_margin is the one today."""
    assert set(PAPER_PROBLEM) == {s.name for s in PARAM_SPECS} - {
        "solver", "time_budget_s", *TOMOGRAPHY}
    def value(p, name):  # a list as the paper writes it (Params.raw holds tuples)
        v = p.raw[name]
        return list(v) if isinstance(v, tuple) else v

    field_only = {n: v for n, v in PAPER_PROBLEM.items() if value(default_params(), n) != v}
    assert field_only == PAPER_VALUES == {"rate_margin": 0.0}
    paper = default_params(paper=True)
    assert {n: value(paper, n) for n in PAPER_PROBLEM} == PAPER_PROBLEM


def test_the_paper_switch_over_a_file_under_an_override(tmp_path):
    """load_params(paper=True): the file's values, then the paper's for the field-only ones,
    then the overrides (an explicit rate_margin wins)."""
    assert load_params(paper=True) == default_params(paper=True)
    assert load_params(CONFIG, paper=True) == default_params(paper=True)
    assert load_params(CONFIG).rate_margin == 0.05  # the field problem stays the default
    f = tmp_path / "p.yaml"
    f.write_text('"/**":\n  ros__parameters:\n    rate_margin: 0.2\n    looks: 8\n')
    p = load_params(f, paper=True)
    assert (p.rate_margin, p.looks) == (0.0, 8)
    assert load_params(f, {"rate_margin": 0.1}, paper=True).rate_margin == 0.1


def test_si_conversion():
    p = default_params()
    assert p.p_max_w == pytest.approx(10 ** 1.01)          # 10.1 dBW
    assert p.radar_power_w == pytest.approx(0.39994, rel=1e-4)  # 26.02 dBm
    assert p.beta_c == pytest.approx(10 ** 1.869)          # 18.69 dB
    assert p.rate_min_bps == (10e6, 16.95e6, 1e6)
    assert p.theta0 == pytest.approx(math.pi / 4)
    assert p.beamwidth == pytest.approx(math.radians(33.44))
    assert p.losses == pytest.approx(10 ** 0.6)


def test_every_params_field_is_one_specs_value_in_si():
    """Params is built from the table alone: each field is a spec's value through its own
    conversion, whatever the value."""
    fields = {f.name for f in dataclasses.fields(default_params())}
    assert {s.attribute for s in PARAM_SPECS} == fields - {"raw", "energy_budget_uav_j"}
    changed = default_params().replace(look_angle_deg=30.0, radar_power_dbm=30.0,
                                       rate_min_mbps=[2.0, 3.0, 4.0], losses_db=3.0)
    assert changed.theta0 == pytest.approx(math.pi / 6) and changed.radar_power_w == 1.0
    assert changed.rate_min_bps == (2e6, 3e6, 4e6)
    assert changed.losses == pytest.approx(10 ** 0.3)
    for spec in PARAM_SPECS:
        assert getattr(changed, spec.attribute) == spec.si_value(changed.raw[spec.name])


def test_replace_checks_what_it_changes_and_every_rule_between_fields():
    """replace takes the unchanged values as they are (a sweep makes thousands of copies)
    and gives what a full validation of the merged values gives, errors included."""
    from uav_insar_planner.params import params_from_mapping

    p = default_params()
    changes = {"h_amb_min_m": 1.3, "rate_min_mbps": [10, 17.5, 1], "num_uavs": 3,
               "p_com_max_db": 9}
    assert p.replace(**changes) == params_from_mapping({**p.raw, **changes})
    assert p.replace(num_uavs=3).rate_min_bps == p.rate_min_bps
    with pytest.raises(ParamError, match=r"^h_amb_min_m: value -1\.0 is not allowed"):
        p.replace(h_amb_min_m=-1.0)
    with pytest.raises(ParamError, match=r"^z_min_m: value 500\.0 is not allowed; expected "
                       r"less than z_max_m"):
        p.replace(z_min_m=500.0)  # valid alone, against the unchanged z_max_m
    with pytest.raises(ParamError, match=r"rate_min_mbps: .* with num_uavs 2"):
        p.replace(num_uavs=2)  # the unchanged per-UAV lists hold three


def test_node_section_overrides_global_section(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text('"/**":\n  ros__parameters:\n    looks: 4\n    d_min_m: 2.0\n'
                 "/planner:\n  ros__parameters:\n    looks: 8\n"
                 "agent:\n  ros__parameters:\n    looks: 16\n")
    p = load_params(f)
    assert (p.looks, p.d_min) == (8, 2.0)


def test_scientific_notation_reads_as_float(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text('"/**":\n  ros__parameters:\n    comm_bandwidth_hz: 2e9\n')
    assert load_params(f).comm_bandwidth_hz == 2e9


def test_all_problems_reported_at_once():
    with pytest.raises(ParamError) as err:
        load_params(None, {"looks": 2.5, "rate_min_mbps": [1, 2], "foo": 1,
                           "scheme": "best"})
    names = sorted(line.split(":")[0] for line in err.value.problems)
    assert names == ["foo", "looks", "rate_min_mbps", "scheme"]


BAD_FILES = {
    "unknown": ('"/**":\n  ros__parameters:\n    looks_n: 4\n', "looks_n: unknown parameter"),
    "type": ('"/**":\n  ros__parameters:\n    z_max_m: high\n', "z_max_m: value 'high'"),
    "range": ('"/**":\n  ros__parameters:\n    coherence_rg_min: 1.5\n',
              "coherence_rg_min: value 1.5 is not allowed; expected a finite number in [0.01, 1)"),
    "not finite": ('"/**":\n  ros__parameters:\n    d_min_m: .nan\n', "d_min_m: value nan"),
    "length": ('"/**":\n  ros__parameters:\n    ground_station_m: [1, 2]\n',
               "ground_station_m: value [1, 2] is not allowed; expected a list of 3"),
    "order": ('"/**":\n  ros__parameters:\n    z_min_m: 120.0\n',
              "z_min_m: value 120.0 is not allowed; expected less than z_max_m (100.0)"),
    "yaml": ('"/**":\n  ros__parameters: [\n', "is not valid YAML"),
    "layout": ("looks: 4\n", "must hold a 'ros__parameters' mapping"),
    # 478 bytes of nested aliases once took 22 s and 2.4 GB to expand.
    "aliases": ("a: &a [x, x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
                "c: [*b, *b, *b, *b, *b, *b, *b, *b, *b]\n", "aliases are not allowed"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_params_file_cli(tmp_path, case):
    text, expected = BAD_FILES[case]
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "solve", "--params",
                           str(f)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert expected in lines[0]
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("path,expected", [("/dev/zero", "larger than 1048576 bytes"),
                                           ("latin1", "is not UTF-8")])
def test_unreadable_kinds_of_params_file_are_one_line(tmp_path, path, expected):
    if path == "latin1":
        path = tmp_path / "p.yaml"
        path.write_bytes(b'"/**":\n  ros__parameters:\n    scheme: "\xe9"\n')
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "solve", "--params",
                           str(path)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and expected in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_missing_file_and_bad_set(tmp_path):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "solve", "--params",
                           str(tmp_path / "nope.yaml")], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and "cannot be read" in proc.stderr
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "solve", "--set",
                           "looks"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "expected NAME=VALUE" in proc.stderr
