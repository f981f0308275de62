"""The table of every scenario parameter (`PARAM_SPECS`): name, type, default (Table I),
allowed range with the reason it stops there, unit and description. `params` validates values
against it and converts them to SI; the planner node declares its ROS parameters from it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from uav_insar_planner.swarm import NUM_UAVS

SCHEMES = ("proposed", "single-baseline", "fixed-master", "static-power")
OBJECTIVES = ("exact", "bound", "multilook")
# The multilook objective tabulates the exact phase std per n_L (multilook.py): O(n_L) work.
MULTILOOK_MAX_LOOKS = 1000
SOLVERS = ("global", "paper-ao")


@dataclass(frozen=True)
class ParamSpec:
    """One user-facing parameter. `length` > 0 means a list of that many numbers."""

    name: str
    kind: type  # int, float or str
    default: Any
    description: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    length: int = 0
    choices: tuple[str, ...] = ()
    hi_open: bool = False
    why: str = ""  # why the range stops where it does (shown with a value outside it)

    def allowed(self) -> str:
        if self.choices:
            return "one of " + ", ".join(self.choices)
        what = {int: "an integer", float: "a finite number", str: "a string"}[self.kind]
        if self.length:
            what = f"a list of {self.length} finite numbers"
        if self.lo is not None and self.hi is not None:
            rng = (f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}"
                   f"{')' if self.hi_open else ']'}")
            return f"{what} in {rng}"
        if self.lo is not None:
            return f"{what} {'>' if self.lo_open else '>='} {self.lo:g}"
        return what


def _f(name, default, desc, lo=None, hi=None, lo_open=False, length=0, hi_open=False, why=""):
    """A float parameter; `why` (the reason for its range) is also appended to `desc`."""
    return ParamSpec(name, float, default, f"{desc}; {why}" if why else desc, lo, hi, lo_open,
                     length, hi_open=hi_open, why=why)


# Lengths stop at 1000 km: beyond any UAV's reach, and their squares and the radar
# equation's r^3 stay far inside double precision.
LENGTH_MAX_M = 1.0e6
_LENGTH_WHY = "1000 km at most, beyond any UAV's reach"


PARAM_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("num_slots", int, 80, "N, number of time slots", 1, 100000),
    _f("slot_duration_s", 1.0, "delta_t, slot duration [s]", 0.0, 3600.0, True,
       why="at most an hour"),
    _f("z_min_m", 1.0, "z_min, lowest flying altitude [m] (C1)", 0.0, LENGTH_MAX_M,
       why=_LENGTH_WHY),
    _f("z_max_m", 100.0, "z_max, highest flying altitude [m] (C1)", 0.0, LENGTH_MAX_M, True,
       why=_LENGTH_WHY),
    _f("h_amb_min_m", 1.2, "h_amb^min, minimum height of ambiguity [m] (C8)", 1e-3,
       LENGTH_MAX_M, why="1 mm to 1000 km"),
    _f("target_x_m", 20.0, "x_t, across-track position of the target line [m]",
       -LENGTH_MAX_M, LENGTH_MAX_M, why=_LENGTH_WHY),
    _f("ground_station_m", [70.0, 149.37, 25.0], "g = (g_x, g_y, g_z), ground station [m]",
       -LENGTH_MAX_M, LENGTH_MAX_M, length=3, why=_LENGTH_WHY),
    _f("d_min_m", 1.5, "d_min, minimum distance between UAVs [m] (C4)", 0.0, LENGTH_MAX_M,
       why=_LENGTH_WHY),
    _f("swath_min_m", 55.0, "S_min, minimum swath width [m] (C5)", 0.0, LENGTH_MAX_M,
       why=_LENGTH_WHY),
    _f("speed_mps", 4.3, "v_y, along-track speed [m/s]", 0.01, 1000.0,
       why="1 cm/s to 1 km/s; gamma_m grows as 1/v_y"),
    _f("p_com_max_db", 10.1, "P_com^max, peak communication power [dBW] (C9)", -100.0, 60.0),
    _f("e_com_max_j", 594.0, "E_com^max, communication energy budget per UAV [J] (C11)",
       0.0, None, True),
    _f("rate_min_mbps", [10.0, 16.95, 1.0], "R_min,k, minimum data rate of U0, U1, U2 "
       "[Mbit/s] (C10)", 0.0, None, length=NUM_UAVS),
    _f("comm_bandwidth_hz", 1.0e9, "B_c, FDMA bandwidth per UAV [Hz]", 0.0, None, True),
    _f("ref_snr_db", 18.69, "beta_c, channel gain at 1 m over noise power [dB]", -200.0, 200.0),
    _f("coherence_rg_min", 0.8, "gamma_Rg^min, minimum baseline coherence (C7)", 0.01, 1.0,
       hi_open=True, why="gamma_Rg = 1 only where b_perp = 0 (sigma_h infinite); below "
       "0.01 eq. 14's phase error is above 35 rad"),
    _f("coherence_snr_min", 0.8, "gamma_SNR^min, minimum SNR coherence (C6)", 0.01, 1.0,
       hi_open=True, why="gamma_SNR = 1 needs an infinite SNR; below 0.01 eq. 14's phase "
       "error is above 35 rad"),
    _f("coherence_other", 0.6, "gamma_other, other decorrelation sources", 0.01, 1.0,
       why="below 0.01 eq. 14's phase error is above 35 rad"),
    _f("sigma0_db", -10.0, "sigma_0, normalised backscatter [dB]", -100.0, 50.0),
    _f("radar_power_dbm", 26.02, "P_t, radar transmit power [dBm]", -100.0, 100.0),
    _f("gain_tx_dbi", 5.0, "G_t, radar transmit antenna gain [dBi]", -50.0, 80.0),
    _f("gain_rx_dbi", 5.0, "G_r, radar receive antenna gain [dBi]", -50.0, 80.0),
    _f("wavelength_m", 0.12, "lambda, radar wavelength [m]", 1e-3, 10.0,
       why="1 mm (mm-wave) to 10 m (VHF)"),
    _f("duty_cycle", 1.0e-4, "tau_p x PRF, radar duty cycle", 0.0, 1.0, True),
    _f("look_angle_deg", 45.0, "theta_0, master look angle from vertical [deg] (C2)",
       0.0, 90.0, True),
    _f("system_temperature_k", 400.0, "T_sys, receiver temperature [K]", 1.0, 1e5,
       why="no receiver is below 1 K or above 1e5 K"),
    _f("radar_bandwidth_hz", 3.0e9, "B_Rg, radar pulse bandwidth [Hz]", 0.0, None, True),
    _f("noise_figure_db", 5.0, "F, receiver noise figure [dB]", 0.0, 100.0),
    _f("losses_db", 6.0, "L, total radar losses [dB]", 0.0, 100.0),
    _f("center_frequency_hz", 2.5e9, "f_0, radar centre frequency [Hz]", 1e6, 1e12,
       why="radar bands from 1 MHz to 1 THz"),
    _f("beamwidth_deg", 33.44, "Theta_3dB, elevation beamwidth [deg] (C5)", 0.0, 180.0, True),
    _f("slave_look_angle_min_deg", 37.24, "theta_min, slave look angle lower limit [deg] (C3)",
       0.0, 90.0),
    _f("slave_look_angle_max_deg", 48.7, "theta_max, slave look angle upper limit [deg] (C3)",
       0.0, 90.0),
    ParamSpec("looks", int, 4, "n_L, number of independent looks", 1, 1_000_000),
    _f("tolerance", 1.0e-2, "eps_0 = eps_1 = eps_2, AO/SCA relative stopping tolerance",
       0.0, 1.0, True),
    _f("master_fixed_xz_m", [-54.0, 74.0], "q0_fixed = (x_0, z_0) for the fixed-master scheme "
       "[m]", -LENGTH_MAX_M, LENGTH_MAX_M, length=2, why=_LENGTH_WHY),
    ParamSpec("scheme", str, "proposed", "which scheme to solve", choices=SCHEMES),
    ParamSpec("objective", str, "exact", "exact: minimise sigma_h; bound: Proposition 1; "
              "multilook: sigma_h with the exact multilook phase std", choices=OBJECTIVES),
    ParamSpec("solver", str, "global", "global (certified) or paper-ao (Algorithm 2)",
              choices=SOLVERS),
)
SPEC_BY_NAME: dict[str, ParamSpec] = {s.name: s for s in PARAM_SPECS}
