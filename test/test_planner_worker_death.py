"""A planner whose solve worker dies says ERROR on /diagnostics and exits 1, never a zombie
that reports OK (FAULT INJECTION: test/fault_solve_callback.py makes the second plan's
publication raise inside the worker's result callback)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticStatus
from std_srvs.srv import Trigger

from uav_insar_planner.demo.processes import start_process, stop_node

FAULT = Path(__file__).with_name("fault_solve_callback.py")


def plan_statuses(watcher) -> list[DiagnosticStatus]:
    return [s for m in watcher.diagnostics for s in m.status if s.name == "planner: plan"]


def test_a_dead_solve_worker_turns_the_planner_error_and_exits_1(watcher):
    proc = start_process([sys.executable, str(FAULT), "--ros-args", "-p", "num_slots:=10"],
                         dict(os.environ))
    try:
        assert watcher.spin_until(lambda: watcher.formations, 30.0), "no first plan"
        assert watcher.spin_until(lambda: any(s.level == DiagnosticStatus.OK
                                              for s in plan_statuses(watcher)), 10.0)
        client = watcher.node.create_client(Trigger, "/planner/replan")
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(Trigger.Request())
        assert watcher.spin_until(future.done, 10.0) and future.result().success
        assert watcher.spin_until(lambda: plan_statuses(watcher)[-1].level
                                  == DiagnosticStatus.ERROR, 10.0)
        assert "solve worker died: RuntimeError: fault injection" in \
            plan_statuses(watcher)[-1].message
        assert proc.wait(timeout=10) == 1
    finally:
        code = stop_node(proc)
        out = proc.stdout.read()
    assert code == 1, out
    assert len(watcher.formations) == 1  # the plan that raised was never half-published
    levels = [s.level for s in plan_statuses(watcher)]
    assert DiagnosticStatus.OK not in levels[levels.index(DiagnosticStatus.ERROR):]
    assert "solve worker died" in out, out
