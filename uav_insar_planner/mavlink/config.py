"""The bridge's configuration and its validation (one line per problem).

Its parameters are `param_specs.nodes.BRIDGE_SPECS`, described there once (the ROS
descriptors, the generated parameter reference and `validate` use them): `BridgeConfig`'s
attributes are the specs' names in their order, its defaults the specs' defaults, lists as
tuples. A config built in code differs in the two "auto" values `from_parameters` resolves for
the node (IN_CODE_DEFAULTS).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, TypeVar

from uav_insar_planner.mavlink.link import parse_address
from uav_insar_planner.param_specs.nodes import (
    BRIDGE_SPECS,
    FIRST_SYSID,
    GCS_TIMEOUT_AUTO,
    GCS_TIMEOUT_DEFAULT_S,
    GCS_TIMEOUT_MIN_S,
    ORIGIN_LIMIT_M,
    vehicle_connection,
)
from uav_insar_planner.params import check_value, shown
from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import MAX_UAVS

#: A config built in code (a test, a script flying without a planner) starts its own pass at
#: capture and has no ground station to hear; the node resolves "auto" (from_parameters).
IN_CODE_DEFAULTS = {"pass_start": "capture", "gcs_timeout_s": 0.0}
_DEFAULTS = {spec.attribute: spec.si_value(spec.default) for spec in BRIDGE_SPECS}
_Class = TypeVar("_Class", bound=type)


def _defaults_from_specs(cls: _Class) -> _Class:
    """`cls` with each field's default from BRIDGE_SPECS (or IN_CODE_DEFAULTS); a field
    without a spec, or a spec without a field, stops the import."""
    fields = list(cls.__annotations__)
    if fields != list(_DEFAULTS):
        raise TypeError(f"{cls.__name__}: fields {fields} are not BRIDGE_SPECS' "
                        f"{list(_DEFAULTS)}")
    for name, default in (_DEFAULTS | IN_CODE_DEFAULTS).items():
        setattr(cls, name, default)
    return cls


@dataclass(frozen=True)
@_defaults_from_specs
class BridgeConfig:
    """Everything the bridge needs; SI inside, degrees only in `track_bearing_deg`. Each
    attribute is the BRIDGE_SPECS parameter of its name (the parameter reference says what
    it means); beside them:

    - connections: one per UAV in `target_sysids`, or one shared by all (a router).
    - arm_and_takeoff: `sequencer` runs the arming sequence for `autopilot`.
    - setpoint_rate_hz: PX4 leaves offboard below 2 Hz.
    - readiness_timeout_s: FAILED / TEMPORARILY_REJECTED arming checks are retried meanwhile;
      a cold-booting ArduCopter needs ~45 s.
    - signing_key_file, gcs_timeout_s: `signing` and `holds` do the work; gcs_timeout_s is
      0 (off) or at least GCS_TIMEOUT_MIN_S.
    - pass_start: "capture" (the bridge's own capture gate) or "planner" (`Bridge.set_start`,
      the planner's formation/start, which the agents' slots follow too).
    """

    uav_id: int
    pass_start: str
    connections: tuple[str, ...]
    target_sysids: tuple[int, ...]
    source_sysid: int
    track_bearing_deg: float
    origin_ned_m: Vec3
    setpoint_rate_hz: float
    velocity_feedforward: bool
    arm_and_takeoff: bool
    autopilot: str
    speed_mps: float
    track_duration_s: float
    capture_radius_m: float
    heartbeat_timeout_s: float
    readiness_timeout_s: float
    min_separation_m: float
    signing_key_file: str
    gcs_timeout_s: float

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
    K's own default (param_specs.nodes.vehicle_connection(K), sysid FIRST_SYSID + K, any
    K < MAX_UAVS); "auto" `pass_start` is planner (one mission clock, which the agents' slots
    follow too), and "auto" (-1) `gcs_timeout_s`
    GCS_TIMEOUT_DEFAULT_S with a uav_id, else off. TypeError or ValueError (one line) when a
    value is bad."""
    values = {name: tuple(v) if isinstance(v, list) else v for name, v in values.items()}
    k = values.get("uav_id", -1)
    if isinstance(k, int) and 0 <= k < MAX_UAVS:
        own = {"connections": vehicle_connection(k), "target_sysids": FIRST_SYSID + k}
        for name in ("connections", "target_sysids"):
            if values.get(name) == _DEFAULTS[name]:
                values[name] = (own[name],)
    if values.get("gcs_timeout_s", GCS_TIMEOUT_AUTO) == GCS_TIMEOUT_AUTO:
        values["gcs_timeout_s"] = (GCS_TIMEOUT_DEFAULT_S if isinstance(k, int) and k >= 0
                                   else 0.0)
    if values.get("pass_start", "auto") == "auto":
        values["pass_start"] = "planner"
    return BridgeConfig(**values)
