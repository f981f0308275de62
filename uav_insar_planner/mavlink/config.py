"""The bridge's configuration and its validation (one line per problem)."""
from __future__ import annotations

from dataclasses import dataclass

from uav_insar_planner.mavlink.autopilots import AUTOPILOTS
from uav_insar_planner.mavlink.frames import Vec3
from uav_insar_planner.mavlink.link import parse_address
from uav_insar_planner.params import ParamSpec, check_value
from uav_insar_planner.plan import SAFE_SEPARATION_M as DEFAULT_MIN_SEPARATION_M
from uav_insar_planner.swarm import UAVS

ORIGIN_LIMIT_M = 1e5  # float32 spacing at 1e5 m is 2**-7 m = 7.8 mm

# Vehicle k's default sysid and local UDP port: FIRST_SYSID + k, FIRST_PORT + PORT_STEP k.
FIRST_SYSID = 2
FIRST_PORT, PORT_STEP = 14552, 10

# The bridge's parameters (ROS descriptors, README table, BridgeConfig.validate). Defaults
# pair with `uav-insar-vehicle --sysid 2..4 --listen udpin:127.0.0.1:14552/14562/14572`.
BRIDGE_SPECS = (
    ParamSpec("connections", list,
              [f"udpout:127.0.0.1:{FIRST_PORT + PORT_STEP * k}" for k in UAVS],
              "pymavlink connection string per UAV (or one shared): udpout:HOST:PORT, "
              "udpin:HOST:PORT, tcp:HOST:PORT, /dev/ttyUSB0,57600"),
    ParamSpec("target_sysids", list, [FIRST_SYSID + k for k in UAVS],
              "MAVLink system id of UAV 0, 1, 2 (1..255, distinct)"),
    ParamSpec("source_sysid", int, 255, "our own system id (ArduPilot: match SYSID_MYGCS)",
              1, 255),
    ParamSpec("track_bearing_deg", float, 0.0, "bearing of the along-track axis y from north "
              "[deg]", -360.0, 360.0),
    ParamSpec("origin_ned_m", float, [0.0, 0.0, 0.0], "track origin in local NED (N, E, D); "
              f"within +-{ORIGIN_LIMIT_M:g} m, where MAVLink's float32 still resolves 8 mm [m]",
              -ORIGIN_LIMIT_M, ORIGIN_LIMIT_M, length=3),
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
    ParamSpec("min_separation_m", float, DEFAULT_MIN_SEPARATION_M, "warn when two planned "
              "UAVs are closer than this (standard GNSS ~1.5-3 m, RTK ~0.05 m); 0: no check "
              "[m]", 0.0, 1e4),
    ParamSpec("signing_key_file", str, "", "MAVLink 2 signing key (32 raw bytes or 64 hex "
              "characters); sign everything, accept only signed frames; empty: no signing"),
)




@dataclass(frozen=True)
class BridgeConfig:
    """Everything the bridge needs; SI inside, degrees only in `track_bearing_deg`.

    - connections: one per UAV in `target_sysids`, or one shared by all (a router).
    - setpoint_rate_hz: 2..50 (PX4 leaves offboard below 2 Hz).
    - velocity_feedforward: also send the track velocity with each setpoint.
    - arm_and_takeoff: run the arming sequence for `autopilot` (see `sequencer`).
    - track_duration_s: 0 for an endless pass, else the pass brakes to a stop after it.
    - capture_radius_m: how close every UAV must be to its start before the pass (0: at once).
    - heartbeat_timeout_s: a UAV is lost after this long without a heartbeat.
    - readiness_timeout_s: with arm_and_takeoff, how long each UAV may take to report a
      position, hold its mode and pass its arming checks (FAILED / TEMPORARILY_REJECTED are
      retried meanwhile) before its sequence fails; a cold-booting ArduCopter needs ~45 s.
    - min_separation_m: the bridge warns when two planned UAVs are closer (0: no check); see
      DEFAULT_MIN_SEPARATION_M for the figure.
    - signing_key_file: MAVLink 2 signing on every link with this key (`signing`); "" off.
    """

    connections: tuple[str, ...]
    target_sysids: tuple[int, ...]
    source_sysid: int = 255
    track_bearing_deg: float = 0.0
    origin_ned_m: Vec3 = (0.0, 0.0, 0.0)
    setpoint_rate_hz: float = 10.0
    velocity_feedforward: bool = False
    arm_and_takeoff: bool = False
    autopilot: str = "ardupilot"
    speed_mps: float = 4.3
    track_duration_s: float = 0.0
    capture_radius_m: float = 1.0
    heartbeat_timeout_s: float = 5.0
    readiness_timeout_s: float = 120.0
    min_separation_m: float = DEFAULT_MIN_SEPARATION_M
    signing_key_file: str = ""

    def validate(self) -> None:
        """Raise ValueError with one line naming the first bad value and what is allowed."""
        n = len(self.target_sysids)
        if n == 0:
            raise ValueError("target_sysids: empty; expected one sysid (1..255) per UAV")
        if len(self.connections) not in (1, n):
            raise ValueError(f"connections: {len(self.connections)} given for {n} UAVs; "
                             "expected one per UAV in target_sysids, or one shared")
        for i, address in enumerate(self.connections):
            try:
                parse_address(address)
            except ValueError as exc:
                raise ValueError(f"connections[{i}]: {exc}") from None
        for sysid in (*self.target_sysids, self.source_sysid):
            if isinstance(sysid, bool) or not isinstance(sysid, int) or not 1 <= sysid <= 255:
                raise ValueError(f"sysid {sysid!r} is not allowed; expected an integer 1..255")
        if len(set(self.target_sysids)) != n:
            raise ValueError(f"target_sysids: {list(self.target_sysids)} repeats a sysid; "
                             "each UAV needs its own")
        if self.source_sysid in self.target_sysids:
            raise ValueError(f"source_sysid: {self.source_sysid} is also a target sysid; "
                             "expected the bridge's own id (e.g. 255, the SYSID_MYGCS default)")
        for spec in BRIDGE_SPECS:
            if spec.kind in (int, float, str):
                problem = check_value(spec, getattr(self, spec.name))[1]
                if problem:
                    raise ValueError(problem)
        length = self.speed_mps * self.track_duration_s
        if length > ORIGIN_LIMIT_M:
            raise ValueError(f"track_duration_s: {self.track_duration_s:g} s at speed_mps "
                             f"{self.speed_mps:g} is a {length:.3g} m pass; expected at most "
                             f"{ORIGIN_LIMIT_M:g} m, where MAVLink's float32 resolves 8 mm")

    def addresses(self) -> tuple[str, ...]:
        """The connection string of each UAV, in UAV order."""
        if len(self.connections) == 1:
            return self.connections * len(self.target_sysids)
        return self.connections
