"""The one slot scheduler of an agent: which P_com[k][n] applies in which slot, and the rate
achieved there.

The agent's phase (`Phase`): WAIT (no plan yet) -> TRANSIT (plan known, before the track) ->
TRACK (slots running) -> DONE (every slot flown). IDLE means the plan does not fly this UAV
(single-baseline's U2); HOLD that a plan in mid-flight took it out (NaN target): it stops
where it is and flies no more slots. Slot n belongs at the along-track line
y = y_start + n v_y delta_t (the model's y[n]). A position source decides when the UAV is
there and calls `start_slot` with where it actually is: `mission.Mission` flies the UAV
itself on the mission clock, `observed_mission.ObservedMission` watches a vehicle something
else flies.

The link may differ from the plan (`fading.LinkFading`, off by default) and the power applied
is the plan's P_com[k][n] (open loop, the default) or the closed-loop choice of
`offload.ClosedLoopOffload`; each sample carries the power applied and the energy used so far
against E_com^max.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Vec3
from uav_insar_planner.schemes import planned_rate_bps
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.offload import ClosedLoopOffload
from uav_insar_sim.radio import achieved_rate


@dataclass
class SlotSample:
    """One flown slot: where the UAV actually was at its start, the power applied, the rate."""

    slot: int
    position: Vec3
    power_w: float
    rate_bps: float
    rate_min_bps: float
    planned_power_w: float = math.nan
    gain: float = 1.0  # channel power gain of the simulated link (1: the paper's)
    energy_used_j: float = 0.0  # this slot included
    energy_left_j: float = math.nan  # E_com^max - energy_used_j

    @property
    def margin_bps(self) -> float:
        return self.rate_bps - self.rate_min_bps


class Phase(Enum):
    """Where an agent's mission is (module doc); the value is the word its log uses."""

    WAIT = "wait"
    TRANSIT = "transit"
    TRACK = "track"
    DONE = "done"
    IDLE = "idle"
    HOLD = "hold"

    @property
    def under_way(self) -> bool:
        """Flying the plan: on its way to the track, or on it."""
        return self in (Phase.TRANSIT, Phase.TRACK)

    @property
    def over(self) -> bool:
        """Nothing more to fly: every slot flown, or taken out in mid-flight."""
        return self in (Phase.DONE, Phase.HOLD)


class SlotSchedule:
    """The plan and the slots of agent `uav_id` under `params` (SI), over the link `fading`
    (None: the paper's), with the closed-loop `controller` (None: open loop)."""

    def __init__(self, uav_id: int, params: Params, fading: LinkFading | None = None,
                 controller: ClosedLoopOffload | None = None):
        self.uav_id = uav_id
        self.params = params
        self.fading = fading
        self.controller = controller
        self.phase = Phase.WAIT
        self.y_start = 0.0
        self.target_xz: tuple[float, float] | None = None
        self.powers: list[float] = []
        self.samples: list[SlotSample] = []

    @property
    def num_slots(self) -> int:
        return len(self.powers)

    @property
    def all_flown(self) -> bool:
        return len(self.samples) >= self.num_slots

    def set_plan(self, target_xz: tuple[float, float], powers: Sequence[float],
                 y_start: float = 0.0) -> None:
        """Adopt a (new) plan: target (x_k, z_k), schedule P_com[k][:] and the track start.

        Slots already flown stay flown, later ones use the new schedule; a replan during the
        track re-targets across-track while the slots continue. A non-finite target means
        the plan does not fly this UAV: `idle` before the flight, `hold` once under way (the
        planner's hold plan, or this UAV taken out of the plan: stop where it is, start no
        more slots). Ignored once the mission is done or holding.
        """
        if self.phase.over:
            return
        if not all(math.isfinite(v) for v in target_xz):
            self.phase = Phase.HOLD if self.phase.under_way else Phase.IDLE
            return
        self.target_xz = (float(target_xz[0]), float(target_xz[1]))
        self.powers = [float(p) for p in powers]
        self.y_start = float(y_start)
        if self.phase in (Phase.WAIT, Phase.IDLE):
            self.phase = Phase.TRANSIT

    def slot_line(self, n: int) -> float:
        """Along-track position y at which slot n starts (n = num_slots: the pass's end)."""
        return self.y_start + n * self.params.speed * self.params.slot_duration_s

    def miss_reason(self, sample: SlotSample) -> str:
        """Why `sample` fell short of R_min, in words: where the UAV was against the plan's
        point for that slot, the power applied against the plan's, the simulated link's gain."""
        p = self.params
        station = tuple(p.ground_station)
        d = float(model.distance_to_station(*sample.position, station))
        why = [f"slot {sample.slot} missed R_min by {-sample.margin_bps:.0f} bit/s "
               f"({sample.rate_bps / 1e6:.6g} of {sample.rate_min_bps / 1e6:g} Mbit/s)"]
        if self.target_xz is not None:
            x, z = self.target_xz
            planned = float(model.distance_to_station(x, self.slot_line(sample.slot), z, station))
            # the plan's power meets (1 + mu) R_min at `planned`: how much farther it still holds
            reach = planned * math.sqrt(_snr(planned_rate_bps(p, self.uav_id, "proposed"), p) /
                                        _snr(sample.rate_min_bps, p)) if sample.rate_min_bps else d
            why.append(f"{d - planned:+.2f} m from the ground station against the plan's point "
                       f"(its rate margin covers {reach - planned:+.2f} m)")
        if not math.isclose(sample.power_w, sample.planned_power_w, rel_tol=1e-9):
            caps = [f"P_max {p.p_max_w:.3g} W"] if sample.power_w >= p.p_max_w * (1 - 1e-9) else []
            energy_left = sample.energy_left_j + sample.power_w * p.slot_duration_s
            if sample.power_w * p.slot_duration_s >= energy_left * (1 - 1e-9):
                caps.append(f"the {energy_left:.3g} J left of E_max")
            why.append(f"power {sample.power_w:.4g} W against the plan's "
                       f"{sample.planned_power_w:.4g} W" + (f", capped by {' and '.join(caps)}"
                                                           if caps else ""))
        if sample.gain != 1.0:
            why.append(f"link gain {10 * math.log10(sample.gain):+.2f} dB (fading)")
        return "; ".join(why)

    def start_slot(self, position: Vec3) -> SlotSample:
        """Start the next slot with the UAV at `position`: the power applied (the plan's, or
        the controller's) and the rate there over the (possibly faded) link."""
        p = self.params
        n = len(self.samples)
        used = self.samples[-1].energy_used_j if self.samples else 0.0
        planned = self.powers[n]
        power = planned if self.controller is None else self.controller.power(
            n, position, self.powers, used)
        gain = 1.0 if self.fading is None else self.fading.gain(position)
        rate = achieved_rate(position, power, p.ground_station, p.comm_bandwidth_hz,
                             p.beta_c, gain)
        used += power * p.slot_duration_s
        sample = SlotSample(n, position, power, rate, p.rate_min_bps[self.uav_id], planned,
                            gain, used, p.e_max_j - used)
        if self.controller is not None:
            self.controller.observe(position, power, rate)
        self.samples.append(sample)
        self.phase = Phase.TRACK
        return sample


def _snr(rate_bps: float, p: Params) -> float:
    """The SNR that carries `rate_bps` over B_c (eq. 17 inverted)."""
    return math.expm1(rate_bps / p.comm_bandwidth_hz * math.log(2.0))
