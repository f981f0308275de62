"""How an agent's UAV flies, chosen once at start-up (`choose_flight`).

- `SelfFlight`: the agent flies itself (`mission.Mission`) on the mission clock, which starts
  when the plan arrives and runs `time_scale` mission seconds per wall second.
- `MavlinkFlight`: an embedded SITL-style vehicle (`vehicle.SimVehicle`) that the MAVLink
  bridge flies; the agent reads its position, converted to the track frame, and runs the
  schedule on it (`observed_mission.ObservedMission`) from the planner's pass start. time_scale,
  the position noise and the wind do not apply then.
- `AutopilotFlight` (`position_source: autopilot`): the UAV's own autopilot, flown by the
  MAVLink bridge, whose positions the node feeds in (`feed`, from uavK/mavlink/pose, already
  in the track frame, with the instant each was read) and the schedule runs on
  (`ObservedMission`, from the planner's pass start); nothing is simulated but the link.
  time_scale, the position noise and the wind do not apply then.

In all three, the simulated link fading (`fading.LinkFading`) and the offloading law (open loop:
the plan's powers; closed: `offload.ClosedLoopOffload`) are the agent parameters' (`link_of`).

All offer the same calls: `start()` (returns a line to log, or ""), `stop()`,
`set_plan(x, y, z, powers)`, `tick() -> started slots`, `new_pass(leg, params)` (a survey
strip, track/leg.py: a fresh slot schedule under the strip's `params`, its slot count and
station, and for a watched vehicle the strip's frame) and
`mission` (the slot schedule);
`observed` says whether the slots wait for the planner's pass start (`mission.set_pass_start`:
both watched flights) or run on the agent's own mission clock (SelfFlight);
`own_poses` says whether the node publishes the mission's position on uavK/pose each tick and
at each slot start (True), or republishes the autopilot's positions as they arrive (False:
no fresh position, no pose, so a silent autopilot goes silent on uavK/pose too).
"""
from __future__ import annotations

import time
from collections.abc import Sequence

from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Vec3
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.leg import SurveyLeg
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.mission import Mission, home_position
from uav_insar_sim.observed_mission import ObservedMission
from uav_insar_sim.offload import ClosedLoopOffload
from uav_insar_sim.slots import Phase, SlotSample
from uav_insar_sim.vehicle.simulator import SimVehicle
from uav_insar_sim.wind import Wind

# MAVLink mode: the embedded vehicle starts airborne (no arming needed) above the agent's home.
MAVLINK_START_HEIGHT_M = 10.0


class SelfFlight:
    """The agent flies the UAV itself."""

    how = "flying"
    vehicle: SimVehicle | None = None
    own_poses = True
    observed = False

    def __init__(self, mission: Mission, time_scale: float, fresh=None):
        self.mission = mission
        self.time_scale = time_scale
        self._wall_t0: float | None = None
        self._fresh = fresh  # () -> a new Mission, for each survey strip

    def new_pass(self, leg: SurveyLeg | None, params: Params) -> None:
        """A strip flown from the home of its own frame (the agent simulates no turn)."""
        self.mission, self._wall_t0 = self._fresh(params), None

    def start(self) -> str:
        return ""

    def stop(self) -> None:
        pass

    def set_plan(self, x: float, y: float, z: float, powers: Sequence[float]) -> None:
        # The plan's y is not used: the run-up always puts slot 0 at y = 0.
        self.mission.set_plan((x, z), powers)
        if self._wall_t0 is None and self.mission.phase is Phase.TRANSIT:
            self._wall_t0 = time.monotonic()

    def tick(self) -> list[SlotSample]:
        if self._wall_t0 is None:
            return []
        return self.mission.advance((time.monotonic() - self._wall_t0) * self.time_scale)

    def track_started_text(self) -> str:
        return "on the run-up, slot 0 starts at y = 0"


class MavlinkFlight:
    """An embedded MAVLink vehicle, flown by the bridge, whose position the agent watches."""

    how = "the bridge flies it"
    own_poses = True
    observed = True

    def __init__(self, mission: ObservedMission, vehicle: SimVehicle, frame: TrackFrame,
                 listen: str, fresh=None):
        self.mission = mission
        self.vehicle = vehicle
        self.frame = self.home = frame
        self.listen = listen
        self._fresh = fresh  # () -> a new ObservedMission, for each survey strip

    def new_pass(self, leg: SurveyLeg | None, params: Params) -> None:
        self.mission = self._fresh(params)
        self.frame = self.home if leg is None else leg.placed(self.home)

    def start(self) -> str:
        self.vehicle.start()
        return (f"MAVLink mode, vehicle sysid {self.vehicle.sysid} on {self.listen} (port "
                f"{self.vehicle.port})")

    def stop(self) -> None:
        self.vehicle.stop()

    def set_plan(self, x: float, y: float, z: float, powers: Sequence[float]) -> None:
        self.mission.set_plan((x, z), powers, y_start=y)

    def tick(self) -> list[SlotSample]:
        return self.mission.observe(self.frame.from_ned(*self.vehicle.position_ned), time.time())

    def track_started_text(self) -> str:
        return f"slot 0 started at y = {self.mission.samples[0].position[1]:.3f} m"


class AutopilotFlight:
    """The UAV's own autopilot, flown by the bridge: the node feeds in its positions."""

    how = "its autopilot flies it"
    vehicle: SimVehicle | None = None
    own_poses = False
    observed = True

    def __init__(self, mission: ObservedMission, fresh=None):
        self.mission = mission
        self._fed: list[tuple[Vec3, float]] = []  # (position, read at) since the last tick
        self._fresh = fresh  # () -> a new ObservedMission, for each survey strip

    def new_pass(self, leg: SurveyLeg | None, params: Params) -> None:
        """(The bridge publishes the positions in the strip's frame already.) Positions fed
        before the new plan are the last strip's: dropped."""
        self.mission, self._fed = self._fresh(params), []

    def start(self) -> str:
        return "position_source autopilot: slots run on the autopilot's uavK/mavlink/pose"

    def stop(self) -> None:
        pass

    def feed(self, position: Vec3, wall_time_s: float) -> None:
        """One finite autopilot position (x, y, z) in the track frame, as it arrived, and the
        wall-clock instant the autopilot's position was read (its message's stamp)."""
        self._fed.append((position, wall_time_s))

    def set_plan(self, x: float, y: float, z: float, powers: Sequence[float]) -> None:
        self.mission.set_plan((x, z), powers, y_start=y)

    def tick(self) -> list[SlotSample]:
        fed, self._fed = self._fed, []
        return [sample for position, t in fed for sample in self.mission.observe(position, t)]

    def track_started_text(self) -> str:
        return (f"slot 0 started at y = {self.mission.samples[0].position[1]:.3f} m "
                "(autopilot position)")


Flight = SelfFlight | MavlinkFlight | AutopilotFlight


def choose_flight(own: dict, params: Params) -> Flight:
    """The flight for the agent parameters `own`: AutopilotFlight for `position_source:
    autopilot`, MavlinkFlight when `mavlink_listen` is set, else SelfFlight.

    ValueError (one line) for a bad value, e.g. max_speed_mps below speed_mps (checked in
    every mode), a bad connection string, or autopilot together with mavlink_listen."""
    k = own["uav_id"]

    def flown(p: Params = params) -> Mission:
        wind = Wind(own["wind_mps"], own["gust_std_mps"], own["gust_tau_s"], own["fading_seed"],
                    k)
        return Mission(k, p, own["max_speed_mps"], own["max_accel_mps2"],
                       own["position_noise_std_m"], own["noise_seed"], wind, *link_of(own, p))

    def observed(p: Params = params) -> ObservedMission:
        return ObservedMission(k, p, *link_of(own, p))

    mission = flown()
    if own["position_source"] == "autopilot":
        if own["mavlink_listen"]:
            raise ValueError(f"position_source: value 'autopilot' is not allowed with "
                             f"mavlink_listen {own['mavlink_listen'][:80]!r} (an embedded "
                             "vehicle); expected agent, or an empty mavlink_listen")
        return AutopilotFlight(observed(), observed)
    if not own["mavlink_listen"]:
        return SelfFlight(mission, own["time_scale"], flown)
    # The embedded vehicle's local NED relates to the track as the bridge's does.
    frame = TrackFrame.from_degrees(own["track_bearing_deg"], own["origin_ned_m"])
    return MavlinkFlight(observed(), embedded_vehicle(own, frame), frame,
                         own["mavlink_listen"], observed)


def link_of(own: dict, params: Params) -> tuple[LinkFading | None, ClosedLoopOffload | None]:
    """(fading, controller) for the agent parameters `own`; None where off / open loop."""
    k = own["uav_id"]
    k_db = own["rician_k_db"] if own["small_scale_fading"] == "rician" else None
    fading = LinkFading(own["shadowing_std_db"], own["shadowing_corr_m"], k_db,
                        own["fading_seed"], k)
    controller = ClosedLoopOffload(k, params) if own["offloading"] == "closed" else None
    return (None if fading.off else fading), controller


def embedded_vehicle(own: dict, frame: TrackFrame) -> SimVehicle:
    """The MAVLink-mode vehicle for the agent parameters `own` (not started): ArduPilot-like,
    airborne in GUIDED at MAVLINK_START_HEIGHT_M above the agent's home, with the agent's
    speed and acceleration limits. ValueError (one line) for a bad connection string."""
    x, y, _ = home_position(own["uav_id"])
    sysid = own["mavlink_sysid"] or FIRST_SYSID + own["uav_id"]
    start = frame.to_ned(float(x), float(y), MAVLINK_START_HEIGHT_M)
    try:
        return SimVehicle(sysid, own["mavlink_listen"], "ardupilot", start_ned=start,
                          max_speed=own["max_speed_mps"], max_accel=own["max_accel_mps2"],
                          airborne=True)
    except ValueError as exc:
        raise ValueError(f"mavlink_listen: {' '.join(str(exc).split())}") from None
