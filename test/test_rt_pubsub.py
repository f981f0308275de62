"""Publish/subscribe across real processes on Cyclone DDS, with the default discovery
settings (which must work without multicast)."""
from __future__ import annotations

import time

from uav_insar_planner import rt
from uav_insar_planner.rt.messages import get_message
from uav_insar_planner.rt.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _spin_until(ctx, node, cond, timeout: float) -> None:
    ex = rt.SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        ex.spin_once(timeout_sec=0.1)
    ex.shutdown()


def _wait_ready(proc) -> None:
    line = proc.stdout.readline()
    assert line.strip() == "ready", (line, proc.stderr.read() if proc.poll() is not None else "")


def test_two_processes_pubsub(children):
    talker = children.start("talker")
    _wait_ready(talker)
    result = children.run("listener", "3", timeout=20)
    assert result.returncode == 0, result.stderr
    got = [line.split(" ", 1)[1] for line in result.stdout.splitlines() if line.startswith("got")]
    assert len(got) == 3 and all(g.startswith("hello ") for g in got)
    numbers = [int(g.split()[1]) for g in got]
    assert numbers == sorted(numbers)


def test_late_joiner_gets_transient_local_sample(children, rt_context):
    talker = children.start("talker")
    _wait_ready(talker)
    time.sleep(0.3)  # the sample was published well before we subscribe
    node = rt.Node("late_joiner", context=rt_context)
    got = []
    node.create_subscription(get_message("geometry_msgs/msg/PoseArray"), "/formation",
                             got.append, LATCHED)
    _spin_until(rt_context, node, lambda: got, 10)
    assert len(got) == 1
    msg = got[0]
    assert msg.header.frame_id == "insar_track"
    assert [p.position.x for p in msg.poses] == [0.0, 10.0, 20.0]
    assert [p.position.z for p in msg.poses] == [50.0, 51.0, 52.0]
    assert all(p.orientation.w == 1.0 for p in msg.poses)


def test_volatile_late_joiner_gets_no_old_sample(children, rt_context):
    talker = children.start("talker")
    _wait_ready(talker)
    node = rt.Node("volatile_joiner", context=rt_context)
    got = []
    node.create_subscription(get_message("geometry_msgs/msg/PoseArray"), "/formation",
                             got.append, QoSProfile(depth=1))
    chatter = []
    node.create_subscription(get_message("std_msgs/msg/String"), "/chatter", chatter.append, 10)
    _spin_until(rt_context, node, lambda: len(chatter) >= 3, 10)
    assert len(chatter) >= 3  # discovery worked, so the missing formation is the QoS
    assert got == []


def test_best_effort_writer_reliable_reader_gets_nothing(children, rt_context, monkeypatch):
    monkeypatch.setenv("QOS", "best_effort")
    talker = children.start("talker")
    _wait_ready(talker)
    node = rt.Node("strict_reader", context=rt_context)
    reliable, best_effort = [], []
    string = get_message("std_msgs/msg/String")
    node.create_subscription(string, "/chatter", reliable.append, QoSProfile(depth=10))
    node.create_subscription(string, "/chatter", best_effort.append, QoSProfile(
        depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
    _spin_until(rt_context, node, lambda: len(best_effort) >= 5, 10)
    assert len(best_effort) >= 5  # the writer is there and sending
    assert reliable == []


def test_in_process_timer_pubsub_and_counts(rt_context):
    node = rt.Node("pinger", context=rt_context, namespace="/uav1")
    float64 = get_message("std_msgs/msg/Float64")
    pub = node.create_publisher(float64, "achieved_rate", 10)
    got = []
    node.create_subscription(float64, "/uav1/achieved_rate", lambda m: got.append(m.data), 10)
    ticks = iter(range(1000))
    node.create_timer(0.02, lambda: pub.publish(float64(data=float(next(ticks)))))
    _spin_until(rt_context, node, lambda: len(got) >= 5, 10)
    assert got[:5] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert node.count_publishers("achieved_rate") == 1
    assert node.count_subscribers("/uav1/achieved_rate") == 1
    assert pub.get_subscription_count() == 1


def test_domains_do_not_cross_talk(children, rt_context, another_domain):
    other = another_domain
    talker = children.start("talker")
    _wait_ready(talker)
    ctx = rt.Context()
    rt.init(args=["x"], context=ctx, domain_id=other)
    try:
        foreign = rt.Node("foreign", context=ctx)
        home = rt.Node("home", context=rt_context)
        string = get_message("std_msgs/msg/String")
        seen_foreign, seen_home = [], []
        foreign.create_subscription(string, "/chatter", seen_foreign.append, 10)
        home.create_subscription(string, "/chatter", seen_home.append, 10)
        ex = rt.SingleThreadedExecutor(context=ctx)
        ex.add_node(foreign)
        _spin_until(rt_context, home, lambda: len(seen_home) >= 5, 10)
        ex.spin_once(timeout_sec=0.3)
        assert len(seen_home) >= 5
        assert seen_foreign == []
    finally:
        ctx.try_shutdown()
