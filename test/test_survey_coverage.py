"""The coverage map of a flown survey: the science (survey/flown_coverage.py) against a
brute-force per-cell test written here in each strip's own track frame, the slots as flown
(report/flown.py) on hand-made samples, and `uav-insar report BAG --survey` on a bag of two
strips written here with rosbags' own writer and type store."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from test_bad_input_cli import assert_one_line, run
from test_bag_report import write_known_bag
from test_survey_file import load_params, planned_survey, survey_document

from uav_insar_planner.evaluate import evaluate, rate_tolerance_bps
from uav_insar_planner.report.flown import sigma_h_per_slot, slot_positions
from uav_insar_planner.survey.coverage import cell_size_m, grid_points
from uav_insar_planner.survey.flown_coverage import flown_coverage
from uav_insar_planner.survey.survey_file import SurveyFile, read_survey

EDGE_M = 1e-6  # as coverage.py: a point on a swath's edge is imaged
P = load_params()


@pytest.fixture(scope="module")
def survey() -> SurveyFile:
    return read_survey(json.dumps(survey_document(planned_survey(), P)))


def brute_force(sf: SurveyFile, sigma_plan: float, flown: dict) -> tuple[np.ndarray, ...]:
    """(cells, planned, flown) cell by cell: each cell centre taken into every strip's track
    frame (Strip.frame: y along the flight from slot 0's line, x to the right, the master at
    x_0), imaged by slot floor(y / (L / N)) when 0 <= y <= L and |x - x_0 - o| <= S / 2."""
    cells = grid_points(sf.area, cell_size_m(sf.area))
    planned, best = np.full(len(cells), math.nan), np.full(len(cells), math.nan)
    for c, (n, e) in enumerate(cells):
        for i, strip in enumerate(sf.strips):
            x, y, _ = sf.frame(i).from_ned(float(n), float(e), 0.0)
            length, slots = strip.track.length_m, sf.num_slots[i]
            if not (-EDGE_M <= y <= length + EDGE_M
                    and abs(x - sf.master_x_m - sf.look_offset_m) <= 0.5 * sf.swath_m + EDGE_M):
                continue
            planned[c] = sigma_plan
            slot = min(slots - 1, max(0, math.floor(y / (length / slots))))
            for m, sigma in flown.get(i, []):
                if m == slot and math.isfinite(sigma) and not sigma >= best[c]:
                    best[c] = sigma
    return cells, planned, best


def _every_slot(sf: SurveyFile) -> dict:
    """Each strip's slots flown once, sigma_h growing with the strip and the slot (so the best
    of overlapping slots is a real choice)."""
    return {i: [(n, 0.07 + 1e-3 * i + 1e-5 * n) for n in range(sf.num_slots[i])]
            for i in range(len(sf.strips))}


def test_every_slot_flown_images_all_the_plan_does(survey):
    flown = _every_slot(survey)
    c = flown_coverage(survey, survey.sigma_h_m, flown)
    assert c.planned_fraction == pytest.approx(planned_survey().covered_fraction, abs=1e-12)
    assert c.flown_fraction == c.planned_fraction > 0.99
    assert np.array_equal(np.isfinite(c.flown_m), np.isfinite(c.planned_m))
    cells, planned, best = brute_force(survey, survey.sigma_h_m, flown)
    assert np.array_equal(c.points_ne, cells)
    np.testing.assert_array_equal(c.planned_m, planned)
    np.testing.assert_array_equal(c.flown_m, best)
    # overlapping swaths: where two strips image a cell, the smaller strip index (less sigma)
    assert len(set(np.round(c.flown_m, 9))) > len(survey.strips)


def test_slots_unusable_on_one_strip_leave_exactly_their_cells_unimaged(survey):
    strip = 2
    flown = _every_slot(survey)
    flown[strip] = [(n, math.nan if 3 <= n <= 5 else s) for n, s in flown[strip]]
    c = flown_coverage(survey, survey.sigma_h_m, flown)
    cells, planned, best = brute_force(survey, survey.sigma_h_m, flown)
    np.testing.assert_array_equal(c.flown_m, best)
    gap = np.isfinite(c.planned_m) & ~np.isfinite(c.flown_m)
    assert gap.sum() > 20  # three slots of ~4.3 m over a swath of ~55 m, less the overlaps
    only = {i: [(n, 1.0) for n in range(3, 6)] for i in (strip,)}  # those slots alone
    assert np.isfinite(brute_force(survey, 1.0, only)[2][gap]).all()
    assert c.flown_fraction == pytest.approx(c.planned_fraction - gap.mean(), abs=1e-12)
    again = dict(flown)
    again[strip] = flown[strip] + [(n, 0.5) for n in range(3, 6)]  # the strip flown again
    fixed = flown_coverage(survey, survey.sigma_h_m, again)
    assert fixed.flown_fraction == fixed.planned_fraction
    assert (fixed.flown_m[gap] == 0.5).all()


@pytest.mark.parametrize(("flown", "says"), [
    ({99: [(0, 0.07)]}, "flown strip 99: not allowed; expected a strip of the survey"),
    ({0: [(10_000, 0.07)]}, "flown strip 0 slot 10000: not allowed"),
    ({0: [(0, -1.0)]}, "flown strip 0 slot 0 sigma_h -1.0: not allowed"),
])
def test_flown_strips_and_slots_the_survey_does_not_have_are_refused(survey, flown, says):
    with pytest.raises(ValueError) as caught:
        flown_coverage(survey, survey.sigma_h_m, flown)
    assert str(caught.value).startswith(says) and "\n" not in str(caught.value)


def test_slots_as_flown_follow_passes_and_attempts():
    """Strip 0 slots 0-2, strip 1 slots 0-1, strip 0 again (attempt 2) slots 0-1; strip 1's
    slot 1 missed its rate, attempt 2's slot 1 has no pose."""
    rows = [(0.0, 0, 0), (1.0, 1, 0), (2.0, 2, 0), (10.0, 0, 1), (11.0, 1, 1), (20.0, 0, 0),
            (21.0, 1, 0)]
    offloads = np.array([(t, n, 1.0, 0.0, 0.0, s) for t, n, s in rows])
    rates = np.array([(t, 5e6 if t != 11.0 else 1e6) for t, _, _ in rows])
    poses = np.array([(t + dt, 3.0 + t, 0.0, 40.0 + dt) for t, _, _ in rows if t != 21.0
                      for dt in (0.2, 0.6)] + [(2.99, 100.0, 0.0, 0.0), (3.5, 1e6, 0.0, 0.0)])
    poses = poses[np.argsort(poses[:, 0])]
    got = slot_positions(offloads, rates, poses, 2e6, rate_tolerance_bps((2e6,)), 1.0)
    assert sorted(got) == [(0, 1, 0), (0, 1, 1), (0, 1, 2), (0, 2, 0), (0, 2, 1), (1, 1, 0),
                           (1, 1, 1)]
    assert got[(0, 1, 0)] == pytest.approx((3.0, 40.4))
    # the pass's last slot ends one slot later: the pose at 2.99 counts, the one at 3.5 not
    assert got[(0, 1, 2)] == pytest.approx(((5.0 + 5.0 + 100.0) / 3, (40.2 + 40.6) / 3))
    assert got[(1, 1, 1)] is None and got[(0, 2, 1)] is None
    assert got[(0, 2, 0)] == pytest.approx((23.0, 40.4))
    planned = np.array([[-27.118, 47.118], [-34.854, 48.190], [-35.914, 49.251]])
    power = np.ones((3, P.num_slots))
    other = {key: (planned[1, 0], planned[1, 1]) for key in got if key != (0, 1, 1)}
    per = sigma_h_per_slot(P, planned, "proposed",
                           {0: {key: (planned[0, 0], planned[0, 1]) for key in got},
                            1: other, 2: {key: tuple(planned[2]) for key in got}})
    plan = evaluate(P, planned, power, "proposed").sigma_h
    assert [n for n, _ in per[0]] == [0, 1, 2, 0, 1]  # attempt 1, then attempt 2
    assert np.isnan(per[0][1][1]) and per[0][0][1] == pytest.approx(plan)  # uav1 lacks (0,1,1)
    assert per[1] == [(0, pytest.approx(plan)), (1, pytest.approx(plan))]


STRIP_T0 = {0: 10.0, 1: 200.0}  # strip i's slot n starts at STRIP_T0[i] + n seconds
UAV2_OFF = (0.5, -0.3)  # on strip 0 uav2 flies this far off (x, z)
MISSED = range(3, 6)  # uav1 misses its rate in strip 1's slots 3-5


def write_survey_bag(path: Path, sf: SurveyFile) -> None:
    """Strips 0 and 1 of `sf` flown (uavK/offload naming the strip), two poses per slot."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    T = ts.types
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                      frame_id="insar_track")
    Layout, Dim = T["std_msgs/msg/MultiArrayLayout"], T["std_msgs/msg/MultiArrayDimension"]
    F64Array = T["std_msgs/msg/Float64MultiArray"]

    def pose(x: float, y: float, z: float):
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=z),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))

    n_last = sf.num_slots[1]
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as bag:
        def put(topic: str, msgtype: str, items) -> None:
            conn = bag.add_connection(topic, msgtype, typestore=ts)
            for t, msg in sorted(items, key=lambda i: i[0]):
                bag.write(conn, int(1.7e18 + round(t * 1e9)), ts.serialize_cdr(msg, msgtype))

        put("/formation", "geometry_msgs/msg/PoseArray", [(1.0, T["geometry_msgs/msg/PoseArray"](
            header=header, poses=[pose(x, 0.0, z) for x, z in sf.formation]))])
        put("/formation/power", "std_msgs/msg/Float64MultiArray", [(1.0, F64Array(
            layout=Layout(dim=[Dim(label="uav", size=3, stride=3 * n_last),
                               Dim(label="slot", size=n_last, stride=n_last)], data_offset=0),
            data=np.ones(3 * n_last)))])
        for k, (x, z) in enumerate(sf.formation):
            rates, offloads, poses = [], [], []
            for strip, t0 in STRIP_T0.items():
                dx, dz = UAV2_OFF if (k, strip) == (2, 0) else (0.0, 0.0)
                for n in range(sf.num_slots[strip]):
                    t = t0 + n
                    miss = k == 1 and strip == 1 and n in MISSED
                    rates.append((t, T["std_msgs/msg/Float64"](
                        data=P.rate_min_bps[k] + (-2e6 if miss else 1e5))))
                    offloads.append((t, F64Array(layout=Layout(dim=[], data_offset=0),
                                                 data=np.array([n, 1.0, n, 600.0 - n, strip]))))
                    poses += [(t + dt, T["geometry_msgs/msg/PoseStamped"](
                        header=header, pose=pose(x + dx, (n + dt) * P.speed, z + dz)))
                        for dt in (0.25, 0.75)]
            put(f"/uav{k}/achieved_rate", "std_msgs/msg/Float64", rates)
            put(f"/uav{k}/offload", "std_msgs/msg/Float64MultiArray", offloads)
            put(f"/uav{k}/pose", "geometry_msgs/msg/PoseStamped", poses)


def expected_flown(sf: SurveyFile) -> dict:
    planned = np.array(sf.formation)
    power = np.ones((3, sf.num_slots[1]))
    off = planned.copy()
    off[2] += UAV2_OFF
    scenario = P.replace(num_slots=sf.num_slots[1])
    plan = evaluate(scenario, planned, power, "proposed").sigma_h
    flown_off = evaluate(scenario, off, power, "proposed").sigma_h
    return {0: [(n, flown_off) for n in range(sf.num_slots[0])],
            1: [(n, math.nan if n in MISSED else plan) for n in range(sf.num_slots[1])]}


@pytest.fixture(scope="module")
def survey_bag(tmp_path_factory, survey) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("survey_bag")
    write_survey_bag(folder / "bag", survey)
    (folder / "survey.json").write_text(json.dumps(survey_document(planned_survey(), P)))
    return folder / "bag", folder / "survey.json"


def test_the_bag_gives_each_strips_slots_as_flown(survey_bag, survey):
    from uav_insar_planner.bag.reader import read_mission
    from uav_insar_planner.report.recorded import flown_by_strip, flown_scenario

    record = read_mission(survey_bag[0])
    assert set(np.unique(record.offloads[0][:, 5])) == {0.0, 1.0}
    got = flown_by_strip(record, flown_scenario(record, P))
    want = expected_flown(survey)
    assert sorted(got) == [0, 1]
    for i in want:
        assert [n for n, _ in got[i]] == [n for n, _ in want[i]]
        np.testing.assert_allclose([s for _, s in got[i]], [s for _, s in want[i]], rtol=1e-12)
    assert want[0][0][1] != pytest.approx(survey.sigma_h_m, rel=1e-4)  # uav2's offset shows


def test_report_with_the_survey_draws_the_coverage_map(capsys, survey_bag, survey, tmp_path):
    bag, survey_json = survey_bag
    out = tmp_path / "report"
    code, stdout, err = run(capsys, "report", str(bag), "--out", str(out), "--no-progress",
                            "--survey", str(survey_json))
    assert code == 0, err
    assert (out / "coverage.png").read_bytes()[:4] == b"\x89PNG"
    summary = json.loads((out / "coverage.json").read_text())
    want = flown_coverage(survey, survey.sigma_h_m, expected_flown(survey))
    assert summary["planned_fraction"] == pytest.approx(want.planned_fraction, abs=1e-12)
    assert summary["flown_fraction"] == pytest.approx(want.flown_fraction, abs=1e-12)
    assert 0.0 < summary["flown_fraction"] < 0.5 < summary["planned_fraction"]  # 2 of 7 strips
    assert summary["strips"]["1"] == {"num_slots": survey.num_slots[1],
                                      "slots_flown": survey.num_slots[1],
                                      "slots_usable": survey.num_slots[1] - len(MISSED)}
    assert (f"coverage: {want.planned_fraction:.1%} of the area planned, "
            f"{want.flown_fraction:.1%} flown with usable data") in stdout
    assert f"wrote {out / 'coverage.png'}" in stdout


@pytest.mark.parametrize("case", ["single pass", "bad survey", "no survey file"])
def test_report_refuses_a_survey_it_cannot_map_in_one_line(capsys, survey_bag, tmp_path, case):
    bag, survey_json = survey_bag
    if case == "single pass":  # a bag of agents that named no strip
        bag = tmp_path / "known"
        write_known_bag(bag)
    elif case == "bad survey":
        survey_json = tmp_path / "survey.json"
        doc = survey_document(planned_survey(), P)
        doc["strips"][0]["direction"] = 2
        survey_json.write_text(json.dumps(doc))
    else:
        survey_json = tmp_path / "nothing.json"
    out = tmp_path / "report"
    code, _, err = run(capsys, "report", str(bag), "--out", str(out), "--no-progress",
                       "--survey", str(survey_json))
    says = {"single pass": "--survey: the bag's uavK/offload samples name no survey strip",
            "bad survey": "strips[0].direction: value 2",
            "no survey file": "--survey: "}[case]
    assert_one_line(code, err, says)
    assert not out.exists()


def test_samples_a_lossy_radio_delivered_late_still_place_each_slot_on_its_stretch():
    """A radio lost slots 2-4's offload and rate: they arrived together 3 s late (Fast DDS
    resends at its next heartbeat). Poses carry when they were taken; with the slot's length
    each slot is still its own stretch of track, and each rate is the one sent with it."""
    from uav_insar_planner.report.flown import slot_positions
    v, n = 4.0, 6
    poses = np.array([(t, 1.0, v * t, 50.0 + (t // 1.0)) for t in np.arange(0.0, n, 0.05)])
    sent = np.arange(n, dtype=float)
    received = np.where((sent >= 2) & (sent <= 4), 5.0, sent)  # bunched, in order
    offloads = np.column_stack([received, np.arange(n), np.zeros(n), np.zeros(n),
                                np.zeros(n), np.full(n, 3.0)])
    rates = np.column_stack([received, np.full(n, 2e7)])
    placed = slot_positions(offloads, rates, poses, 1e7, 1e4, 1.0, v * 1.0)
    assert [key[2] for key in placed] == list(range(n))
    for (_, _, slot), xz in placed.items():
        assert xz is not None and xz[1] == pytest.approx(50.0 + slot), (slot, xz)
    by_time = slot_positions(offloads, rates, poses, 1e7, 1e4, 1.0)  # without the length
    assert by_time[(3, 1, 2)] is None or by_time[(3, 1, 2)][1] != pytest.approx(52.0)
