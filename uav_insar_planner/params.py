"""Scenario parameters: validated, then converted to SI.

`PARAM_SPECS` (param_specs/science.py) is the single table of every scenario parameter: name,
type, default, allowed range, unit, description, and its SI value's name in `Params` with the
conversion to it. The planner node declares its ROS parameters from it; the CLI and
`params_file.load_params` validate against it, and `params_from_mapping` builds `Params` from
it. Reading params files and `NAME=VALUE` overrides is `params_file`'s job.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Container, Mapping
from dataclasses import dataclass, field
from typing import Any

from uav_insar_planner.param_specs import ParamSpec
from uav_insar_planner.param_specs.nodes import NODE_SPECS, SUITE_PARAMETER_NAMES, nodes_taking
from uav_insar_planner.param_specs.science import (
    BACKEND_BY_NAME,
    BACKENDS,
    LENGTH_MAX_M,
    MULTILOOK_MAX_LOOKS,
    OBJECTIVES,
    PAPER_VALUES,
    PARAM_SPECS,
    SCHEMES,
    SOLVERS,
    SPEC_BY_NAME,
)
from uav_insar_planner.swarm import MAX_UAVS, MIN_UAVS

# Re-exported: callers import the table and its choices from here, with the values.
__all__ = ["LENGTH_MAX_M", "MULTILOOK_MAX_LOOKS", "OBJECTIVES", "PAPER_VALUES", "PARAM_SPECS",
           "SCHEMES", "SOLVERS", "SPEC_BY_NAME", "ParamSpec"]

SPEED_OF_LIGHT = 299_792_458.0
BOLTZMANN = 1.380649e-23


class ParamError(ValueError):
    """Invalid parameters. `problems` holds one line per bad value; str() joins them."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


def fractional_bandwidth(radar_bandwidth_hz: float, center_frequency_hz: float) -> float:
    """B_p = B_Rg / f_0 (eq. 10), of `Params` or of the values being checked into one."""
    return radar_bandwidth_hz / center_frequency_hz


@dataclass(frozen=True)
class Params:
    """Validated scenario in SI units (metres, seconds, watts, bit/s, radians, linear ratios):
    each field but `raw` and `energy_budget_uav_j` is one PARAM_SPECS value, named and converted
    by its spec (`ParamSpec.attribute`, `ParamSpec.si_value`)."""

    raw: Mapping[str, Any] = field(repr=False)
    num_uavs: int
    num_slots: int
    slot_duration_s: float
    z_min: float
    z_max: float
    h_amb_min: float
    h_amb_ratio: float  # C8 ladder: slave k's limit is h_amb_min h_amb_ratio^(k-1) (model)
    x_t: float
    ground_station: tuple[float, float, float]
    d_min: float
    swath_min: float
    speed: float
    p_max_w: float
    e_max_j: float
    rate_min_bps: tuple[float, ...]  # one per UAV (num_uavs): what a flight must deliver
    rate_margin: float  # C10 as planned: schemes.planned_rate_bps
    comm_bandwidth_hz: float
    beta_c: float
    coherence_rg_min: float
    coherence_snr_min: float
    coherence_other: float
    sigma0: float
    radar_power_w: float
    gain_tx: float
    gain_rx: float
    wavelength: float
    duty_cycle: float
    theta0: float
    system_temperature_k: float
    radar_bandwidth_hz: float
    noise_figure: float
    losses: float
    center_frequency_hz: float
    beamwidth: float
    theta_min: float
    theta_max: float
    looks: int
    tolerance: float
    master_fixed: tuple[float, float]
    nav_error_m: float  # e: each UAV anywhere within e of its planned point (solver/robust.py)
    time_budget_s: float  # the global search's budget; 0: none (optimum.solve_global)
    tomo_height_span_m: float  # S: the tomographic figures' sidelobe span (tomography/)
    tomo_resolution_m: float  # the tomography objective's resolution and ambiguity
    tomo_ambiguity_min_m: float
    scheme: str
    objective: str
    solver: str
    #: Per-UAV budgets [J] in place of E_com^max in C11, for a re-plan in mid-mission
    #: (replanning/plans.py); None: e_max_j for every UAV. Not a user parameter: `replace` drops it.
    energy_budget_uav_j: tuple[float, ...] | None = None  # one per UAV (num_uavs)

    def energy_budget_j(self, k: int) -> float:
        """E_com^max of UAV k in C11: e_max_j, unless a re-plan gave each UAV its own."""
        return self.e_max_j if self.energy_budget_uav_j is None else self.energy_budget_uav_j[k]

    def replace(self, **user_values: Any) -> Params:
        """A copy with some user-facing (file-unit) parameters changed: those validated and
        converted, and every cross-field rule checked again (the others are this one's, valid
        and converted already: a sweep or a map makes thousands of copies)."""
        merged = dict(self.raw)
        merged.update(user_values)
        return params_from_mapping(merged, known=self, changed=frozenset(user_values))

    @property
    def fractional_bandwidth(self) -> float:
        """B_p = B_Rg / f_0, the radar's fractional bandwidth in gamma_Rg (eq. 10)."""
        return fractional_bandwidth(self.radar_bandwidth_hz, self.center_frequency_hz)

    @property
    def y_track(self):
        """y[n] = (n - 1) v_y delta_t for n = 1..N (equation (1)), as a numpy array."""
        import numpy as np

        return np.arange(self.num_slots) * self.speed * self.slot_duration_s


VALUE_SHOWN_CHARS = 60
# C1 and C5 must keep the master this far from the target: with neither, sigma_h keeps
# falling as the whole formation shrinks onto the target (the SNR grows as 1/r^3).
MASTER_RANGE_MIN_M = 0.1
# B_Rg / f_0 below this: gamma_Rg (eq. 10) falls below any allowed gamma_Rg^min within
# microradians of theta_0, so C7 leaves no baseline worth flying.
FRACTIONAL_BANDWIDTH_MIN = 1e-4


def _cut(text: str) -> str:
    return text if len(text) <= VALUE_SHOWN_CHARS else text[:VALUE_SHOWN_CHARS - 3] + "..."


def shown(value: Any) -> str:
    """repr(value) for an error line, cut to VALUE_SHOWN_CHARS. Never renders more than that
    of a long str or bytes value, and an int beyond Python's str limit is described."""
    if isinstance(value, (str, bytes)) and len(value) > VALUE_SHOWN_CHARS:
        value = value[:VALUE_SHOWN_CHARS]
    try:
        return _cut(repr(list(value) if isinstance(value, tuple) else value))
    except ValueError:  # int with more digits than sys.get_int_max_str_digits()
        return f"<integer of about {int(value.bit_length() * 0.30103)} digits>"


def check_value(spec: ParamSpec, value: Any) -> tuple[Any, str | None]:
    """Coerce one value to the spec's type (int, float, str, or a list of `length` floats);
    return (value, problem or None), the problem one line naming the value and what is
    allowed. The one value check of every node and the CLI."""
    bad = (f"{spec.name}: value {shown(value)} is not allowed; expected {spec.allowed()}"
           + (f" ({spec.why})" if spec.why else ""))
    if spec.kind is str:
        if not isinstance(value, str) or (spec.choices and value not in spec.choices):
            return value, bad
        return value, None
    if spec.length or spec.per_uav:
        lengths = range(MIN_UAVS, MAX_UAVS + 1) if spec.per_uav else (spec.length,)
        if not isinstance(value, (list, tuple)) or len(value) not in lengths:
            return value, bad
        items = []
        for item in value:
            item = _as_float(item)
            if item is None or not math.isfinite(item) or not _in_range(spec, item):
                return value, bad
            items.append(item)
        return tuple(items), None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return value, bad
    if spec.kind is int:
        if isinstance(value, float) and not value.is_integer():
            return value, bad
        value = int(value)
        return value, (None if _in_range(spec, value) else bad)
    number = _as_float(value)
    if number is None or not math.isfinite(number) or not _in_range(spec, number):
        return value, bad
    return number, None


def _as_float(value: Any) -> float | None:
    """`value` as a float, None when it is no number (bool included) or an int beyond it."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        return float(value)
    except OverflowError:  # an integer above 1.8e308
        return None


def _in_range(spec: ParamSpec, v: float) -> bool:
    if spec.lo is not None and (v <= spec.lo if spec.lo_open else v < spec.lo):
        return False
    return not (spec.hi is not None and (v >= spec.hi if spec.hi_open else v > spec.hi))


def unknown_parameter(name: str) -> str:
    """The one line for a parameter name that no node of the suite takes, as the command line
    and every node say it, with the closest name of any node when one is close."""
    near = difflib.get_close_matches(name[:VALUE_SHOWN_CHARS], sorted(SUITE_PARAMETER_NAMES),
                                     n=1)
    hint = f" (did you mean {near[0]}?)" if near else ""
    label = _cut(name) if name.isidentifier() else shown(name)  # one line, always
    nodes = list(NODE_SPECS)
    return (f"{label}: unknown parameter{hint}; expected a parameter of "
            f"{', '.join(nodes[:-1])} or {nodes[-1]} (the documentation's parameter reference)")


def validate(values: Mapping[str, Any],
             trusted: Container[str] = ()) -> tuple[dict[str, Any], list[str]]:
    """Check every value against PARAM_SPECS and the cross-field rules; collect all problems.
    `trusted`: names whose values are check_value's output already (taken as they are)."""
    problems: list[str] = []
    clean: dict[str, Any] = {}
    for name in values:
        if not isinstance(name, str):
            problems.append(f"parameter name {shown(name)} is not allowed; expected a name "
                            "from config/params.yaml")
        elif name in SUITE_PARAMETER_NAMES and name not in SPEC_BY_NAME:
            problems.append(f"{name}: a parameter of {', '.join(nodes_taking(name))}, not "
                            "of the scenario; expected a name in config/params.yaml")
        elif name not in SPEC_BY_NAME:
            problems.append(unknown_parameter(name))
    bad: set[str] = set()
    for spec in PARAM_SPECS:
        if spec.name in trusted:
            clean[spec.name] = values[spec.name]
            continue
        value, problem = check_value(spec, values.get(spec.name, spec.default))
        clean[spec.name] = value
        if problem:
            problems.append(problem)
            bad.add(spec.name)
    if bad & {"z_min_m", "z_max_m", "slave_look_angle_min_deg", "slave_look_angle_max_deg",
              "radar_bandwidth_hz", "center_frequency_hz"}:
        return clean, problems
    problems += per_uav_problems(clean, bad)
    if clean["z_min_m"] >= clean["z_max_m"]:
        problems.append(f"z_min_m: value {clean['z_min_m']!r} is not allowed; expected less "
                        f"than z_max_m ({clean['z_max_m']!r})")
    if clean["slave_look_angle_min_deg"] >= clean["slave_look_angle_max_deg"]:
        problems.append(
            f"slave_look_angle_min_deg: value {clean['slave_look_angle_min_deg']!r} is not "
            f"allowed; expected less than slave_look_angle_max_deg "
            f"({clean['slave_look_angle_max_deg']!r})")
    problems += objective_problems(clean["objective"], clean["solver"])
    problems += nav_error_problems(clean["nav_error_m"], clean["solver"])
    if not bad & {"swath_min_m", "look_angle_deg", "beamwidth_deg"}:
        c0 = math.cos(math.radians(clean["look_angle_deg"]))
        least = max(clean["z_min_m"] / c0 if c0 > 0 else math.inf,
                    clean["swath_min_m"] * c0 / math.radians(clean["beamwidth_deg"]))
        if least < MASTER_RANGE_MIN_M:
            problems.append(
                f"z_min_m: value {clean['z_min_m']!r} is not allowed with swath_min_m "
                f"{clean['swath_min_m']!r}; expected the master's least slant range "
                f"max(z_min/cos theta_0, S_min cos theta_0/Theta_3dB) >= {MASTER_RANGE_MIN_M:g}"
                f" m, not {least:.3g} m (nearer, the optimum moves onto the target, r_0 -> 0,"
                " where eqs. 8-9's SNR diverges and no formation attains it)")
    fractional = fractional_bandwidth(clean["radar_bandwidth_hz"], clean["center_frequency_hz"])
    if not FRACTIONAL_BANDWIDTH_MIN <= fractional < 2.0:
        problems.append(
            f"radar_bandwidth_hz: value {clean['radar_bandwidth_hz']!r} is not allowed; "
            f"expected a fractional bandwidth B_Rg/f_0 in [{FRACTIONAL_BANDWIDTH_MIN:g}, 2) "
            "(narrower, C7's gamma_Rg >= gamma_Rg^min leaves no baseline)")
    return clean, problems


def per_uav_problems(clean: Mapping[str, Any], bad: set[str]) -> list[str]:
    """Every per-UAV list holds num_uavs values, one per UAV (U0 first)."""
    if "num_uavs" in bad:
        return []
    n = clean["num_uavs"]
    return [f"{spec.name}: value {shown(clean[spec.name])} is not allowed with num_uavs {n}; "
            f"expected a list of {n} numbers, one per UAV (U0..U{n - 1})"
            for spec in PARAM_SPECS
            if spec.per_uav and spec.name not in bad and len(clean[spec.name]) != n]


def objective_problems(objective: Any, solver: Any) -> list[str]:
    """The objective's cross-field rule: each back end takes the objectives its declaration
    (`BACKENDS`) names; e.g. `multilook` runs on the global solver only."""
    backend = BACKEND_BY_NAME.get(solver) if isinstance(solver, str) else None
    if backend is None or objective not in OBJECTIVES or objective in backend.objectives:
        return []
    others = [b.name for b in BACKENDS if objective in b.objectives]
    return [f"objective: value {objective!r} is not allowed with solver {solver!r}; expected "
            f"{' or '.join(backend.objectives)} ({backend.why}), or solver "
            + " or ".join(others)]


def nav_error_problems(nav_error: Any, solver: Any) -> list[str]:
    """nav_error_m > 0 runs on the back ends that plan for it; the others' declaration
    (`Backend.nominal_only`) says why they refuse it."""
    backend = BACKEND_BY_NAME.get(solver) if isinstance(solver, str) else None
    if backend is None or not backend.nominal_only or not isinstance(nav_error, float) \
            or nav_error == 0.0:
        return []
    others = [b.name for b in BACKENDS if not b.nominal_only]
    return [f"nav_error_m: value {shown(nav_error)} is not allowed with solver {solver!r}; "
            f"expected 0 ({backend.nominal_only}), or solver " + " or ".join(others)]


def params_from_mapping(values: Mapping[str, Any], known: Params | None = None,
                        changed: frozenset[str] = frozenset()) -> Params:
    """Validate user-facing values (file units) and convert them to SI. Raises ParamError.
    known: a Params whose values `values` keeps for every name not in `changed` (Params.replace),
    taken from it without a second check or conversion."""
    same = frozenset() if known is None else frozenset(known.raw) - changed
    v, problems = validate(values, same)
    if problems:
        raise ParamError(problems)
    return Params(raw=dict(v), **{
        spec.attribute: getattr(known, spec.attribute) if spec.name in same
        else spec.si_value(v[spec.name]) for spec in PARAM_SPECS})


def default_params(paper: bool = False) -> Params:
    """Table I defaults, straight from PARAM_SPECS (no file needed): the field problem, or with
    `paper` the paper's problem (P), every field-only default at its paper value
    (PAPER_VALUES: rate_margin 0)."""
    return params_from_mapping(dict(PAPER_VALUES) if paper else {})
