"""What every node of the suite shares: the latched plan QoS and the run-until-stopped loop."""
from __future__ import annotations

from collections.abc import Callable

from uav_insar_planner.seam import (
    DurabilityPolicy,
    ExternalShutdownException,
    HistoryPolicy,
    Node,
    QoSProfile,
    ReliabilityPolicy,
    rclpy,
)

# /formation and /formation/power: a late joiner (an agent started after the planner, or a
# planner restarted) still gets the last plan.
LATCHED = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
EXIT_BAD_PARAMS = 2


def run_node(make_node: Callable[[], Node], args: list[str] | None = None) -> int:
    """init, build the node, spin until Ctrl-C / SIGTERM, shut down; 0, or EXIT_BAD_PARAMS
    when the node found invalid parameters (its `problems`, one log line each) and so never
    started publishing. A node's optional `stop()` runs before it is destroyed."""
    rclpy.init(args=args)
    node = make_node()
    code = 0
    try:
        if node.problems:
            for line in node.problems:
                node.get_logger().error(line)
            code = EXIT_BAD_PARAMS
        else:
            rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop = getattr(node, "stop", None)
        if stop is not None:
            stop()
        node.destroy_node()
        rclpy.try_shutdown()
    return code
