"""Position source for a UAV that something else flies (a MAVLink vehicle under the bridge).

The agent only watches: it is given the UAV's actual position (`observe`) and applies the
schedule where the plan puts it. Slot n starts when the UAV crosses, moving forward along the
track, the line y = y_start + n v_y delta_t (`SlotSchedule.slot_line`), so the slots follow
the vehicle's real progress whatever its clock or speed. The position at the crossing is
interpolated between two observations, and the rate is computed there with P_com[k][n].
A line already behind the UAV when the plan arrives waits until the UAV crosses it forward
(the bridge brings every vehicle back to y_start before the pass begins). The mission is
`done` once the line after the last slot is crossed.
"""
from __future__ import annotations

from collections.abc import Sequence

from uav_insar_planner.mavlink.frames import Vec3
from uav_insar_planner.params import Params
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.offload import ClosedLoopOffload
from uav_insar_sim.slots import SlotSample, SlotSchedule


class ObservedMission(SlotSchedule):
    """Slots of UAV `uav_id` under `params` (SI), triggered by the observed position."""

    def __init__(self, uav_id: int, params: Params, fading: LinkFading | None = None,
                 controller: ClosedLoopOffload | None = None):
        super().__init__(uav_id, params, fading, controller)
        self._last: Vec3 | None = None

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
        while not self.all_flown:
            line = self.slot_line(len(self.samples))
            if not before[1] < line <= here[1]:
                break
            started.append(self.start_slot(interpolate(before, here, line)))
        if self.all_flown and here[1] >= self.slot_line(self.num_slots):
            self.phase = "done"
        return started


def interpolate(a: Vec3, b: Vec3, y: float) -> Vec3:
    """The point of segment a-b (a[1] < b[1]) where the along-track coordinate equals y."""
    s = (y - a[1]) / (b[1] - a[1])
    return (a[0] + s * (b[0] - a[0]), y, a[2] + s * (b[2] - a[2]))
