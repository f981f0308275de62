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
    flown = Pass(bag, UAVS, 40, 4.3, 1.0)   # the above for the pass of the bag's start
    flown.spread(since), flown.durations(since), flown.speeds(since)
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


class Pass:
    """The pass begun by a bag's first formation/start, of `num_slots` slots of `slot_s` at
    `speed_mps` from the first plan's y_start, as the autopilots reported it (each track
    smoothed over `smooth_s`); figures from an instant on (`since`, default its start) until
    its end, when the first UAV crossed the line past the last slot."""

    def __init__(self, bag: Mapping[str, list], uavs: Sequence[int], num_slots: int,
                 speed_mps: float, slot_s: float, smooth_s: float = 0.0) -> None:
        starts = start_instants(bag)
        assert starts, f"no formation/start in the bag: {sorted(bag)}"
        self.start, self.smooth_s = starts[0], smooth_s
        lines = slot_lines(y_start(bag), speed_mps, slot_s, num_slots)
        self.tracks = tracks_from_bag(bag, uavs)
        #: per UAV, when it crossed each slot line and the one past the last (as far as it got)
        self.crossed = {k: np.array(crossings(self.tracks[k].smoothed(smooth_s), lines,
                                              self.start)) for k in uavs}
        ends = [c[-1] for c in self.crossed.values() if len(c) == len(lines)]
        self.end = min(ends) if ends else float("nan")
        self._lines = len(lines)

    def spread(self, since: float | None = None) -> float:
        """The largest along-track spread [m] from `since` to the end (nan: no end)."""
        if np.isnan(self.end):
            return float("nan")
        _, spread = along_track_spread(self.tracks, self.since(since), self.end,
                                       self.smooth_s)
        return float(max(spread, default=float("nan")))

    def durations(self, since: float | None = None) -> dict[int, np.ndarray]:
        """Per UAV, the duration [s] of each slot it flew that began at or after `since`."""
        return {k: np.diff(c)[c[:-1] >= self.since(since)] for k, c in self.crossed.items()}

    def short_slots(self, shortest_s: float,
                    since: float | None = None) -> dict[int, list[tuple[int, float]]]:
        """Per UAV, (slot, duration [s]) of each slot begun at or after `since` that lasted
        less than `shortest_s`."""
        return {k: [(n, round(float(d), 2)) for n, d in enumerate(np.diff(c))
                    if c[n] >= self.since(since) and d < shortest_s]
                for k, c in self.crossed.items()}

    def speeds(self, since: float | None = None,
               window_s: float = 1.0) -> dict[int, tuple[float, float]]:
        """Per UAV, its fastest (along-track, ground) speed [m/s] over `window_s` from
        `since` until it crossed the last line (on the pass only: before it each UAV
        crosses from its home to its formation point)."""
        return {k: max_speed(self.tracks[k], window_s, self.since(since),
                             c[-1] if len(c) == self._lines else np.inf)
                for k, c in self.crossed.items()}

    def since(self, since: float | None) -> float:
        return self.start if since is None else since

    def text(self, since: float | None = None) -> str:
        """The figures from `since` in one line."""
        durations = ", ".join(
            f"{uav_name(k)} {len(d)} slots {d.min():.2f}-{d.max():.2f} s" if len(d) else
            f"{uav_name(k)} no slot" for k, d in self.durations(since).items())
        speeds = ", ".join(f"{uav_name(k)} {a:.2f}/{g:.2f}"
                           for k, (a, g) in self.speeds(since).items())
        return (f"from {self.since(since) - self.start:+.1f} s after the pass start: "
                f"along-track spread up to {self.spread(since):.2f} m until "
                f"{self.end - self.start:+.1f} s; slot durations {durations}; fastest "
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
