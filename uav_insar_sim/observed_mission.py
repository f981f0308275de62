"""One UAV's mission when something else flies it (a MAVLink vehicle under the bridge).

The agent only watches: it is given the UAV's actual position (`observe`) and applies the
schedule where the plan puts it. Slot n starts when the UAV crosses, moving forward along the
track, the line y = y_start + n v_y delta_t (where the model's y[n] is), so the slots follow
the vehicle's real progress whatever its clock or speed. The position at the crossing is
interpolated between two observations, and the rate is computed there with P_com[k][n].
A line already behind the UAV when the plan arrives waits until the UAV crosses it forward
(the bridge brings every vehicle back to y_start before the pass begins).

Phases as in `mission.Mission`: `wait` (no plan) -> `transit` (plan known, before slot 0) ->
`track` (slots running) -> `done` (the line after the last slot crossed); `idle` when the plan
does not fly this UAV.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from uav_insar_planner.params import Params
from uav_insar_sim.link import achieved_rate
from uav_insar_sim.mission import SlotSample

Vec3 = tuple[float, float, float]


class ObservedMission:
    """Slots of UAV `uav_id` under `params` (SI), triggered by the observed position."""

    def __init__(self, uav_id: int, params: Params):
        self.uav_id = uav_id
        self.params = params
        self.phase = "wait"
        self.y_start = 0.0
        self.target_xz: tuple[float, float] | None = None
        self.powers: list[float] = []
        self.samples: list[SlotSample] = []
        self._last: Vec3 | None = None

    @property
    def num_slots(self) -> int:
        return len(self.powers)

    def set_plan(self, target_xz: tuple[float, float], powers: Sequence[float],
                 y_start: float = 0.0) -> None:
        """Adopt a (new) plan; slots already flown stay flown, later ones use the new
        schedule. Ignored once the mission is done."""
        if self.phase == "done":
            return
        if not all(math.isfinite(v) for v in target_xz):
            self.phase = "idle"
            return
        self.target_xz = (float(target_xz[0]), float(target_xz[1]))
        self.powers = [float(p) for p in powers]
        self.y_start = float(y_start)
        if self.phase in ("wait", "idle"):
            self.phase = "transit"

    def slot_line(self, n: int) -> float:
        """Along-track position y at which slot n starts (n = num_slots: the pass's end)."""
        return self.y_start + n * self.params.speed * self.params.slot_duration_s

    def actual_position(self) -> Vec3 | None:
        """The last observed position (None before the first)."""
        return self._last

    def observe(self, position: Sequence[float]) -> list[SlotSample]:
        """Record the UAV at `position` (x, y, z); return the slots that started since the
        last observation, in order."""
        here = (float(position[0]), float(position[1]), float(position[2]))
        before, self._last = self._last, here
        started: list[SlotSample] = []
        if before is None or self.phase not in ("transit", "track") or here[1] <= before[1]:
            return started
        while len(self.samples) < self.num_slots:
            line = self.slot_line(len(self.samples))
            if not before[1] < line <= here[1]:
                break
            started.append(self._sample(interpolate(before, here, line)))
            self.phase = "track"
        if len(self.samples) >= self.num_slots and here[1] >= self.slot_line(self.num_slots):
            self.phase = "done"
        return started

    def _sample(self, position: Vec3) -> SlotSample:
        p = self.params
        n = len(self.samples)
        rate = achieved_rate(position, self.powers[n], p.ground_station, p.comm_bandwidth_hz,
                             p.beta_c)
        sample = SlotSample(n, position, self.powers[n], rate, p.rate_min_bps[self.uav_id])
        self.samples.append(sample)
        return sample


def interpolate(a: Vec3, b: Vec3, y: float) -> Vec3:
    """The point of segment a-b (a[1] < b[1]) where the along-track coordinate equals y."""
    s = (y - a[1]) / (b[1] - a[1])
    return (a[0] + s * (b[0] - a[0]), y, a[2] + s * (b[2] - a[2]))
