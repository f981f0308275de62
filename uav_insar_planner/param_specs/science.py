"""The scenario's parameters (`PARAM_SPECS`, Table I): name, type, default, allowed range with
the reason it stops there, unit, description, and the SI value's name in `Params` with the
conversion to it. `params` validates values against the table and builds `Params` from it; the
planner node declares its ROS parameters from it. The scenario's dB, dBm, degrees and Mbit/s
become SI here, once: each spec names its conversion (`to_si`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from uav_insar_planner.param_specs import ParamSpec
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, MIN_UAVS

SCHEMES = ("proposed", "single-baseline", "fixed-master", "static-power")
OBJECTIVES = ("exact", "bound", "multilook", "tomography")
# n_L stops at 1000 looks, beyond any UAV SAR product: the multilook objective tabulates the
# exact phase std per n_L (multilook.py, O(n_L): 4.4 s at 1000) and a Monte-Carlo pixel draws
# 4 n_L normals (montecarlo.py; cli/montecarlo.py bounds samples x looks per pair).
MULTILOOK_MAX_LOOKS = 1000
_LOOKS_WHY = "beyond any UAV SAR product; the multilook objective and the Monte-Carlo cost O(n_L)"


@dataclass(frozen=True)
class Backend:
    """One solver back end, declared once: the `solver` parameter's choices, the dispatcher
    (`solver.solve`), the objective rule (`params.objective_problems`) and the documentation's
    table of back ends all read `BACKENDS`. `entry` is "module:function" of its
    solve(params, scheme, objective) -> SolverResult, imported on first use (a lean install
    lacks scipy and CVXPY); `why` says why the other objectives are not offered;
    `nominal_only`, when set, is why it refuses nav_error_m > 0 (it plans nominal positions
    only; solver/robust.py serves the back ends that take it); `warm_start`, when set, is
    "module:Class" of the state its solve function takes as keyword `warm_start` along a
    sweep (a fresh instance per sequence of solves)."""

    name: str
    entry: str
    objectives: tuple[str, ...]
    certified: bool
    summary: str
    why: str = ""
    nominal_only: str = ""
    warm_start: str = ""


BACKENDS = (
    Backend("global", "uav_insar_planner.solver.global_opt.optimum:solve_global",
            ("exact", "bound", "multilook"), True, "certified",
            "tomography is the evolution back end's (its relaxation carries the bound)",
            warm_start="uav_insar_planner.solver.global_opt.warm:WarmStart"),
    Backend("paper-ao", "uav_insar_planner.solver.ao.algorithm2:solve_ao", ("exact", "bound"),
            False, "Algorithm 2", "paper-ao minimises Proposition 1's bound",
            "paper-ao's convex sub-problems have no robust counterpart of the worst case"),
    Backend("evolution", "uav_insar_planner.solver.evolution.algorithm:solve_evolution",
            ("exact", "bound", "tomography"), False, "differential evolution, no certificate",
            "its baseline searches the Cramer-Rao objectives and the tomographic one",
            "its baseline has no certificate, so no certified worst case"),
)
SOLVERS = tuple(b.name for b in BACKENDS)
BACKEND_BY_NAME = {b.name: b for b in BACKENDS}


# A spec's `to_si`: from the unit of its name to SI.
def db_to_linear(db: float) -> float:
    return 10.0 ** (db / 10.0)


def dbm_to_watt(dbm: float) -> float:
    return 10.0 ** ((dbm - 30.0) / 10.0)


def mbps_to_bps(mbps: float) -> float:
    return mbps * 1e6


def _f(name, default, desc, lo=None, hi=None, lo_open=False, length=0, hi_open=False, why="",
       per_uav=False, si_name="", to_si=None, paper=None):
    """A float parameter; `why` (the reason for its range) is also appended to `desc`."""
    return ParamSpec(name, float, default, f"{desc}; {why}" if why else desc, lo, hi, lo_open,
                     length, hi_open=hi_open, why=why, per_uav=per_uav, si_name=si_name,
                     to_si=to_si, paper=paper)


# Lengths stop at 1000 km: beyond any UAV's reach, and their squares and the radar
# equation's r^3 stay far inside double precision.
LENGTH_MAX_M = 1.0e6
_LENGTH_WHY = "1000 km at most, beyond any UAV's reach"


PARAM_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("num_uavs", int, DEFAULT_NUM_UAVS, "N_UAV, UAVs in the swarm: the master U0 and "
              "N_UAV - 1 slaves, one interferogram each; every per-UAV list has this length",
              MIN_UAVS, MAX_UAVS, why=f"{MIN_UAVS} is the single baseline; the certified solver "
              f"is measured up to {MAX_UAVS}"),
    ParamSpec("num_slots", int, 80, "N, number of time slots", 1, 100000),
    _f("slot_duration_s", 1.0, "delta_t, slot duration [s]", 0.0, 3600.0, True,
       why="at most an hour"),
    _f("z_min_m", 1.0, "z_min, lowest flying altitude [m] (C1)", 0.0, LENGTH_MAX_M,
       why=_LENGTH_WHY, si_name="z_min"),
    _f("z_max_m", 100.0, "z_max, highest flying altitude [m] (C1)", 0.0, LENGTH_MAX_M, True,
       why=_LENGTH_WHY, si_name="z_max"),
    _f("h_amb_min_m", 1.2, "h_amb^min, minimum height of ambiguity [m] (C8)", 1e-3,
       LENGTH_MAX_M, why="1 mm to 1000 km", si_name="h_amb_min"),
    _f("h_amb_ratio", 1.0, "rho, ratio between successive slaves' minimum heights of ambiguity, "
       "h_amb,k >= h_amb_min_m rho^(k-1) for slave k (C8); 1 is the paper's common limit. Diverse "
       "h_amb,k let the pairs resolve each other's phase ambiguities (measured: 4 slaves at "
       "1.25 more than halve the resolved DEM error for a 30 % larger sigma_h)", 1.0, 10.0,
       why="at 10 the fifth slave's limit is 1e4 h_amb_min, beyond any useful baseline"),
    _f("target_x_m", 20.0, "x_t, across-track position of the target line [m]",
       -LENGTH_MAX_M, LENGTH_MAX_M, why=_LENGTH_WHY, si_name="x_t"),
    _f("ground_station_m", [70.0, 149.37, 25.0], "g = (g_x, g_y, g_z), ground station [m]",
       -LENGTH_MAX_M, LENGTH_MAX_M, length=3, why=_LENGTH_WHY, si_name="ground_station"),
    _f("d_min_m", 1.5, "d_min, minimum distance between UAVs [m] (C4)", 0.0, LENGTH_MAX_M,
       why=_LENGTH_WHY, si_name="d_min"),
    _f("swath_min_m", 55.0, "S_min, minimum swath width [m] (C5)", 0.0, LENGTH_MAX_M,
       why=_LENGTH_WHY, si_name="swath_min"),
    _f("speed_mps", 4.3, "v_y, along-track speed [m/s]", 0.01, 1000.0,
       why="1 cm/s to 1 km/s; gamma_m grows as 1/v_y", si_name="speed"),
    _f("p_com_max_db", 10.1, "P_com^max, peak communication power [dBW] (C9)", -100.0, 60.0,
       si_name="p_max_w", to_si=db_to_linear),
    _f("e_com_max_j", 594.0, "E_com^max, communication energy budget per UAV [J] (C11)",
       0.0, None, True, si_name="e_max_j"),
    _f("rate_min_mbps", [10.0, 16.95, 1.0], "R_min,k, minimum data rate of each UAV, U0 first "
       "[Mbit/s] (C10)", 0.0, None, per_uav=True, si_name="rate_min_bps", to_si=mbps_to_bps),
    _f("rate_margin", 0.05, "mu, rate margin: plans size P_com so that R_k[n] >= (1 + mu) "
       "R_min,k (C10 as planned), so a UAV a few metres off its planned point, or a link a "
       "little weaker, still offloads R_min,k; 0 is the paper's C10. Costs power and energy, "
       "and sigma_h only where C9 or C11 then limit the formation", 0.0, 1.0,
       why="at 1 the plan doubles every rate", paper=0.0),
    _f("comm_bandwidth_hz", 1.0e9, "B_c, FDMA bandwidth per UAV [Hz]", 0.0, None, True),
    _f("ref_snr_db", 18.69, "beta_c, channel gain at 1 m over noise power [dB]", -200.0, 200.0,
       si_name="beta_c", to_si=db_to_linear),
    _f("coherence_rg_min", 0.8, "gamma_Rg^min, minimum baseline coherence (C7)", 0.01, 1.0,
       hi_open=True, why="gamma_Rg = 1 only where b_perp = 0 (sigma_h infinite); below "
       "0.01 eq. 14's phase error is above 35 rad"),
    _f("coherence_snr_min", 0.8, "gamma_SNR^min, minimum SNR coherence (C6)", 0.01, 1.0,
       hi_open=True, why="gamma_SNR = 1 needs an infinite SNR; below 0.01 eq. 14's phase "
       "error is above 35 rad"),
    _f("coherence_other", 0.6, "gamma_other, other decorrelation sources", 0.01, 1.0,
       why="below 0.01 eq. 14's phase error is above 35 rad"),
    _f("sigma0_db", -10.0, "sigma_0, normalised backscatter [dB]", -100.0, 50.0,
       si_name="sigma0", to_si=db_to_linear),
    _f("radar_power_dbm", 26.02, "P_t, radar transmit power [dBm]", -100.0, 100.0,
       si_name="radar_power_w", to_si=dbm_to_watt),
    _f("gain_tx_dbi", 5.0, "G_t, radar transmit antenna gain [dBi]", -50.0, 80.0,
       si_name="gain_tx", to_si=db_to_linear),
    _f("gain_rx_dbi", 5.0, "G_r, radar receive antenna gain [dBi]", -50.0, 80.0,
       si_name="gain_rx", to_si=db_to_linear),
    _f("wavelength_m", 0.12, "lambda, radar wavelength [m]", 1e-3, 10.0,
       why="1 mm (mm-wave) to 10 m (VHF)", si_name="wavelength"),
    _f("duty_cycle", 1.0e-4, "tau_p x PRF, radar duty cycle", 0.0, 1.0, True),
    _f("look_angle_deg", 45.0, "theta_0, master look angle from vertical [deg] (C2)",
       0.0, 90.0, True, si_name="theta0", to_si=math.radians),
    _f("system_temperature_k", 400.0, "T_sys, receiver temperature [K]", 1.0, 1e5,
       why="no receiver is below 1 K or above 1e5 K"),
    _f("radar_bandwidth_hz", 3.0e9, "B_Rg, radar pulse bandwidth [Hz]", 0.0, None, True),
    _f("noise_figure_db", 5.0, "F, receiver noise figure [dB]", 0.0, 100.0,
       si_name="noise_figure", to_si=db_to_linear),
    _f("losses_db", 6.0, "L, total radar losses [dB]", 0.0, 100.0,
       si_name="losses", to_si=db_to_linear),
    _f("center_frequency_hz", 2.5e9, "f_0, radar centre frequency [Hz]", 1e6, 1e12,
       why="radar bands from 1 MHz to 1 THz"),
    _f("beamwidth_deg", 33.44, "Theta_3dB, elevation beamwidth [deg] (C5)", 0.0, 180.0, True,
       si_name="beamwidth", to_si=math.radians),
    _f("slave_look_angle_min_deg", 37.24, "theta_min, slave look angle lower limit [deg] (C3)",
       0.0, 90.0, si_name="theta_min", to_si=math.radians),
    _f("slave_look_angle_max_deg", 48.7, "theta_max, slave look angle upper limit [deg] (C3)",
       0.0, 90.0, si_name="theta_max", to_si=math.radians),
    ParamSpec("looks", int, 4, f"n_L, number of independent looks; {_LOOKS_WHY}", 1,
              MULTILOOK_MAX_LOOKS, why=_LOOKS_WHY),
    _f("tolerance", 1.0e-2, "eps_0 = eps_1 = eps_2, AO/SCA relative stopping tolerance",
       0.0, 1.0, True),
    _f("master_fixed_xz_m", [-54.0, 74.0], "q0_fixed = (x_0, z_0) for the fixed-master scheme "
       "[m]", -LENGTH_MAX_M, LENGTH_MAX_M, length=2, why=_LENGTH_WHY, si_name="master_fixed"),
    _f("nav_error_m", 0.0, "e, navigation error [m]: each UAV may fly anywhere within e of its "
       "planned point in the across-track (x, z) plane; the plan keeps C1 and C3-C11 at every "
       "such position with its own power schedule and minimises the worst-case sigma_h "
       "(solver/robust.py); 0 plans the nominal points (the paper's)", 0.0, 100.0,
       why="100 m at most, far beyond any GNSS error a formation flies with"),
    _f("time_budget_s", 0.0, "seconds the global solver's search may take: past them it "
       "returns the best feasible plan found with its proven gap and says the certificate is "
       "incomplete; 0: no limit but the search's node limit", 0.0, 3600.0,
       why="an hour at most: a plan is wanted before the flight"),
    # tomography/: the array's figures of every plan and the tomographic objective
    _f("tomo_height_span_m", 2.5, "S, height span of the tomographic figures [m]: the array "
       "factor's sidelobes (PSLR, ISLR) are measured over |h| <= S, past the main lobe",
       0.0, 1.0e4, True, why="10 km at most, beyond any scene's heights"),
    _f("tomo_resolution_m", 1.0, "rho_req, Rayleigh elevation resolution the tomography "
       "objective holds (lambda r_0 sin(theta_0) / span of b_perp) [m]", 0.0, 1.0e4, True,
       why="10 km at most, beyond any scene's heights"),
    _f("tomo_ambiguity_min_m", 2.5, "H_req, least nearest elevation ambiguity the tomography "
       "objective allows (first h beyond the main lobe with AF >= 0.9) [m]; it takes the "
       "place of C8's per-pair h_amb limit", 0.0, 1.0e4,
       why="10 km at most, beyond any scene's heights"),
    ParamSpec("scheme", str, "proposed", "which scheme to solve", choices=SCHEMES),
    ParamSpec("objective", str, "exact", "exact: minimise sigma_h; bound: Proposition 1; "
              "multilook: sigma_h with the exact multilook phase std; tomography: minimise "
              "the elevation array factor's ISLR at tomo_resolution_m (solver evolution)",
              choices=OBJECTIVES),
    ParamSpec("solver", str, "global", ", ".join(f"{b.name} ({b.summary})" for b in BACKENDS[:-1])
              + f" or {BACKENDS[-1].name} ({BACKENDS[-1].summary})", choices=SOLVERS),
)
SPEC_BY_NAME: dict[str, ParamSpec] = {s.name: s for s in PARAM_SPECS}
#: The paper's problem (P) at Table I: the value of each parameter whose default is field-only
#: (`ParamSpec.paper`). `--paper` and `load_params(paper=True)` apply these over a params file;
#: an explicit override (`--set`) still wins.
PAPER_VALUES: dict[str, Any] = {s.name: s.paper for s in PARAM_SPECS if s.paper is not None}
