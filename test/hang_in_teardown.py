"""FAULT INJECTION for tests, not a fake of anything real: a node whose teardown hangs, as an
agent's did once in CI past SIGINT and SIGTERM (where, unknown: rcl or the middleware).

    python test/hang_in_teardown.py

The node spins until Ctrl-C; its destroy_node then sleeps for a minute in `stuck_here`.
`run_node` must print every thread's stack, naming that function, and end the process with
code 0 within TEARDOWN_MAX_S and a little more.
"""
import sys
import time

from rclpy.node import Node

from uav_insar_planner.ros.run import run_node


def stuck_here() -> None:
    time.sleep(60.0)


class HangsInTeardown(Node):
    problems: list[str] = []

    def __init__(self) -> None:
        super().__init__("hangs_in_teardown")
        print("spinning", flush=True)

    def destroy_node(self) -> None:
        stuck_here()
        super().destroy_node()


if __name__ == "__main__":
    sys.exit(run_node(HangsInTeardown, "hangs_in_teardown", sys.argv))
