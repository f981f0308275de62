"""The suite's ROS interface in one place: topic names, the frame id and the QoS of each.

Names are relative (a namespace moves the whole swarm) except /diagnostics. A node of one UAV
(an agent, a bridge given `uav_id`) may also run in that UAV's own namespace, as a stack on the
UAV's computer does (`-r __ns:=/uav1`): `swarm_namespace` finds the swarm's namespace above it
and `resolve` names its topics absolutely, so they stay /uav1/pose and /formation. Frame
`insar_track`: x = range / across-track, y = azimuth / along-track, z = up; SI on every topic.
A plan is `formation` + `formation/power` under one identity, validated wherever it enters
(ros/plan_msgs.py); agents and the bridge apply one plan at a time, of the sole planner on the
domain (ros/plan_gate.py).
"""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from uav_insar_planner.swarm import UAVS, uav_name

FRAME_ID = "insar_track"
# A plan's identity (ros/plan_msgs.py): formation's header.stamp, and the same stamp with the
# planner's name in the power message's third layout dimension, "plan /planner <sec>.<ns>".
FORMATION = "formation"  # geometry_msgs/PoseArray, LATCHED; header.stamp = the plan's stamp
POWER = "formation/power"  # std_msgs/Float64MultiArray [uav, slot, plan id], LATCHED
# std_msgs/Header, LATCHED: stamp = the pass's wall-clock start (time.time(); not ROS time),
# frame_id = the identity label of the plan it starts (ros/start_msgs.py)
FORMATION_START = "formation/start"
MARKERS = "formation/markers"  # visualization_msgs/MarkerArray, LATCHED: the plan (markers.py)
FLOWN_MARKERS = "formation/markers/flown"  # visualization_msgs/MarkerArray, depth 10: agents
DIAGNOSTICS = "/diagnostics"  # diagnostic_msgs/DiagnosticArray, depth 10
REPLAN = "~/replan"  # std_srvs/Trigger
# std_msgs/Header, GCS_HEARTBEAT_QOS, every param_specs.GCS_HEARTBEAT_PERIOD_S from the
# planner: stamp = its wall clock, frame_id = its fully qualified name (ros/gcs_link.py).
GCS_HEARTBEAT = "gcs/heartbeat"

# /formation, /formation/power and uavK/plan: a late joiner (an agent started after the
# planner, or a planner restarted) still gets the last plan, and which plan each agent flies.
LATCHED = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
# gcs/heartbeat over a lossy radio: best effort (a lost heartbeat is not worth resending,
# and one resent late would hide a silence), volatile (a late joiner must not take an old
# heartbeat for a live ground station), depth 1 (only the newest matters).
GCS_HEARTBEAT_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                               reliability=ReliabilityPolicy.BEST_EFFORT,
                               durability=DurabilityPolicy.VOLATILE)
# One rate per slot, each one counts: a history deep enough that a subscriber stalled for a
# few seconds (a busy 2-core host, a planner restarting) still gets them all.
RATE_DEPTH = 100
DEPTH = 10


def pose(k: int) -> str:
    """geometry_msgs/PoseStamped: agent k's actual position."""
    return f"{uav_name(k)}/pose"


def achieved_rate(k: int) -> str:
    """std_msgs/Float64: bit/s agent k achieved in the slot just flown (RATE_DEPTH)."""
    return f"{uav_name(k)}/achieved_rate"


#: The fields of one `offload(k)` message, in order (its layout's single dimension label).
OFFLOAD_FIELDS = ("slot", "power_w", "energy_used_j", "energy_left_j")


def offload(k: int) -> str:
    """std_msgs/Float64MultiArray: agent k's slot just started, data = OFFLOAD_FIELDS (power
    applied [W], energy used so far this slot included and left of E_com^max [J]),
    RATE_DEPTH."""
    return f"{uav_name(k)}/offload"


def flown_plan(k: int) -> str:
    """std_msgs/String, LATCHED: the identity label of the plan agent k flies
    ("plan /planner <sec>.<nanosec>"), published each time it adopts one (ros/plan_gate.py)."""
    return f"{uav_name(k)}/plan"


def mavlink_pose(k: int) -> str:
    """geometry_msgs/PoseStamped: vehicle k's LOCAL_POSITION_NED in the track frame (bridge)."""
    return f"{uav_name(k)}/mavlink/pose"


def mavlink_claim(k: int) -> str:
    """std_msgs/String, LATCHED: "claim <bridge node> <sec>.<nanosec>", the bridge that flies
    vehicle k and its wall-clock start (ros/claims.py: the oldest claim flies)."""
    return f"{uav_name(k)}/mavlink/claim"


def swarm_namespace(node_namespace: str, k: int | None) -> str:
    """The namespace of the swarm's topics for a node in `node_namespace` flying UAV `k`
    (None: the whole swarm): the node's own, or its parent when it is the UAV's own
    (/uav1 or /field/uav1 for k = 1). ValueError (one line) when it is another UAV's, whose
    topics the node would then publish."""
    ns = "/" + node_namespace.strip("/")
    parent, _, last = ns.rpartition("/")
    if k is not None and last == uav_name(k):
        return parent or "/"
    names = {uav_name(j) for j in UAVS}
    if last in names:
        raise ValueError(f"namespace: {ns!r} is another UAV's; expected {uav_name(k)!r} "
                         f"(its own) or the swarm's namespace" if k is not None else
                         f"namespace: {ns!r} is one UAV's; expected the swarm's namespace "
                         "for a node of the whole swarm, or uav_id")
    return ns


def resolve(swarm_ns: str, name: str) -> str:
    """The absolute name of topic `name` (as the constants and functions above give it)
    in the swarm namespace `swarm_ns`; absolute names (/diagnostics) stay."""
    if name.startswith("/"):
        return name
    return swarm_ns.rstrip("/") + "/" + name


def matching_qos(offered: Sequence[QoSProfile], depth: int) -> QoSProfile:
    """The QoS of a subscriber that matches every offered profile and loses nothing they keep,
    as `ros2 topic echo` and `ros2 bag record` choose it: reliable only if every publisher is,
    transient_local only if every publisher is (so a late subscriber gets latched topics)."""
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    latched = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
