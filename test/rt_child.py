"""Child processes for the runtime tests: `python rt_child.py MODE [args]`.

talker        publishes /formation (PoseArray, reliable transient_local depth 1) once, then
              String on /chatter every 50 ms; QOS=best_effort publishes /chatter best-effort
listener N    prints the first N /chatter strings as lines "got <data>", then exits
server        serves /planner/replan (std_srvs/Trigger), counting calls in the reply
caller        calls /planner/replan twice and prints the replies
params        declares the parameters of the params test and prints them as JSON
"""
from __future__ import annotations

import json
import os
import sys

from uav_insar_planner.seam import (
    DurabilityPolicy,
    ExternalShutdownException,
    FloatingPointRange,
    Node,
    ParameterDescriptor,
    QoSProfile,
    ReliabilityPolicy,
    msg_type,
    rclpy,
)

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def talker(node: Node) -> None:
    pose_array, pose, string = (msg_type("geometry_msgs/msg/PoseArray"),
                                msg_type("geometry_msgs/msg/Pose"), msg_type("std_msgs/msg/String"))
    formation = pose_array()
    formation.header.frame_id = "insar_track"
    formation.poses = [pose() for _ in range(3)]
    for k, p in enumerate(formation.poses):
        p.position.x, p.position.z = 10.0 * k, 50.0 + k
    node.create_publisher(pose_array, "/formation", LATCHED).publish(formation)
    best_effort = os.environ.get("QOS") == "best_effort"
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                     else ReliabilityPolicy.RELIABLE)
    chatter = node.create_publisher(string, "chatter", qos)
    count = iter(range(1, 10**9))
    node.create_timer(0.05, lambda: chatter.publish(string(data=f"hello {next(count)}")))
    print("ready", flush=True)
    rclpy.spin(node)


def listener(node: Node, n: str) -> None:
    got: list[str] = []

    def on_msg(msg: object) -> None:
        got.append(msg.data)
        print("got", msg.data, flush=True)

    node.create_subscription(msg_type("std_msgs/msg/String"), "/chatter", on_msg, 10)
    while len(got) < int(n):
        rclpy.spin_once(node, timeout_sec=1.0)


def server(node: Node) -> None:
    calls = [0]

    def on_call(_req: object, resp: object) -> object:
        calls[0] += 1
        resp.success, resp.message = True, f"call {calls[0]} served by {node.get_name()}"
        return resp

    node.create_service(msg_type("std_srvs/srv/Trigger"), "/planner/replan", on_call)
    print("ready", flush=True)
    rclpy.spin(node)


def caller(node: Node) -> None:
    trigger = msg_type("std_srvs/srv/Trigger")
    client = node.create_client(trigger, "/planner/replan")
    if not client.wait_for_service(timeout_sec=10.0):
        print("no service", flush=True)
        raise SystemExit(1)
    for _ in range(2):
        future = client.call_async(trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        print("reply", future.result().success, future.result().message, flush=True)


def params(node: Node) -> None:
    rng = ParameterDescriptor(floating_point_range=[
        FloatingPointRange(from_value=0.0, to_value=100.0, step=0.0)])
    node.declare_parameter("speed_mps", 4.3, rng)
    node.declare_parameter("num_slots", 80)
    node.declare_parameter("scheme", "proposed")
    node.declare_parameter("ground_station_m", [70.0, 149.37, 25.0])
    node.declare_parameter("bandwidth_hz", 1.0)
    values = {n: node.get_parameter(n).value for n in
              ("speed_mps", "num_slots", "scheme", "ground_station_m", "bandwidth_hz")}
    print(json.dumps({"node": node.get_fully_qualified_name(), "values": values}), flush=True)


MODES = {"talker": talker, "listener": listener, "server": server, "caller": caller,
         "params": params}


def main() -> int:
    mode = sys.argv[1]
    rclpy.init(args=sys.argv)
    extra = rclpy.utilities.remove_ros_args(sys.argv)[2:]
    node = Node("planner" if mode == "params" else mode)
    try:
        MODES[mode](node, *extra)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
