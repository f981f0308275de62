"""The table of every scenario parameter (`PARAM_SPECS`): name, type, default (Table I),
allowed range with the reason it stops there, unit and description. `params` validates values
against it and converts them to SI; the planner node declares its ROS parameters from it.

Beside it, as plain data, the tables of every node's own parameters (PLANNER_SPECS,
AGENT_SPECS, MAVLINK_SPECS, BRIDGE_SPECS) and which node takes which (`NODE_SPECS`,
`nodes_taking`): `ros/parameters.py` and `mavlink/config.py` declare and check them, and the
command line and the demo know from here, without ROS, every name a params file may hold.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from uav_insar_planner.autopilots.profiles import AUTOPILOTS
from uav_insar_planner.plan import SAFE_SEPARATION_M
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, MIN_UAVS, uavs

SCHEMES = ("proposed", "single-baseline", "fixed-master", "static-power")
OBJECTIVES = ("exact", "bound", "multilook")
# n_L stops at 1000 looks, beyond any UAV SAR product: the multilook objective tabulates the
# exact phase std per n_L (multilook.py, O(n_L): 4.4 s at 1000) and a Monte-Carlo pixel draws
# 4 n_L normals (montecarlo.py; cli/montecarlo.py bounds samples x looks per pair).
MULTILOOK_MAX_LOOKS = 1000
_LOOKS_WHY = "beyond any UAV SAR product; the multilook objective and the Monte-Carlo cost O(n_L)"
SOLVERS = ("global", "paper-ao", "evolution")


@dataclass(frozen=True)
class ParamSpec:
    """One user-facing parameter. `length` > 0 means a list of that many numbers; `per_uav` a
    list of one number per UAV (num_uavs of them, checked against num_uavs by `params`)."""

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
    per_uav: bool = False

    def allowed(self) -> str:
        """What the parameter allows, in words (node descriptors, errors, the docs)."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        if self.kind is bool:
            return "true or false"
        if self.kind is list:
            return "a non-empty list of " + ("strings" if isinstance(self.default[0], str)
                                             else "integers")
        what = {int: "an integer", float: "a finite number", str: "a string"}[self.kind]
        if self.length:
            what = f"a list of {self.length} finite numbers"
        if self.per_uav:
            what = "a list of num_uavs finite numbers (one per UAV, U0 first)"
        # %g would write an integer bound such as 2**31 - 1 as 2.14748e+09
        num = (lambda v: str(int(v))) if self.kind is int else (lambda v: f"{v:g}")
        if self.lo is not None and self.hi is not None:
            rng = (f"{'(' if self.lo_open else '['}{num(self.lo)}, {num(self.hi)}"
                   f"{')' if self.hi_open else ']'}")
            return f"{what} in {rng}"
        if self.lo is not None:
            return f"{what} {'>' if self.lo_open else '>='} {num(self.lo)}"
        return what


def _f(name, default, desc, lo=None, hi=None, lo_open=False, length=0, hi_open=False, why="",
       per_uav=False):
    """A float parameter; `why` (the reason for its range) is also appended to `desc`."""
    return ParamSpec(name, float, default, f"{desc}; {why}" if why else desc, lo, hi, lo_open,
                     length, hi_open=hi_open, why=why, per_uav=per_uav)


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
       why=_LENGTH_WHY),
    _f("z_max_m", 100.0, "z_max, highest flying altitude [m] (C1)", 0.0, LENGTH_MAX_M, True,
       why=_LENGTH_WHY),
    _f("h_amb_min_m", 1.2, "h_amb^min, minimum height of ambiguity [m] (C8)", 1e-3,
       LENGTH_MAX_M, why="1 mm to 1000 km"),
    _f("h_amb_ratio", 1.0, "rho, ratio between successive slaves' minimum heights of ambiguity, "
       "h_amb,k >= h_amb_min_m rho^(k-1) for slave k (C8); 1 is the paper's common limit. Diverse "
       "h_amb,k let the pairs resolve each other's phase ambiguities (measured: 4 slaves at "
       "1.25 more than halve the resolved DEM error for a 30 % larger sigma_h)", 1.0, 10.0,
       why="at 10 the fifth slave's limit is 1e4 h_amb_min, beyond any useful baseline"),
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
    _f("rate_min_mbps", [10.0, 16.95, 1.0], "R_min,k, minimum data rate of each UAV, U0 first "
       "[Mbit/s] (C10)", 0.0, None, per_uav=True),
    _f("rate_margin", 0.05, "mu, rate margin: plans size P_com so that R_k[n] >= (1 + mu) "
       "R_min,k (C10 as planned), so a UAV a few metres off its planned point, or a link a "
       "little weaker, still offloads R_min,k; 0 is the paper's C10. Costs power and energy, "
       "and sigma_h only where C9 or C11 then limit the formation", 0.0, 1.0,
       why="at 1 the plan doubles every rate"),
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
    ParamSpec("looks", int, 4, f"n_L, number of independent looks; {_LOOKS_WHY}", 1,
              MULTILOOK_MAX_LOOKS, why=_LOOKS_WHY),
    _f("tolerance", 1.0e-2, "eps_0 = eps_1 = eps_2, AO/SCA relative stopping tolerance",
       0.0, 1.0, True),
    _f("master_fixed_xz_m", [-54.0, 74.0], "q0_fixed = (x_0, z_0) for the fixed-master scheme "
       "[m]", -LENGTH_MAX_M, LENGTH_MAX_M, length=2, why=_LENGTH_WHY),
    ParamSpec("scheme", str, "proposed", "which scheme to solve", choices=SCHEMES),
    ParamSpec("objective", str, "exact", "exact: minimise sigma_h; bound: Proposition 1; "
              "multilook: sigma_h with the exact multilook phase std", choices=OBJECTIVES),
    ParamSpec("solver", str, "global", "global (certified), paper-ao (Algorithm 2) or "
              "evolution (differential evolution, no certificate)", choices=SOLVERS),
)
SPEC_BY_NAME: dict[str, ParamSpec] = {s.name: s for s in PARAM_SPECS}


# --- the nodes' own parameters --------------------------------------------------------------

AXES = 3  # a position or velocity vector: (x, y, z) or (N, E, D), not the number of UAVs
# MAVLink positions are float32: its spacing at 1e5 m is 2**-7 m = 7.8 mm.
ORIGIN_LIMIT_M = 1e5
# Vehicle k's default sysid and local UDP port: FIRST_SYSID + k, FIRST_PORT + PORT_STEP k.
FIRST_SYSID = 2
FIRST_PORT, PORT_STEP = 14552, 10


def vehicle_connection(k: int) -> str:
    """The bridge's default connection to vehicle k (`uav-insar-vehicle --listen` of it)."""
    return f"udpout:127.0.0.1:{FIRST_PORT + PORT_STEP * k}"
PASS_STARTS = ("auto", "capture", "planner")  # who starts the bridge's pass
POSITION_SOURCES = ("agent", "autopilot")  # where an agent takes its UAV's position from

AGENT_SPECS = (
    ParamSpec("uav_id", int, 0, "which UAV this agent flies: 0 master, 1..num_uavs - 1 the "
              "slaves", 0, MAX_UAVS - 1),
    ParamSpec("time_scale", float, 1.0, "mission seconds per wall-clock second", 0.0, 1000.0,
              True),
    ParamSpec("position_noise_std_m", float, 0.0, "std of the position disturbance per axis "
              "[m]", 0.0, 100.0),
    ParamSpec("noise_seed", int, 0, "seed of the position disturbance", 0, 2**31 - 1),
    ParamSpec("max_speed_mps", float, 10.0, "speed limit [m/s], at least speed_mps", 0.0,
              100.0, True),
    ParamSpec("max_accel_mps2", float, 3.0, "acceleration limit [m/s^2]", 0.0, 50.0, True),
    ParamSpec("offloading", str, "open", "power per slot: open = the plan's P_com[k][n], "
              "closed = least power meeting R_min from the measured rate and position",
              choices=("open", "closed")),
    ParamSpec("shadowing_std_db", float, 0.0, "simulated link: std of the log-normal "
              "shadowing [dB] (0: off)", 0.0, 30.0),
    ParamSpec("shadowing_corr_m", float, 20.0, "simulated link: correlation length of the "
              "shadowing along the track [m]", 0.0, 10000.0, True),
    ParamSpec("small_scale_fading", str, "off", "simulated link: small-scale fading, off or "
              "rician (K-factor rician_k_db)", choices=("off", "rician")),
    ParamSpec("rician_k_db", float, 10.0, "simulated link: Rician K-factor [dB], when "
              "small_scale_fading is rician", -30.0, 60.0),
    ParamSpec("fading_seed", int, 0, "seed of the simulated link fading and of the wind "
              "gusts", 0, 2**31 - 1),
    ParamSpec("wind_mps", float, [0.0, 0.0, 0.0], "steady wind (x, y, z) in the track frame "
              "[m/s], self-flown agent only", -50.0, 50.0, length=AXES),
    ParamSpec("gust_std_mps", float, 0.0, "std of the wind gusts per axis [m/s] (0: off)",
              0.0, 30.0),
    ParamSpec("gust_tau_s", float, 2.0, "time constant of the wind gusts [s]", 0.0, 1000.0,
              True),
    ParamSpec("position_source", str, "agent", "where the UAV is: agent = the agent's own "
              "flight (or its embedded vehicle, mavlink_listen), autopilot = its autopilot's "
              "uavK/mavlink/pose from mavlink_bridge (slots start where it crosses their lines; "
              "not with mavlink_listen)", choices=POSITION_SOURCES),
)
MAVLINK_SPECS = (
    ParamSpec("mavlink_listen", str, "", "MAVLink mode: the embedded vehicle's connection "
              "string, e.g. udpin:127.0.0.1:14552 (empty: fly /formation directly)"),
    ParamSpec("mavlink_sysid", int, 0, "MAVLink mode: the embedded vehicle's sysid (0: 2 + "
              "uav_id)", 0, 255),
    ParamSpec("track_bearing_deg", float, 0.0, "MAVLink mode: bearing of the along-track "
              "axis from north [deg], as the bridge's", -360.0, 360.0),
    ParamSpec("origin_ned_m", float, [0.0, 0.0, 0.0], "MAVLink mode: track origin in the "
              f"vehicle's local NED, as the bridge's; within +-{ORIGIN_LIMIT_M:g} m [m]",
              -ORIGIN_LIMIT_M, ORIGIN_LIMIT_M, length=AXES),
)
#: The planner's own parameters beside the scenario's PARAM_SPECS; closed ranges, which rclpy
#: checks at start and on every set, so nothing else validates them.
PLANNER_SPECS = (
    ParamSpec("uav_timeout_s", float, 5.0, "a UAV heard once and then silent (no pose, rate "
              "or offload) this long [s] is lost: the swarm is re-planned without it", 0.1,
              3600.0),
    ParamSpec("capture_radius_m", float, 1.0, "publish the pass start (formation/start) once "
              "every flown UAV's uavK/mavlink/pose is this close to its start point, as the "
              "bridge's [m]", 0.0, 1e4),
    ParamSpec("start_delay_s", float, 2.0, "the pass starts this long after every UAV was "
              "seen captured, on the wall clock: time for the start to reach every bridge [s]",
              0.1, 600.0),
)
#: The scenario parameters an agent needs (P_max and E_max for the closed loop).
AGENT_SCENARIO_SPECS = tuple(SPEC_BY_NAME[n] for n in (
    "num_uavs", "num_slots", "slot_duration_s", "speed_mps", "ground_station_m",
    "comm_bandwidth_hz", "ref_snr_db", "rate_min_mbps", "rate_margin", "p_com_max_db",
    "e_com_max_j"))

#: The planner's gcs/heartbeat period [s] (ros/gcs_link.py): 2 Hz is ~100 bytes/s on the
#: radio, and a timeout of a few seconds then spans several heartbeats.
GCS_HEARTBEAT_PERIOD_S = 0.1
#: The smallest non-zero gcs_timeout_s: ten heartbeat periods (at 30 % loss all ten are lost
#: with probability 6e-6: a hold means the ground is gone, not a lost heartbeat).
GCS_TIMEOUT_MIN_S = 10 * GCS_HEARTBEAT_PERIOD_S
#: gcs_timeout_s's default, "auto": GCS_TIMEOUT_DEFAULT_S on a per-UAV bridge (ArduPilot's
#: FS_GCS_TIMEOUT default), off on the all-in-one bridge, which sits with the ground station.
GCS_TIMEOUT_AUTO = -1.0
GCS_TIMEOUT_DEFAULT_S = 5.0

# The bridge's parameters (ROS descriptors, the parameter reference, BridgeConfig.validate).
# Defaults pair with `uav-insar-vehicle --sysid 2..4 --listen udpin:127.0.0.1:14552/14562/14572`.
BRIDGE_SPECS = (
    ParamSpec("uav_id", int, -1, "fly this UAV only (0..num_uavs - 1: one stack per UAV, one "
              "connection and one sysid, default that UAV's); -1: every UAV (one ground radio)",
              -1, MAX_UAVS - 1),
    ParamSpec("pass_start", str, "auto", "who starts the pass: planner = at the planner's "
              "formation/start, the one mission clock the agents' slots follow too; capture = "
              "this bridge once every UAV it flies is captured (flown without a planner: agents "
              "on position_source autopilot then start no slot); auto = planner",
              choices=PASS_STARTS),
    ParamSpec("connections", list,
              [vehicle_connection(k) for k in uavs(DEFAULT_NUM_UAVS)],
              "pymavlink connection string per UAV (or one shared): udpout:HOST:PORT, "
              "udpin:HOST:PORT, tcp:HOST:PORT, /dev/ttyUSB0,57600"),
    ParamSpec("target_sysids", list, [FIRST_SYSID + k for k in uavs(DEFAULT_NUM_UAVS)],
              "MAVLink system id of UAV 0, 1, 2, ... (1..255, distinct; one per UAV flown)"),
    ParamSpec("source_sysid", int, 255, "our own system id (ArduPilot: match SYSID_MYGCS)",
              1, 255),
    ParamSpec("track_bearing_deg", float, 0.0, "bearing of the along-track axis y from north "
              "[deg]", -360.0, 360.0),
    ParamSpec("origin_ned_m", float, [0.0, 0.0, 0.0], "track origin in local NED (N, E, D); "
              f"within +-{ORIGIN_LIMIT_M:g} m, where MAVLink's float32 still resolves 8 mm [m]",
              -ORIGIN_LIMIT_M, ORIGIN_LIMIT_M, length=AXES),
    ParamSpec("setpoint_rate_hz", float, 10.0, "SET_POSITION_TARGET_LOCAL_NED rate per UAV "
              "[Hz]", 2.0, 50.0),
    ParamSpec("velocity_feedforward", bool, False, "send the along-track velocity too "
              "(type_mask 3520)"),
    ParamSpec("arm_and_takeoff", bool, False, "set GUIDED/OFFBOARD, arm and take off "
              "(default: you do)"),
    ParamSpec("autopilot", str, "ardupilot", "mode numbers and arming sequence",
              choices=AUTOPILOTS),
    ParamSpec("speed_mps", float, 4.3, "along-track speed v_y [m/s]", 0.0, 1000.0),
    ParamSpec("track_duration_s", float, 0.0, "length of the pass in time, then hold at its "
              "end; 0: no end [s]", 0.0, 1e6),
    ParamSpec("capture_radius_m", float, 1.0, "start the pass when every UAV is this close to "
              "its start point; 0: start at once [m]", 0.0, 1e4),
    ParamSpec("heartbeat_timeout_s", float, 5.0, "report a UAV lost after this long without "
              "heartbeat [s]", 0.0, 3600.0, True),
    ParamSpec("readiness_timeout_s", float, 120.0, "arm_and_takeoff: how long to wait for "
              "position, mode and a passed arming check (FAILED is retried) before giving up "
              "[s]", 0.0, 3600.0, True),
    ParamSpec("min_separation_m", float, SAFE_SEPARATION_M, "warn when two planned "
              "UAVs are closer than this (standard GNSS ~1.5-3 m, RTK ~0.05 m); 0: no check "
              "[m]", 0.0, 1e4),
    ParamSpec("signing_key_file", str, "", "MAVLink 2 signing key (32 raw bytes or 64 hex "
              "characters); sign everything, accept only signed frames; empty: no signing"),
    ParamSpec("gcs_timeout_s", float, GCS_TIMEOUT_AUTO, "hold (LOITER / AUTO.LOITER) when "
              "nothing came from the ground station (gcs/heartbeat, plan, start) for this "
              f"long, counted from when it was first heard; {GCS_TIMEOUT_AUTO:g}: auto = "
              f"{GCS_TIMEOUT_DEFAULT_S:g} s with uav_id (a stack on the UAV), off for the "
              f"all-in-one bridge; 0: off; else at least {GCS_TIMEOUT_MIN_S:g} [s]",
              GCS_TIMEOUT_AUTO, 3600.0,
              why="at most an hour, beyond any battery"),
)

#: Which parameters each executable of the suite declares (the agents, however renamed,
#: are `agent`): the one answer to "who takes this name", for the nodes and the CLI alike.
NODE_SPECS: dict[str, tuple[ParamSpec, ...]] = {
    "planner": PARAM_SPECS + PLANNER_SPECS,
    "agent": AGENT_SPECS + MAVLINK_SPECS + AGENT_SCENARIO_SPECS,
    "mavlink_bridge": BRIDGE_SPECS,
}
#: The parameters rclpy declares on every node itself (Jazzy).
RCLPY_PARAMETER_NAMES = ("use_sim_time", "start_type_description_service")
#: Every parameter name of every node of the suite: a params file or an override may hold
#: any of them (a `/**` section serves every node); each node takes its own.
SUITE_PARAMETER_NAMES = frozenset(
    [s.name for specs in NODE_SPECS.values() for s in specs] + list(RCLPY_PARAMETER_NAMES))


def nodes_taking(name: str) -> tuple[str, ...]:
    """The nodes of the suite that declare parameter `name`, in NODE_SPECS order (all of
    them for rclpy's own; none for a name no node knows)."""
    if name in RCLPY_PARAMETER_NAMES:
        return tuple(NODE_SPECS)
    return tuple(node for node, specs in NODE_SPECS.items()
                 if any(s.name == name for s in specs))


def spec_named(name: str, node: str | None = None) -> ParamSpec | None:
    """The spec of parameter `name`: node `node`'s when it takes it (nodes differ in a few
    ranges), else that of the first node in NODE_SPECS that does; None for rclpy's own names
    and names no node takes."""
    for owner in ([node] if node in NODE_SPECS else []) + list(NODE_SPECS):
        for spec in NODE_SPECS[owner]:
            if spec.name == name:
                return spec
    return None
