"""`--kill-uav K --at SLOT`: kill agent K's process mid-mission and watch the planner answer
(a formation without uavK after `uav_timeout_s`, or the hold when K is the master)."""
from __future__ import annotations

import signal
import subprocess
import time
from typing import Any

from uav_insar_planner.swarm import agent_name, uav_name

# The planner's answer comes after uav_timeout_s (5 s by default) and a re-plan, and may take
# that long and more on a busy host.
ANSWER_TIMEOUT_S = 60.0


def swarm_slot(w: Any) -> int:
    """The latest slot any agent reported on uavK/offload (-1 before any); `w` a
    TopicWatcher."""
    return max((int(o[-1][0]) for o in w.offloads.values() if o), default=-1)


def kill_agent(w: Any, procs: list[subprocess.Popen], k: int, slot: int,
               timeout: float) -> tuple[list[str], bool]:
    """Kill agent k (procs[k]) with SIGKILL once the swarm reached `slot`, then wait for the
    planner's next formation; (summary lines, whether the planner answered)."""
    agent = procs[k]
    if not w.spin_until(lambda: swarm_slot(w) >= slot, timeout, procs):
        return [f"  kill: the swarm never reached slot {slot}"], False
    agent.send_signal(signal.SIGKILL)
    killed, at, seen = time.monotonic(), swarm_slot(w), len(w.formations)
    print(f"demo: killed {agent_name(k)} (SIGKILL) at slot {at}", flush=True)
    others = [p for p in procs if p is not agent]
    if not w.spin_until(lambda: len(w.formations) > seen, ANSWER_TIMEOUT_S, others):
        return [f"  kill: {agent_name(k)} killed at slot {at}; no new formation came"], False
    after = time.monotonic() - killed
    w.spin_until(lambda: False, 1.0, others)  # the agents' and the bridge's reactions, logged
    w.spin_until(lambda: (s := w.plan_status()) is not None and uav_name(k) in s.message
                 and "lost" in s.message, 5.0, others)
    status = w.plan_status()
    values = {kv.key: kv.value for kv in status.values} if status else {}
    swarm = [s for m in w.diagnostics for s in m.status if s.name == "planner: swarm"]
    timeout_s = {kv.key: kv.value for kv in swarm[-1].values}.get("uav_timeout_s", "?") \
        if swarm else "?"
    lines = [f"  kill: {agent_name(k)} killed (SIGKILL) at slot {at}; new formation {after:.2f} s "
             f"later (uav_timeout_s {timeout_s} s)"]
    if "replan_latency_s" in values:
        lines.append(f"  planner: detection to new formation "
                     f"{float(values['replan_latency_s']) * 1e3:.0f} ms")
    if status is None:
        lines.append("  kill: no plan status came")
    return lines, True
