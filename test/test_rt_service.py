"""std_srvs/Trigger across processes, and in-process with two clients of one service."""
from __future__ import annotations

import time

from uav_insar_planner import rt
from uav_insar_planner.rt.messages import msg_type


def test_trigger_round_trip_across_processes(children):
    server = children.start("server")
    assert server.stdout.readline().strip() == "ready"
    result = children.run("caller", timeout=30)
    assert result.returncode == 0, result.stderr
    replies = [line for line in result.stdout.splitlines() if line.startswith("reply")]
    assert replies == ["reply True call 1 served by server", "reply True call 2 served by server"]


def test_two_clients_get_only_their_own_replies(rt_context):
    trigger = msg_type("std_srvs/srv/Trigger")
    node = rt.Node("planner", context=rt_context)
    calls = []

    def on_call(_req, resp):
        calls.append(1)
        resp.success, resp.message = True, f"reply {len(calls)}"
        return resp

    node.create_service(trigger, "~/replan", on_call)
    clients = [node.create_client(trigger, "/planner/replan") for _ in range(2)]
    ex = rt.MultiThreadedExecutor(num_threads=2, context=rt_context)
    ex.add_node(node)
    assert all(c.wait_for_service(timeout_sec=5.0) for c in clients)
    futures = [c.call_async(trigger.Request()) for c in clients]
    end = time.monotonic() + 10
    while not all(f.done() for f in futures) and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.1)
    ex.shutdown()
    assert sorted(f.result().message for f in futures) == ["reply 1", "reply 2"]
    assert len(calls) == 2


def test_client_without_service_is_not_ready(rt_context):
    node = rt.Node("lonely", context=rt_context)
    client = node.create_client(msg_type("std_srvs/srv/Trigger"), "/nobody/home")
    assert client.wait_for_service(timeout_sec=0.3) is False
