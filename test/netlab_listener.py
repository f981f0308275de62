"""Subscriber process for test_netlab.py, on real rclpy: prints "got <data>" for every
std_msgs/String on TOPIC (default /chatter, reliable, depth 10) until killed.

    netlab_listener.py [TOPIC]

Prints "ready" once its subscription exists.
"""
from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String


def main() -> None:
    topic = sys.argv[1] if len(sys.argv) > 1 else "/chatter"
    rclpy.init()
    node = rclpy.create_node("netlab_listener")
    node.create_subscription(String, topic, lambda msg: print(f"got {msg.data}", flush=True),
                             QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    print("ready", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == "__main__":
    main()
