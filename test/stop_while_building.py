"""FAULT INJECTION for tests, not a fake of anything real: a node whose constructor is cut by
Ctrl-C the way CI once saw the planner's (the signal came after the node was on the graph and
before its constructor had made its last publisher).

    python test/stop_while_building.py

The constructor sends its own process SIGINT and waits until rclpy's handler has shut the
context down. The KeyboardInterrupt Python raises for that signal is swallowed here, because
in the case seen in CI it arrived later, after the next publisher had already failed. Then it
creates a publisher, which fails with RCLError "context is invalid". `run_node` must take that
for the stop it is: exit 0, no traceback.
"""
import os
import signal
import sys
import time

import rclpy
from rclpy.node import Node
from std_msgs.msg import String

from uav_insar_planner.ros.run import run_node


class CutWhileBuilding(Node):
    problems: list[str] = []

    def __init__(self) -> None:
        super().__init__("cut_while_building")
        try:
            os.kill(os.getpid(), signal.SIGINT)
            end = time.monotonic() + 10.0
            while rclpy.ok() and time.monotonic() < end:
                time.sleep(0.01)
        except KeyboardInterrupt:
            pass
        end = time.monotonic() + 10.0
        while rclpy.ok() and time.monotonic() < end:
            time.sleep(0.01)
        print("context shut down" if not rclpy.ok() else "context still up", flush=True)
        self.create_publisher(String, "after_the_signal", 1)


if __name__ == "__main__":
    sys.exit(run_node(CutWhileBuilding, "cut_while_building", sys.argv))
