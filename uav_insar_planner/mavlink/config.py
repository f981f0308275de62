"""The bridge's configuration and its validation (one line per problem); its parameters are
`param_specs.BRIDGE_SPECS` (the ROS descriptors, the generated parameter reference and
`validate` use them)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from uav_insar_planner.mavlink.link import parse_address
from uav_insar_planner.param_specs import (
    BRIDGE_SPECS,
    FIRST_SYSID,
    GCS_TIMEOUT_AUTO,
    GCS_TIMEOUT_DEFAULT_S,
    GCS_TIMEOUT_MIN_S,
    ORIGIN_LIMIT_M,
    vehicle_connection,
)
from uav_insar_planner.params import check_value, shown
from uav_insar_planner.plan import SAFE_SEPARATION_M as DEFAULT_MIN_SEPARATION_M
from uav_insar_planner.scene import Vec3
from uav_insar_planner.swarm import MAX_UAVS

_DEFAULTS = {spec.name: spec.default for spec in BRIDGE_SPECS}


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
    - gcs_timeout_s: hold when the ground station is silent this long (`holds`); 0 off,
      else at least GCS_TIMEOUT_MIN_S.
    - uav_id: -1 flies UAV k = 0.. of `target_sysids` each (N entries for N UAVs);
      0..MAX_UAVS-1 flies that UAV alone (one sysid, one connection: a stack per UAV).
    - pass_start: "capture" (the bridge's own capture gate, for a bridge flown without a
      planner) or "planner" (`Bridge.set_start`, the planner's formation/start, which the
      agents' slots follow too).
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
    gcs_timeout_s: float = 0.0
    uav_id: int = -1
    pass_start: str = "capture"

    def validate(self) -> None:
        """Raise ValueError with one line naming the first bad value and what is allowed."""
        n = len(self.target_sysids)
        if n == 0:
            raise ValueError("target_sysids: empty; expected one sysid (1..255) per UAV")
        if n > MAX_UAVS:
            raise ValueError(f"target_sysids: value {shown(list(self.target_sysids))} is not "
                             f"allowed: {n} UAVs; expected one sysid per UAV, at most "
                             f"{MAX_UAVS} (the largest swarm)")
        if self.pass_start == "auto":
            raise ValueError("pass_start: 'auto' is resolved by from_parameters; expected "
                             "capture or planner")
        for spec in BRIDGE_SPECS:  # uav_id first: the lengths below depend on it
            if spec.kind in (int, float, str):
                problem = check_value(spec, getattr(self, spec.name))[1]
                if problem:
                    raise ValueError(problem)
        if self.uav_id >= 0:
            for name, given in (("target_sysids", self.target_sysids),
                                ("connections", self.connections)):
                if len(given) != 1:
                    raise ValueError(f"{name}: {len(given)} given with uav_id "
                                     f"{self.uav_id}; expected exactly one, this UAV's")
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
        if 0.0 < self.gcs_timeout_s < GCS_TIMEOUT_MIN_S or self.gcs_timeout_s < 0.0:
            raise ValueError(f"gcs_timeout_s: value {self.gcs_timeout_s:g} is not allowed; "
                             f"expected 0 (off) or at least {GCS_TIMEOUT_MIN_S:g} s (ten "
                             "gcs/heartbeat periods, so lost heartbeats never hold)")
        length = self.speed_mps * self.track_duration_s
        if length > ORIGIN_LIMIT_M:
            raise ValueError(f"track_duration_s: {self.track_duration_s:g} s at speed_mps "
                             f"{self.speed_mps:g} is a {length:.3g} m pass; expected at most "
                             f"{ORIGIN_LIMIT_M:g} m, where MAVLink's float32 resolves 8 mm")

    def uavs(self) -> tuple[int, ...]:
        """The UAV index of each entry of `target_sysids`, in order."""
        if self.uav_id >= 0:
            return (self.uav_id,)
        return tuple(range(len(self.target_sysids)))

    def addresses(self) -> tuple[str, ...]:
        """The connection string of each UAV, in UAV order."""
        if len(self.connections) == 1:
            return self.connections * len(self.target_sysids)
        return self.connections


def from_parameters(values: dict[str, Any]) -> BridgeConfig:
    """The config of the node's parameter values (lists as given). With `uav_id` K >= 0,
    `connections` and `target_sysids` left at their defaults (Table I's three UAVs') mean UAV
    K's own default (param_specs.vehicle_connection(K), sysid FIRST_SYSID + K, any K < 6);
    "auto" `pass_start` is planner (one mission clock, which the agents' slots follow too), and
    "auto" (-1) `gcs_timeout_s`
    GCS_TIMEOUT_DEFAULT_S with a uav_id, else off. TypeError or ValueError (one line) when a
    value is bad."""
    values = {name: tuple(v) if isinstance(v, list) else v for name, v in values.items()}
    k = values.get("uav_id", -1)
    if isinstance(k, int) and 0 <= k < MAX_UAVS:
        own = {"connections": vehicle_connection(k), "target_sysids": FIRST_SYSID + k}
        for name in ("connections", "target_sysids"):
            if values.get(name) == tuple(_DEFAULTS[name]):
                values[name] = (own[name],)
    if values.get("gcs_timeout_s", GCS_TIMEOUT_AUTO) == GCS_TIMEOUT_AUTO:
        values["gcs_timeout_s"] = (GCS_TIMEOUT_DEFAULT_S if isinstance(k, int) and k >= 0
                                   else 0.0)
    if values.get("pass_start", "auto") == "auto":
        values["pass_start"] = "planner"
    return BridgeConfig(**values)
