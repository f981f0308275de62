"""Pure checks of what the planner publishes (no ROS): formation, power, diagnostics, worker."""
import math
import threading

import numpy as np
import pytest

from uav_insar_planner import published
from uav_insar_planner.evaluate import evaluate, rate_tolerance_bps
from uav_insar_planner.params import SPEC_BY_NAME, ParamSpec
from uav_insar_planner.params_file import load_params
from uav_insar_planner.plan import Plan
from uav_insar_planner.ros.solve_worker import SolveWorker
from uav_insar_planner.solver.power import schedules

FORMATION = np.array([[-40.0, 60.0], [-35.0, 58.0], [-45.0, 62.0]])


def plan_for(formation, scheme="proposed", feasible=None, blocking=()):
    """A Plan for a given formation, judged by the independent checker (no solver needed)."""
    p = load_params(overrides={"num_slots": 4})
    power = schedules(p, formation, scheme)
    ev = evaluate(p, formation, power, scheme)
    ok = ev.feasible if feasible is None else feasible
    return Plan(ok, scheme, "exact", "global", formation, power, ev.sigma_h, ev.sigma_h_bound, 7,
                0.012, ev.constraints, ev.metrics, list(blocking))


def test_formation_points_and_power_rows():
    plan = plan_for(FORMATION)
    assert published.formation_points(plan) == [(-40.0, 0.0, 60.0), (-35.0, 0.0, 58.0),
                                             (-45.0, 0.0, 62.0)]
    rows, cols, data = published.power_rows(plan)
    assert (rows, cols) == (3, 4)
    assert data[cols * 2 + 1] == plan.p_com_w[2, 1]  # row-major: [k][n] at k * N + n


def test_unflown_uav_keeps_nan_pose():
    formation = FORMATION.copy()
    formation[2] = np.nan
    x, y, z = published.formation_points(plan_for(formation, "single-baseline"))[2]
    assert math.isnan(x) and math.isnan(z) and y == 0.0


def test_plan_status_ok_lists_the_figures():
    plan = plan_for(FORMATION, feasible=True)
    status = published.plan_status(plan)
    values = dict(status.values)
    assert status.level == published.OK
    assert float(values["sigma_h_m"]) == pytest.approx(plan.sigma_h_m, rel=1e-5)
    for key in ("sigma_h_bound_m", "b_perp_m.uav1", "b_perp_m.uav2", "h_amb_m.uav1",
                "coherence.uav2", "solve_time_s", "iterations", "scheme", "x_m.uav0"):
        assert key in values
    assert values["iterations"] == "7" and values["scheme"] == "proposed"


def test_infeasible_plan_is_an_error_naming_the_blocking_constraints():
    plan = plan_for(FORMATION, feasible=False, blocking=["C8", "C10"])
    status = published.plan_status(plan)
    assert status.level == published.ERROR
    assert "C8, C10" in status.message and "not published" in status.message
    assert dict(status.values)["blocking_constraints"] == "C8,C10"
    assert published.failure_status("proposed", "boom").level == published.ERROR


def test_uav_status_stale_ok_warn():
    rate_min = (10e6, 16.95e6, 1e6)
    rep = published.UavReport()
    assert published.uav_status(1, (-35.0, 58.0), rate_min, rep).level == published.STALE
    rep.position = (-35.0, 12.0, 62.0)
    rep.record_rate(16.95e6 + 0.5 * rate_tolerance_bps(rate_min) * -1, rate_min[1])
    ok = published.uav_status(1, (-35.0, 58.0), rate_min, rep)
    assert ok.level == published.OK
    assert float(dict(ok.values)["position_error_m"]) == pytest.approx(4.0)
    rep.record_rate(16.0e6, rate_min[1])
    warn = published.uav_status(1, (-35.0, 58.0), rate_min, rep)
    assert warn.level == published.WARN and "missed" in warn.message
    assert float(dict(warn.values)["rate_margin_bps"]) == pytest.approx(-0.95e6)
    assert dict(warn.values)["slots_reported"] == "2"


def test_solve_worker_coalesces_requests_and_reports_errors():
    started, release, results = threading.Event(), threading.Event(), []
    done = threading.Semaphore(0)

    def slow_solve(params):
        started.set()
        release.wait(5.0)
        if params == "bad":
            raise RuntimeError("no plan")
        return params

    def on_result(params, plan, error, reason):
        results.append((plan, error, reason))
        done.release()

    worker = SolveWorker(slow_solve, on_result)
    try:
        assert worker.request("a", "first") is True
        assert started.wait(5.0)
        assert worker.request("b", "second") is False
        assert worker.request("bad", "third") is False  # replaces "b"
        release.set()
        assert done.acquire(timeout=5.0) and done.acquire(timeout=5.0)
        assert results == [("a", None, "first"), (None, "RuntimeError: no plan", "third")]
    finally:
        worker.stop()


def test_descriptor_ranges_and_scalar_checks():
    from uav_insar_planner.ros.parameters import as_double, check_values, descriptor_for

    rng = descriptor_for(SPEC_BY_NAME["num_slots"], False).integer_range[0]
    assert (rng.from_value, rng.to_value) == (1, 100000)
    rng = descriptor_for(SPEC_BY_NAME["speed_mps"], True).floating_point_range[0]
    assert (rng.from_value, rng.to_value) == (0.01, 1000.0)
    assert descriptor_for(SPEC_BY_NAME["speed_mps"], True).read_only
    for name in ("ground_station_m", "scheme"):
        d = descriptor_for(SPEC_BY_NAME[name], False)
        assert not d.floating_point_range and not d.integer_range and not d.read_only
    assert "one of proposed" in descriptor_for(SPEC_BY_NAME["scheme"], False).description
    assert as_double(4) == 4.0 and as_double([70, 150, 25]) == [70.0, 150.0, 25.0]
    assert as_double(True) is None and as_double(2.5) is None and as_double("4") is None
    specs = (ParamSpec("time_scale", float, 1.0, "x", 0.0, 1000.0, True),
             ParamSpec("uav_id", int, 0, "k", 0, 2))
    assert check_values({"time_scale": 20.0, "uav_id": 2}, specs) == []
    problems = check_values({"time_scale": 0.0, "uav_id": 3}, specs)
    assert problems == ["time_scale: value 0.0 is not allowed; expected a finite number in "
                        "(0, 1000]",
                        "uav_id: value 3 is not allowed; expected an integer in [0, 2]"]
