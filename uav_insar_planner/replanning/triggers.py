"""What calls for a re-plan (`ReplanTriggers`): what the planner knows of the swarm in flight,
who is heard, who is lost, whose closed loop saturates. Plain Python on a clock the caller
passes (no ROS; ros/swarm_watch.py feeds it).

Lost: a UAV heard at least once (any of uavK/pose, uavK/achieved_rate, uavK/offload) that
then stays silent for more than `timeout_s`, or that the MAVLink bridge reports lost on
/diagnostics (`bridge_lost`). A UAV never heard is never lost, so a planner started before
its agents waits for them. Lost is final for the mission: a UAV heard again later is reported
(`back`, once through `take_back`), not taken back into the plan. Its own stack holds it: it
timed out on the ground station's silence (mavlink/holds.py) and the survivors' plan gives
it no target; only a new mission (a planner started again) flies it again.

The slot the swarm has reached (`next_slot`): one past the latest slot any surviving UAV
reported on uavK/offload, else from the furthest survivor's pose (0 before any). Energy
left: the UAV's latest `energy_left_j`, else E_com^max minus the plan's schedule up to that
slot.

Saturated closed loop: each slot's rate and offload report are paired in arrival order. A slot
counts when the rate misses R_min,k by more than the checker's tolerance while the loop is
saturated: the power applied is at P_max (within SATURATION_RTOL) or the energy left is below
what the plan's schedule still needs after that slot. SATURATED_MISSES such slots in a row
give one `Saturated` event (then the count starts again).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.params import Params
from uav_insar_planner.replanning.plans import measured_gain

SATURATED_MISSES = 3
SATURATION_RTOL = 1e-3


@dataclass(frozen=True)
class Lost:
    """UAV `uav` declared lost at time `at`, the swarm about to fly slot `slot`."""

    uav: int
    slot: int
    why: str
    at: float


@dataclass(frozen=True)
class Saturated:
    """UAV `uav` missed R_min in `slots` with its loop saturated; `gain` is the mean channel
    gain those slots showed (linear, 1 = the model's), `energy_left_j` what it has left."""

    uav: int
    slots: tuple[int, ...]
    energy_left_j: float
    gain: float
    at_p_max: bool

    @property
    def next_slot(self) -> int:
        return self.slots[-1] + 1


@dataclass
class UavState:
    """What was last heard from one UAV."""

    last_heard: float | None = None
    position: tuple[float, float, float] | None = None
    slot: int | None = None  # latest slot reported on uavK/offload
    energy_left_j: float | None = None
    rates: deque = field(default_factory=deque)
    offloads: deque = field(default_factory=deque)
    misses: list[tuple[int, float, bool]] = field(default_factory=list)  # (slot, gain, P_max)
    back: bool = False  # heard again after it was declared lost


class ReplanTriggers:
    """The state machine of the module doc for the scenario `params` (SI)."""

    def __init__(self, params: Params, num_uavs: int | None = None):
        self.params = params
        self.uavs = [UavState() for _ in range(params.num_uavs if num_uavs is None
                                                 else num_uavs)]
        self.lost: dict[int, Lost] = {}
        self.plan_power_w: np.ndarray | None = None
        self._saturated: list[Saturated] = []
        self._back: list[int] = []
        self._tol = rate_tolerance_bps(params.rate_min_bps)

    def watch(self, n: int) -> None:
        """Keep a state for UAVs 0..n-1 at least (a larger num_uavs set in flight)."""
        self.uavs += [UavState() for _ in range(n - len(self.uavs))]

    # --- what is heard -------------------------------------------------------------------
    def set_plan(self, power_w: np.ndarray, params: Params | None = None) -> None:
        """The schedule now flown (num_uavs, N) [W]; saturation counts start again."""
        if params is not None:
            self.params, self._tol = params, rate_tolerance_bps(params.rate_min_bps)
        self.plan_power_w = np.asarray(power_w, dtype=float)
        for u in self.uavs:
            u.misses.clear()

    def _heard(self, k: int, now: float) -> UavState:
        u = self.uavs[k]
        u.last_heard = now
        if k in self.lost and not u.back:
            u.back = True
            self._back.append(k)
        return u

    def heard_pose(self, k: int, now: float, position: tuple[float, float, float]) -> None:
        self._heard(k, now).position = tuple(float(c) for c in position)

    def heard_rate(self, k: int, now: float, rate_bps: float) -> None:
        self._heard(k, now).rates.append(float(rate_bps))
        self._pair(k)

    def heard_offload(self, k: int, now: float, slot: int, power_w: float,
                      energy_left_j: float) -> None:
        u = self._heard(k, now)
        u.slot = max(int(slot), u.slot if u.slot is not None else -1)
        u.energy_left_j = float(energy_left_j)
        u.offloads.append((int(slot), float(power_w), float(energy_left_j)))
        self._pair(k)

    def bridge_lost(self, k: int, now: float, text: str) -> Lost | None:
        """The bridge reports UAV k lost; the new Lost, or None if it already was."""
        return self.declared_lost(k, now, f"MAVLink bridge: {text}")

    def declared_lost(self, k: int, now: float, why: str) -> Lost | None:
        """UAV k lost for `why` (said whole: who found it and what); the new Lost, or None if
        it already was."""
        if k in self.lost or not 0 <= k < len(self.uavs):
            return None
        return self._declare(k, now, why)

    # --- what follows ----------------------------------------------------------------------
    def check(self, now: float, timeout_s: float) -> list[Lost]:
        """The UAVs newly lost by silence at `now`, each once."""
        out = []
        for k, u in enumerate(self.uavs):
            if k in self.lost or u.last_heard is None:
                continue
            silent = now - u.last_heard
            if silent > timeout_s:
                out.append(self._declare(k, now, f"no pose, rate or offload for {silent:.1f} s, "
                                                  f"uav_timeout_s {timeout_s:g}"))
        return out

    def _declare(self, k: int, now: float, why: str) -> Lost:
        self.lost[k] = Lost(k, self.next_slot(), why, now)
        return self.lost[k]

    def next_slot(self) -> int:
        """One past the latest slot a surviving UAV reported; without any uavK/offload, the
        slot line y[n] = n v_y delta_t the furthest survivor's pose has passed; 0 before."""
        alive = [u for k, u in enumerate(self.uavs) if k not in self.lost]
        slots = [u.slot for u in alive if u.slot is not None]
        if slots:
            return max(slots) + 1
        step = self.params.speed * self.params.slot_duration_s
        ys = [u.position[1] for u in alive if u.position is not None and u.position[1] >= 0.0]
        return min(int(max(ys) // step) + 1, self.params.num_slots) if ys else 0

    def energy_left_j(self, k: int, first_slot: int) -> float:
        """What UAV k has left for the slots from `first_slot` on (see the module doc)."""
        u = self.uavs[k]
        if u.energy_left_j is not None:
            return u.energy_left_j
        if self.plan_power_w is None:
            return self.params.e_max_j
        used = float(self.plan_power_w[k, :first_slot].sum()) * self.params.slot_duration_s
        return self.params.e_max_j - used

    def take_back(self) -> list[Lost]:
        """The lost UAVs heard again since the last call, each once."""
        out, self._back = [self.lost[k] for k in self._back], []
        return out

    def take_saturated(self) -> list[Saturated]:
        """The saturation events since the last call."""
        out, self._saturated = self._saturated, []
        return out

    def _pair(self, k: int) -> None:
        u = self.uavs[k]
        while u.rates and u.offloads:
            self._slot_flown(k, u.rates.popleft(), *u.offloads.popleft())

    def _slot_flown(self, k: int, rate: float, slot: int, power: float, left: float) -> None:
        p, u = self.params, self.uavs[k]
        if k >= p.num_uavs or (self.plan_power_w is not None
                                         and k >= len(self.plan_power_w)):
            return  # a UAV beyond the scenario (num_uavs made smaller): nothing to check
        at_p_max = power >= p.p_max_w * (1.0 - SATURATION_RTOL)
        still_needed = (0.0 if self.plan_power_w is None or slot + 1 > self.plan_power_w.shape[1]
                        else float(self.plan_power_w[k, slot + 1:].sum()) * p.slot_duration_s)
        saturated = at_p_max or left < still_needed * (1.0 - SATURATION_RTOL)
        missed = rate < p.rate_min_bps[k] - self._tol
        if k in self.lost or not (missed and saturated):
            u.misses.clear()
            return
        if u.misses and u.misses[-1][0] != slot - 1:
            u.misses.clear()
        gain = (measured_gain(p, k, u.position, power, rate) if u.position is not None
                else math.nan)
        u.misses.append((slot, gain, at_p_max))
        if len(u.misses) >= SATURATED_MISSES:
            gains = [g for _, g, _ in u.misses if math.isfinite(g) and g > 0.0]
            mean = math.exp(sum(map(math.log, gains)) / len(gains)) if gains else math.nan
            self._saturated.append(Saturated(k, tuple(s for s, _, _ in u.misses), left, mean,
                                             all(m for _, _, m in u.misses)))
            u.misses.clear()

    # --- the operator's view ---------------------------------------------------------------
    def describe(self, k: int, now: float) -> str:
        """UAV k in a few words: not heard yet / heard 0.1 s ago / lost at slot n (why)."""
        u = self.uavs[k]
        if k in self.lost:
            lost = self.lost[k]
            return (f"lost at slot {lost.slot} ({lost.why})"
                    + ("; heard again since, not re-planned" if u.back else ""))
        if u.last_heard is None:
            return "not heard yet"
        return f"heard {now - u.last_heard:.1f} s ago" + (
            f", slot {u.slot}" if u.slot is not None else "")
