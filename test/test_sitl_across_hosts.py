"""Per-UAV stacks on ArduCopter SITL, in the field: four hosts (a ground station and one
computer per UAV, Linux network namespaces on a lossy switch, 10 % loss each way), three
ArduCopter SITL copters (../shared/sitl/), one inside each UAV's namespace with its own bridge
(arm_and_takeoff) and agent (position_source autopilot), all taking off from one home beside
the track start in 5 m/s of turbulent wind across the track with GNSS noise
(test/sitl_hosts.py runs it and measures; the figures are printed).

Asserted, from what the ground recorded (the bag), the processes' output and the simulator's
own physics state (SIMSTATE, recorded inside each UAV's namespace):
- slot 0 starts on time: each agent sent its slot 0 (uavK/offload, the bag's publish
  time: the agent's own clock) no more than EARLY_S before the pass clock put the target on
  slot 0's line (the planner's formation/start instant and the run-in from the entry,
  `slot0_due_s`), and at most LATE_S after that or after the UAV's agent and bridge heard of
  the start, whichever is latest (formation/start crosses the radio: at 10 % loss a lost
  sample is resent after Fast DDS's next heartbeat, 3 s, later than the planner's
  start_delay_s of 2 s; seen in
  3 of 5 runs, an agent or a bridge hearing it 1.2 s after the instant); every UAV flies every
  slot, once and in order;
- the rate met (achieved_rate >= R_min - evaluate.rate_tolerance_bps) in at least
  MET_SHARE of the slots (the issue's target is 95 %), each miss explained in the agent's log
  (a line with "missed R_min" naming the slot);
- sigma_h of the flown geometry (each UAV's mean (x, z) on the pass) within SIGMA_TOL of the
  plan's, from the autopilots' positions recorded on the ground (uavK/mavlink/pose) and from
  the simulator's truth; each copter's true mean across-track and height error on the pass
  within TRUE_MEAN_M of the plan.

Skipped with the reason where the SITL binary is missing, or namespaces / TAP devices are not
permitted (NetLab's LabUnavailable). About 70 s on 2 cores, flown side by side with the suite's
other SITL flights (test/side_by_side.py); every process is killed by process group and every
namespace deleted when the lab closes.
"""
from __future__ import annotations

import math
import re

import pytest
import sitl_autopilot as sitl
import sitl_hosts as hosts
from side_by_side import flight

from uav_insar_planner.swarm import uav_name
from uav_insar_sim.netlab.lab import LabUnavailable, NetLab

# The copter may lead its target after the ramp: with the run-in's 6 m of cruise before slot 0
# (track.passes.RUN_IN_MARGIN_M) every copter reached slot 0's line 0.51-0.58 s (2.2-2.5 m)
# before the clock in two runs, in 5 m/s of turbulent wind; before, slot 0 came at the ramp's
# end, where copters lag (0.31-0.47 s late).
EARLY_S = 0.75
# A copter is captured up to capture_radius_m (1 m) behind its entry and follows its target
# with a lag; the agent hears its autopilot at ~10 Hz. Measured before the run-in (a start at
# the line): +0.31 to +0.47 s from the pass start when the agent and bridge heard it in time.
LATE_S = 2.0
MET_SHARE = 0.90
SIGMA_TOL = 0.03
TRUE_MEAN_M = 1.0  # the capture radius: where the planner counts a UAV as on its start

pytestmark = [
    pytest.mark.timeout(240),
    pytest.mark.skipif(not sitl.ARDUCOPTER.exists(),
                       reason=f"ArduCopter SITL not found at {sitl.ARDUCOPTER}: a user's machine "
                              "does not have it"),
]


@flight("sitl-across-hosts", "sitl")
def fly_on_four_hosts(workdir, domain: int) -> dict:
    """The mission in the lab (the namespaces are deleted when it ends); its figures."""
    with NetLab(hosts.HOST_NAMES) as lab:
        for name in hosts.HOST_NAMES[1:]:
            lab.switch(f"set {name} {hosts.RADIO}")
        return hosts.figures(hosts.fly(lab, domain, workdir))


@pytest.mark.side_by_side("sitl-across-hosts")
def test_arducopters_on_their_own_hosts_fly_every_slot_from_the_pass_start(side_by_side):
    try:
        f = side_by_side.result("sitl-across-hosts")
    except LabUnavailable as exc:
        pytest.skip(f"no network lab here: {exc}")
    print("\n" + hosts.table(f))
    n = hosts.N_SLOTS
    for k, u in f["uav"].items():
        name = uav_name(k)
        # the field is what it says: every simulator runs with our wind and GNSS noise
        assert u["sim_parameters"] == pytest.approx(hosts.field_parameters()), name
        assert u["slots"] == list(range(n)), (name, u["slots"])
        assert len(u["rates_bps"]) == n, (name, len(u["rates_bps"]))
        heard = (u["start_heard_s"], u["bridge_heard_s"])
        assert all(map(math.isfinite, heard)), (name, "no word of the pass start", heard)
        due = f["slot0_due_s"]
        assert due - EARLY_S <= u["slot0_sent_s"] <= max(*heard, due) + LATE_S, (
            name, u["slot0_sent_s"], due, heard)
    assert f["met_share"] >= MET_SHARE, f["met_share"]
    for k, u in f["uav"].items():
        for slot in u["missed"]:
            said = [line for line in u["missed_lines"] if re.search(rf"\bslot {slot}\b", line)]
            assert said, (uav_name(k), slot, u["missed_lines"])
    plan = f["sigma_h_plan_m"]
    for key in ("sigma_h_autopilot_m", "sigma_h_truth_m"):
        assert math.isfinite(f[key]) and abs(f[key] / plan - 1.0) <= SIGMA_TOL, (key, f[key], plan)
    for k, u in f["uav"].items():
        for axis in ("across", "height"):
            assert abs(u["truth"][axis]["mean"]) <= TRUE_MEAN_M, (uav_name(k), axis,
                                                                  u["truth"][axis])
