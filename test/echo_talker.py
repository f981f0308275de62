"""Publisher process for test_echo.py, on real rclpy; runs until killed.

    echo_talker.py formation [TOPIC]      one latched PoseArray (reliable, transient_local, depth 1)
    echo_talker.py diagnostics [TOPIC]    one latched DiagnosticArray
    echo_talker.py chatter [TOPIC]        std_msgs/String "hello N" every 50 ms (reliable, volatile)
    echo_talker.py sensor [TOPIC]         the same stream, best effort
    echo_talker.py silent [TOPIC]         a String publisher that never publishes

Prints "published" once the latched message is out or the stream's publisher exists.
"""
from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def formation() -> object:
    from geometry_msgs.msg import Pose, PoseArray

    msg = PoseArray()
    msg.header.stamp.sec, msg.header.stamp.nanosec = 12, 345
    msg.header.frame_id = "insar_track"
    for x in (0.0, 10.0, 20.0):
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = x, -5.5, 120.25
        pose.orientation.w = 1.0
        msg.poses.append(pose)
    return msg


def diagnostics() -> object:
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

    return DiagnosticArray(status=[DiagnosticStatus(name="link", message="ok")])


def main() -> None:
    mode = sys.argv[1]
    topic = sys.argv[2] if len(sys.argv) > 2 else {"formation": "/formation",
                                                   "diagnostics": "/diagnostics"}.get(mode,
                                                                                      "/chatter")
    rclpy.init()
    node = rclpy.create_node("echo_talker")
    if mode in ("formation", "diagnostics"):
        msg = formation() if mode == "formation" else diagnostics()
        node.create_publisher(type(msg), topic, LATCHED).publish(msg)
    else:
        from std_msgs.msg import String

        reliability = (ReliabilityPolicy.BEST_EFFORT if mode == "sensor"
                       else ReliabilityPolicy.RELIABLE)
        pub = node.create_publisher(String, topic,
                                    QoSProfile(depth=10, reliability=reliability))
        count = iter(range(sys.maxsize))
        if mode != "silent":
            node.create_timer(0.05, lambda: pub.publish(String(data=f"hello {next(count)}")))
    print("published", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == "__main__":
    main()
