"""The autopilot flavours the bridge flies: one `AutopilotProfile` a flavour, in `PROFILES`.

Adding a flavour is a row in `PROFILES` (and one in `uav_insar_sim.vehicle.profiles` to fly it
in simulation); `profile(name)` is the one place that looks a flavour up by its name, and
`AUTOPILOTS`, the flavour list, is what `param_specs` and the command lines offer. Plain data,
no MAVLink library: the parameter tables import it.

Mode numbers are the ones each autopilot puts in HEARTBEAT.custom_mode: ArduCopter uses the
plain mode number (`COPTER_MODES`), PX4 packs main and sub mode as main << 16 | sub << 24
(`PX4_MODES`, `px4_custom_mode`). Only the modes the simulator flies are listed (a GCS's usual
ones). PX4 names: "HOLD" is AUTO.LOITER, "TAKEOFF" AUTO.TAKEOFF, "LAND" AUTO.LAND, "RTL"
AUTO.RTL.
"""
from __future__ import annotations

from dataclasses import dataclass

#: ArduCopter mode numbers (ArduCopter's `Mode::Number`).
COPTER_MODES = {"STABILIZE": 0, "ALT_HOLD": 2, "GUIDED": 4, "LOITER": 5, "RTL": 6, "LAND": 9,
                "BRAKE": 17}
#: PX4 (main mode, sub mode); sub mode 0 for main modes other than AUTO (4).
PX4_MODES = {"MANUAL": (1, 0), "ALTCTL": (2, 0), "POSCTL": (3, 0), "OFFBOARD": (6, 0),
             "TAKEOFF": (4, 2), "HOLD": (4, 3), "RTL": (4, 5), "LAND": (4, 6)}
#: PX4's main mode AUTO, the only one whose sub mode matters.
PX4_MAIN_MODE_AUTO = 4
#: The bits of custom_mode that hold PX4's main mode.
PX4_MAIN_MODE_MASK = 0x00FF0000
ALL_BITS = 0xFFFFFFFF
#: The arming sequence's steps, in the order a profile may list them (`sequencer`).
ARMING_STEPS = ("wait for position", "stream setpoints", "mode", "arm", "takeoff", "climb")


def px4_custom_mode(name: str) -> int:
    """PX4 mode name (a key of PX4_MODES) -> HEARTBEAT.custom_mode."""
    main, sub = PX4_MODES[name]
    return (main << 16) | (sub << 24)


def px4_mode_name(main: int, sub: int) -> str | None:
    """(main, sub) -> the PX4_MODES name, or None when the simulator has no such mode."""
    for name, (m, s) in PX4_MODES.items():
        if m == main and (s == sub or m != PX4_MAIN_MODE_AUTO):
            return name
    return None


def copter_mode_name(number: int) -> str | None:
    """ArduCopter mode number -> the COPTER_MODES name, or None when not simulated."""
    for name, n in COPTER_MODES.items():
        if n == number:
            return name
    return None


@dataclass(frozen=True)
class Mode:
    """A flight mode as MAV_CMD_DO_SET_MODE asks for it and HEARTBEAT shows it."""

    name: str  # as a ground station shows it
    custom_mode: int  # HEARTBEAT.custom_mode
    set_params: tuple[float, ...]  # DO_SET_MODE's param2.. (param1: the custom-mode flag)
    mask: int = ALL_BITS  # the bits of custom_mode that tell this mode

    def shown_by(self, custom_mode: int) -> bool:
        """Whether a heartbeat's custom_mode is this mode."""
        return (custom_mode & self.mask) == (self.custom_mode & self.mask)


def copter_mode(name: str) -> Mode:
    """ArduCopter's mode `name` (a key of COPTER_MODES)."""
    number = COPTER_MODES[name]
    return Mode(name, number, (float(number),))


def px4_mode(name: str, shown_as: str, mask: int = ALL_BITS) -> Mode:
    """PX4's mode `name` (a key of PX4_MODES), shown as `shown_as` (e.g. AUTO.LOITER)."""
    main, sub = PX4_MODES[name]
    return Mode(shown_as, px4_custom_mode(name), (float(main), float(sub)), mask)


@dataclass(frozen=True)
class AutopilotProfile:
    """What the bridge, its arming sequence and the mission files do differently per flavour."""

    name: str
    #: the mode the bridge flies in: the arming sequence's and a resume's after a hold
    flight: Mode
    #: the position hold the bridge's holds order
    hold: Mode
    #: return to launch and land: after a survey sortie's last strip
    home: Mode
    #: the arming sequence (names from ARMING_STEPS); "takeoff" sends NAV_TAKEOFF, without it
    #: the first setpoint is the takeoff
    arming_steps: tuple[str, ...]
    #: seconds of setpoints streamed before `flight` is asked for (0: none needed)
    stream_before_flight_s: float
    #: no setpoints outside `flight` nor during the arming sequence (the autopilot ignores
    #: them); else the stream never stops (the mode needs it before and on return)
    setpoints_in_flight_only: bool
    #: its MAV_AUTOPILOT value: HEARTBEAT.autopilot (the simulator's) and a `.plan`'s
    #: firmwareType (plain ints, as pymavlink's MAV_AUTOPILOT_*: no MAVLink library here)
    mav_autopilot: int
    #: a mission file waits for a UTC time (NAV_DELAY); else it holds until MISSION_START
    mission_waits_for_utc: bool
    #: the main mode whose sub modes a ground station names AUTO.<sub> (PX4's AUTO), if any
    auto_main_mode: int | None = None
    #: the setpoint moved this many times the across-track and height error against the
    #: autopilot's estimate (`track.cross_track`); 0: the target as planned
    cross_track_gain: float = 0.0
    #: a mission's seq 0 is the home, which the autopilot replaces with its own (ArduPilot);
    #: else the first item is seq 0 (PX4)
    mission_home_item: bool = False

    def __post_init__(self) -> None:
        order = [ARMING_STEPS.index(step) for step in self.arming_steps]
        if order != sorted(order) or "mode" not in self.arming_steps:
            raise ValueError(f"arming_steps: {self.arming_steps!r} is not allowed; expected "
                             f"a subsequence of {ARMING_STEPS} with 'mode'")

    def mode_text(self, custom_mode: int, generic: str) -> str:
        """A heartbeat's mode as the autopilot's own messages and ground station name it
        (`generic`: pymavlink's name, "LOITER" for PX4's AUTO.LOITER): AUTO.LOITER, AUTO.RTL,
        AUTO.LAND (PX4's blind land) on PX4; `generic` otherwise."""
        main = (custom_mode & PX4_MAIN_MODE_MASK) >> 16
        if self.auto_main_mode is None or custom_mode < 0 or main != self.auto_main_mode:
            return generic
        return "AUTO." + generic

    @property
    def takes_off(self) -> bool:
        """The arming sequence sends NAV_TAKEOFF (then the vehicle must be airborne to count
        as under our control already)."""
        return "takeoff" in self.arming_steps


PROFILES = {
    "ardupilot": AutopilotProfile(
        "ardupilot", flight=copter_mode("GUIDED"), hold=copter_mode("LOITER"),
        home=copter_mode("RTL"),
        arming_steps=("wait for position", "mode", "arm", "takeoff", "climb"),
        stream_before_flight_s=0.0, setpoints_in_flight_only=True,
        mav_autopilot=3, mission_waits_for_utc=True,  # MAV_AUTOPILOT_ARDUPILOTMEGA
        mission_home_item=True),
    "px4": AutopilotProfile(
        "px4", flight=px4_mode("OFFBOARD", "OFFBOARD", PX4_MAIN_MODE_MASK),
        hold=px4_mode("HOLD", "AUTO.LOITER"), home=px4_mode("RTL", "AUTO.RTL"),
        arming_steps=("wait for position", "stream setpoints", "mode", "arm"),
        # PX4 wants > 1 s of setpoints before OFFBOARD; the margin is for jitter
        stream_before_flight_s=1.2, setpoints_in_flight_only=False,
        mav_autopilot=12, mission_waits_for_utc=False,  # MAV_AUTOPILOT_PX4
        auto_main_mode=PX4_MAIN_MODE_AUTO,
        # PX4's soft position loops let the estimate wander 0.3-0.6 m on a pass: the
        # setpoint side's PI correction holds it to ~0.3 m (ArduCopter holds 0.2 m without)
        cross_track_gain=1.0),
}
AUTOPILOTS = tuple(PROFILES)


def profile(name: str) -> AutopilotProfile:
    """The profile of flavour `name` (one of AUTOPILOTS); ValueError naming them otherwise."""
    if name not in PROFILES:
        raise ValueError(f"autopilot: {name!r:.40} is not allowed; expected one of "
                         f"{', '.join(AUTOPILOTS)}")
    return PROFILES[name]


def by_mav_autopilot(number: object) -> AutopilotProfile | None:
    """The profile whose MAV_AUTOPILOT is `number` (a HEARTBEAT's, a `.plan`'s
    firmwareType), or None."""
    return next((p for p in PROFILES.values() if p.mav_autopilot == number
                 and not isinstance(number, bool)), None)
