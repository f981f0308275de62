"""A survey on ArduCopter SITL, in the field (issue 40, item 4): three copters taking off from
three places, one stack per UAV on hosts of their own over a lossy radio, 5 m/s of turbulent
wind across the strips, fly test/survey_field.py's survey (test/sitl_survey.py flies it):
two strips with a turn, the return to launch and the landing, the operator's next sortie, a
re-arm and take-off, the third strip.

Asserted from the processes' output and the bag:
- every agent flew every strip's slots, every one of them at the planned speed (slot 0
  included: each strip has its run-in), and each strip's slots are named by its offloads;
- after each sortie every bridge ordered its copter home and saw it land and disarm; the
  operator's ~/next_sortie was accepted; the planner said the survey was complete;
- `uav-insar report BAG --survey survey.json` draws the coverage map of what was flown, whose
  flown coverage is the planned one where every slot was usable.

Skipped with the reason where the SITL binary is missing or namespaces are not permitted.
About 4 minutes, flown in a group of its own after the other SITL flights: beside them 18
copters would share 2 cores (test_sitl.py failed once with this survey flying beside it).
"""
from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest
import sitl_autopilot as sitl
import sitl_survey
from side_by_side import flight

from uav_insar_planner.swarm import uav_name
from uav_insar_sim.netlab.lab import LabUnavailable, NetLab

pytestmark = [
    pytest.mark.timeout(700),
    pytest.mark.skipif(not sitl.ARDUCOPTER.exists(),
                       reason=f"ArduCopter SITL not found at {sitl.ARDUCOPTER}: a user's machine "
                              "does not have it"),
]
STRIPS = ((0, "strip 1 of sortie 1"), (1, "strip 2 of sortie 1 (its last)"),
          (2, "strip 3 of sortie 2 (its last)"))


@flight("sitl-survey", "sitl-survey")
def fly_the_survey(workdir, domain: int) -> dict:
    """The survey in the lab; what the checks need (the namespaces are gone when it ends)."""
    from sitl_hosts import HOST_NAMES, RADIO
    with NetLab(HOST_NAMES) as lab:
        for name in HOST_NAMES[1:]:
            lab.switch(f"set {name} {RADIO}")
        f = sitl_survey.fly(lab, domain, workdir)
    report = workdir / "report"
    done = subprocess.run([sys.executable, "-m", "uav_insar_planner.cli", "report", str(f.bag),
                           "--survey", str(f.survey_path), "--out", str(report),
                           "--no-progress"], capture_output=True, text=True, timeout=300)
    return {"texts": {name: o.text() for name, o in f.out.items()}, "survey": f.survey,
            "times": f.times, "report": report, "report_run": done}


@pytest.mark.side_by_side("sitl-survey")
def test_copters_fly_a_survey_in_wind_strip_after_strip_and_sortie_after_sortie(side_by_side):
    try:
        f = side_by_side.result("sitl-survey")
    except LabUnavailable as exc:
        pytest.skip(f"no network lab here: {exc}")
    texts, survey = f["texts"], f["survey"]
    print("times:", f["times"])
    for k in range(3):
        agent = texts[f"agent{k}"]
        for strip, what in STRIPS:
            n = survey.num_slots[strip]
            done = re.search(rf"{uav_name(k)}: {re.escape(what)} complete: (\d+) slots flown, "
                             r"(\d+) at the planned speed.*", agent)
            assert done, f"{uav_name(k)} {what}:\n{agent[-3000:]}"
            print(done[0])
            assert (int(done[1]), int(done[2])) == (n, n), done[0]
        bridge = texts[f"bridge{k}"]
        assert bridge.count("return to launch") == 2, bridge[-3000:]
        assert bridge.count("landed and disarmed") == 2, bridge[-3000:]
    assert "next_sortie: True" in texts["operator"], texts["operator"]
    assert "survey complete: 3 strips flown" in texts["planner"], texts["planner"][-3000:]


@pytest.mark.side_by_side("sitl-survey")
def test_the_report_draws_the_coverage_the_copters_flew(side_by_side):
    try:
        f = side_by_side.result("sitl-survey")
    except LabUnavailable as exc:
        pytest.skip(f"no network lab here: {exc}")
    run = f["report_run"]
    assert run.returncode == 0, run.stderr[-3000:]
    assert (f["report"] / "coverage.png").stat().st_size > 10_000
    summary = json.loads((f["report"] / "coverage.json").read_text())
    print(run.stdout[-1500:], summary)
    assert summary["planned_fraction"] > 0.99
    assert set(summary["strips"]) == {"0", "1", "2"}
    for i, strip in summary["strips"].items():
        assert strip["slots_flown"] == strip["num_slots"] == f["survey"].num_slots[int(i)]
    usable = all(s["slots_usable"] == s["num_slots"] for s in summary["strips"].values())
    if usable:  # (a slot whose rate the wind made miss is unusable: its ground unimaged)
        assert summary["flown_fraction"] == pytest.approx(summary["planned_fraction"])
    assert 0.5 * summary["planned_fraction"] < summary["flown_fraction"] <= \
        summary["planned_fraction"] + 1e-12
