"""Every node's own parameters beside the scenario's (PLANNER_SPECS, AGENT_SPECS, MAVLINK_SPECS,
BRIDGE_SPECS), and which node takes which (`NODE_SPECS`, `nodes_taking`, `spec_named`): the
one answer to "who takes this name", for the nodes, the command line and the demo alike.
`mavlink/config.py` builds `BridgeConfig` from BRIDGE_SPECS (its attributes are the specs'
names, its defaults their defaults).
"""
from __future__ import annotations

from uav_insar_planner.autopilots.profiles import AUTOPILOTS
from uav_insar_planner.param_specs import ParamSpec
from uav_insar_planner.param_specs.science import PARAM_SPECS, SPEC_BY_NAME
from uav_insar_planner.plan import SAFE_SEPARATION_M
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, uavs

AXES = 3  # a position or velocity vector: (x, y, z) or (N, E, D), not the number of UAVs
# MAVLink positions are float32: its spacing at 1e5 m is 2**-7 m = 7.8 mm.
ORIGIN_LIMIT_M = 1e5
# Vehicle k's default sysid and local UDP port: FIRST_SYSID + k, FIRST_PORT + PORT_STEP k.
FIRST_SYSID = 2
FIRST_PORT, PORT_STEP = 14552, 10


def vehicle_connection(k: int) -> str:
    """The bridge's default connection to vehicle k (`uav-insar-vehicle --listen` of it)."""
    return f"udpout:127.0.0.1:{FIRST_PORT + PORT_STEP * k}"


# Simulated vehicle k starts airborne above agent k's home, (5 k, -30, 10) m in the track
# frame, so it reaches the pass start (y = 0) from behind, moving forward (the demo's and
# swarm.launch.py's vehicles).
VEHICLE_HOME_Y_M, VEHICLE_SPACING_M, VEHICLE_START_HEIGHT_M = -30.0, 5.0, 10.0


def vehicle_start_ned(k: int) -> tuple[float, float, float]:
    """Simulated vehicle k's start in local NED (N = y, E = x, D = -z of the track frame)."""
    return VEHICLE_HOME_Y_M, VEHICLE_SPACING_M * k, -VEHICLE_START_HEIGHT_M
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
    ParamSpec("start_confirm_wait_s", float, 20.0, "a pass resumed from the hover starts only "
              "once every flown UAV's bridge confirmed its start on /diagnostics, moved later "
              "meanwhile, and after this long without them (then left behind); 0: not waited "
              "for [s]", 0.0, 600.0),
    ParamSpec("capture_timeout_s", float, 120.0, "the pass start waits this long [s] for every "
              "flown UAV to be captured at its entry (counted from the first bridge seen "
              "flying the plan); then the ones not captured are declared lost, one line naming "
              "each and why, and the others fly without them once re-planned; 0: wait for ever",
              0.0, 3600.0),
    ParamSpec("survey_file", str, "", "fly this survey (the survey.json of `uav-insar survey "
              "--out`) strip after strip, sortie after sortie (~/next_sortie); its speed must be "
              "speed_mps; empty: one pass"),
)
#: The scenario parameters an agent needs (P_max and E_max for the closed loop).
AGENT_SCENARIO_SPECS = tuple(SPEC_BY_NAME[n] for n in (
    "num_uavs", "num_slots", "slot_duration_s", "speed_mps", "ground_station_m",
    "comm_bandwidth_hz", "ref_snr_db", "rate_min_mbps", "rate_margin", "p_com_max_db",
    "e_com_max_j"))

#: The planner's gcs/heartbeat period [s] (ros/gcs_link.py): a 51-byte message naming the
#: plan (serialized; about 135 bytes with RTPS, UDP and IP headers), so about 1.4 kB/s on the
#: radio, and the shortest timeout spans ten heartbeats.
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
    ParamSpec("velocity_feedforward", bool, True, "send the target's velocity too (type_mask "
              "3520); false: position only (3576), which a moving target outruns (PX4 lags "
              "v_y / MPC_XY_P, 4.5 m)"),
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
