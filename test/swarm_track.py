"""How a swarm flew, measured from a recorded bag: the autopilots' positions
(uavK/mavlink/pose, PoseStamped, header.stamp = when the position was read on the UAV's host;
every host shares one clock), turned into the along-track spread of the swarm, each UAV's
fastest speed over a sliding window, and the durations of its slots (between the crossings
of the slot lines y = y_start + n v_y delta_t, as the agent starts them). Also the slot
durations an agent reports in its last line. Numbers only: no ROS here.

    tracks = tracks_from_bag(bag, UAVS)
    times, spread = along_track_spread(tracks, t0, t1, smooth_s=1.0)
    along, ground = max_speed(tracks[0], window_s=1.0)
    durations = slot_durations(tracks[0], slot_lines(0.0, 4.3, 1.0, 40), pass_start)
    figures = pass_figures(bag, UAVS, 40, 4.3, 1.0)   # all of the above for a whole pass
"""
from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.swarm import uav_name

STEP_S = 0.1  # the common time grid; the bridges publish positions at ~10 Hz
# A time farther than this from every recorded position of a UAV is not measured (a lost
# run of samples): interpolating across it would hide what the UAV did meanwhile.
MAX_GAP_S = 1.5
AGENT_DURATIONS = re.compile(r"slot durations ([\d.]+)-([\d.]+) s of ([\d.]+) s")


@dataclass(frozen=True)
class Track:
    """One UAV's positions: t [s, wall clock] increasing, xyz [m] (len(t), 3), track frame."""

    t: np.ndarray
    xyz: np.ndarray

    @property
    def y(self) -> np.ndarray:
        return self.xyz[:, 1]

    def covered(self, times: np.ndarray, max_gap_s: float = MAX_GAP_S) -> np.ndarray:
        """Which of `times` lie within the track, each between two positions read at most
        `max_gap_s` apart."""
        i = np.searchsorted(self.t, times)
        inside = (i > 0) & (i < len(self.t))
        j = np.clip(i, 1, len(self.t) - 1)
        return inside & (self.t[j] - self.t[j - 1] <= max_gap_s)

    def at(self, times: np.ndarray) -> np.ndarray:
        """The position at each of `times`, linearly interpolated, (len(times), 3)."""
        return np.stack([np.interp(times, self.t, self.xyz[:, c]) for c in range(3)], axis=1)

    def smoothed(self, window_s: float) -> Track:
        """Each position replaced by the mean of those read within window_s / 2 of it (a
        moving average against the reported position's noise; 0: unchanged)."""
        if window_s <= 0.0:
            return self
        lo = np.searchsorted(self.t, self.t - window_s / 2, side="left")
        hi = np.searchsorted(self.t, self.t + window_s / 2, side="right")
        sums = np.vstack([np.zeros((1, 3)), np.cumsum(self.xyz, axis=0)])
        return Track(self.t, (sums[hi] - sums[lo]) / (hi - lo)[:, None])


def tracks_from_bag(bag: Mapping[str, list], uavs: Iterable[int],
                    topic: str = "mavlink/pose") -> dict[int, Track]:
    """Each UAV's `uavK/<topic>` track in the bag (read_bag's layout), by its read time;
    repeated stamps (a sample resent) once."""
    tracks = {}
    for k in uavs:
        rows = {}
        for _, msg in bag.get(f"/{uav_name(k)}/{topic}", []):
            p = msg.pose.position
            rows[msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec] = (p.x, p.y, p.z)
        t = np.array(sorted(rows))
        tracks[k] = Track(t, np.array([rows[s] for s in t]).reshape(len(t), 3))
    return tracks


def along_track_spread(tracks: Mapping[int, Track], t0: float, t1: float,
                       smooth_s: float = 0.0,
                       max_gap_s: float = MAX_GAP_S) -> tuple[np.ndarray, np.ndarray]:
    """(times, spread): on a STEP_S grid over [t0, t1], the largest minus the smallest
    along-track y of the UAVs of `tracks` (each smoothed over `smooth_s`), at the times where
    every track is `covered`."""
    times = np.arange(t0, t1, STEP_S)
    ok = np.ones(len(times), bool)
    ys = []
    for track in tracks.values():
        ok &= track.covered(times, max_gap_s)
        ys.append(np.interp(times, track.t, track.smoothed(smooth_s).y))
    ys = np.array(ys)
    return times[ok], (ys.max(axis=0) - ys.min(axis=0))[ok]


def max_speed(track: Track, window_s: float = 1.0, t0: float = -np.inf, t1: float = np.inf,
              max_gap_s: float = MAX_GAP_S) -> tuple[float, float]:
    """(along-track, ground) speed [m/s], the largest over every window of `window_s`
    within [t0, t1] (STEP_S apart) whose both ends are `covered`: along-track the distance
    made good in y, ground the horizontal (x, y) distance, each over window_s."""
    start = max(t0, track.t[0])
    times = np.arange(start, min(t1, track.t[-1]) - window_s, STEP_S)
    ok = track.covered(times, max_gap_s) & track.covered(times + window_s, max_gap_s)
    times = times[ok]
    if not len(times):
        return float("nan"), float("nan")
    step = track.at(times + window_s) - track.at(times)
    return (float(np.max(step[:, 1]) / window_s),
            float(np.max(np.hypot(step[:, 0], step[:, 1])) / window_s))


def crossings(track: Track, lines: Sequence[float], after_s: float) -> list[float]:
    """When the UAV first reached each of `lines` (y, increasing) at or after `after_s`: the
    first position at or past the line, its time interpolated onto the line when the one
    before was behind it (never before `after_s`); as many as were reached."""
    times: list[float] = []
    i = int(np.searchsorted(track.t, after_s))
    for line in lines:
        while i < len(track.t) and track.y[i] < line:
            i += 1
        if i == len(track.t):
            break
        t = track.t[i]
        if i > 0 and track.y[i - 1] < line:
            s = (line - track.y[i - 1]) / (track.y[i] - track.y[i - 1])
            t = track.t[i - 1] + s * (track.t[i] - track.t[i - 1])
        times.append(max(t, after_s))
    return times


def slot_durations(track: Track, lines: Sequence[float], after_s: float) -> np.ndarray:
    """Each slot's duration [s]: from its line's crossing to the next's (lines: the slot
    lines and the one past the last slot)."""
    return np.diff(crossings(track, lines, after_s))


def slot_lines(y_start: float, speed_mps: float, slot_s: float, num_slots: int) -> np.ndarray:
    """y_start + n v_y delta_t for n = 0..num_slots (the last: the end of the last slot)."""
    return y_start + speed_mps * slot_s * np.arange(num_slots + 1)


def agent_durations(log: str) -> tuple[float, float, float] | None:
    """(shortest, longest, planned) slot duration [s] from an agent's "mission complete"
    line, None when its line does not say them."""
    found = AGENT_DURATIONS.search(log)
    return (float(found[1]), float(found[2]), float(found[3])) if found else None


@dataclass(frozen=True)
class PassFigures:
    """How a swarm flew its pass (`pass_figures`)."""

    pass_start: float  # the first formation/start's instant [s, wall clock]
    pass_end: float  # when the first UAV reached the line past the last slot (nan: none did)
    spread_m: float  # the largest along-track spread from `since` to pass_end (nan: none)
    since: float
    durations: dict[int, np.ndarray]  # per UAV, each slot's duration [s]
    speeds: dict[int, tuple[float, float]]  # per UAV, max_speed on its pass [m/s]

    def text(self) -> str:
        durations = ", ".join(
            f"{uav_name(k)} {len(d)} slots {d.min():.2f}-{d.max():.2f} s" if len(d) else
            f"{uav_name(k)} no slot" for k, d in self.durations.items())
        speeds = ", ".join(f"{uav_name(k)} {a:.2f}/{g:.2f}" for k, (a, g) in self.speeds.items())
        return (f"along-track spread up to {self.spread_m:.2f} m over "
                f"{self.pass_end - self.since:.1f} s; slot durations {durations}; fastest "
                f"along-track/ground speed over 1 s [m/s] {speeds}")


def y_start(bag: Mapping[str, list]) -> float:
    """The track start of the bag's first plan (formation: poses (x_k, y_start, z_k))."""
    _, plan = bag["/formation"][0]
    return float(np.nanmax([p.position.y for p in plan.poses]))


def start_instants(bag: Mapping[str, list]) -> list[float]:
    """The formation/start instants in the bag [s, wall clock], each once, in order."""
    seen: list[float] = []
    for _, msg in bag.get("/formation/start", []):
        t = msg.stamp.sec + 1e-9 * msg.stamp.nanosec
        if t not in seen:
            seen.append(t)
    return seen


def pass_figures(bag: Mapping[str, list], uavs: Sequence[int], num_slots: int,
                 speed_mps: float, slot_s: float, *, smooth_s: float = 0.0,
                 since: float | None = None, window_s: float = 1.0) -> PassFigures:
    """The figures of the pass begun by the bag's first formation/start, of `num_slots`
    slots of `slot_s` at `speed_mps` from the first plan's y_start: the along-track spread
    from `since` (default: that start) until the first UAV crossed the line past the last
    slot, slot durations, fastest speeds from the start until the UAV crossed that line."""
    starts = start_instants(bag)
    assert starts, f"no formation/start in the bag: {sorted(bag)}"
    lines = slot_lines(y_start(bag), speed_mps, slot_s, num_slots)
    tracks = tracks_from_bag(bag, uavs)
    passed = {k: crossings(tracks[k].smoothed(smooth_s), lines, starts[0]) for k in uavs}
    ends = [c[-1] for c in passed.values() if len(c) == len(lines)]
    end = min(ends) if ends else float("nan")
    since = starts[0] if since is None else since
    _, spread = along_track_spread(tracks, since, end, smooth_s) if ends else (None, [])
    # on the pass only: before it each UAV crosses from its home to its formation point
    speeds = {k: max_speed(tracks[k], window_s, starts[0],
                           passed[k][-1] if len(passed[k]) == len(lines) else np.inf)
              for k in uavs}
    return PassFigures(starts[0], end, float(max(spread, default=float("nan"))), since,
                       {k: np.diff(passed[k]) for k in uavs}, speeds)
