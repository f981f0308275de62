"""The suite's ROS interface in one place: topic names, the frame id and the QoS of each, and
`INTERFACE`, the registry of every topic and service with its type, QoS, publishers and
subscribers (the documentation's topics page is generated from it; test_topic_registry.py
compares it with what the running nodes create).

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

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from uav_insar_planner.param_specs.nodes import GCS_HEARTBEAT_PERIOD_S
from uav_insar_planner.swarm import uav_index, uav_name

FRAME_ID = "insar_track"
FORMATION = "formation"
POWER = "formation/power"
FORMATION_START = "formation/start"
MARKERS = "formation/markers"
FLOWN_MARKERS = "formation/markers/flown"
DIAGNOSTICS = "/diagnostics"
REPLAN = "~/replan"
NEXT_SORTIE = "~/next_sortie"
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
#: The profiles INTERFACE names, under the names the nodes pass to rclpy (an int is rclpy's
#: shorthand for a reliable, volatile, keep-last profile of that depth).
QOS_PROFILES: dict[str, QoSProfile] = {
    "LATCHED": LATCHED, "GCS_HEARTBEAT_QOS": GCS_HEARTBEAT_QOS,
    "DEPTH": QoSProfile(depth=DEPTH), "RATE_DEPTH": QoSProfile(depth=RATE_DEPTH)}
def pose(k: int) -> str:
    """Agent k's actual position (INTERFACE has the type and QoS of this and the below)."""
    return f"{uav_name(k)}/pose"


def achieved_rate(k: int) -> str:
    """The bit/s agent k achieved in the slot just flown."""
    return f"{uav_name(k)}/achieved_rate"


#: The fields of one `offload(k)` message, in order (its layout's single dimension label);
#: `strip` is the survey strip the slot belongs to (plan_msgs: the formation's), -1 for a
#: single pass.
OFFLOAD_FIELDS = ("slot", "power_w", "energy_used_j", "energy_left_j", "strip")


def offload(k: int) -> str:
    """Agent k's slot just started: data = OFFLOAD_FIELDS."""
    return f"{uav_name(k)}/offload"


def flown_plan(k: int) -> str:
    """The identity label of the plan agent k flies."""
    return f"{uav_name(k)}/plan"


def mavlink_pose(k: int) -> str:
    """Vehicle k's position from its autopilot, in the track frame."""
    return f"{uav_name(k)}/mavlink/pose"


def mavlink_claim(k: int) -> str:
    """The claims of the bridges that would fly vehicle k (ros/claims.py)."""
    return f"{uav_name(k)}/mavlink/claim"


@dataclass(frozen=True)
class TopicSpec:
    """One topic or service of the suite. `name` as the nodes create it: relative, `~/` for
    a node's own, `{k}` for the UAV of a per-UAV topic (`uav{k}/pose`); `msg_type` as ROS
    spells it (`pkg/msg/Type`; `pkg/srv/Type` makes it a service); `qos` the key in
    QOS_PROFILES of the publishers' profile (empty for a service); `publishers` and
    `subscribers` the executables that create them (for a service: servers and clients)."""

    name: str
    msg_type: str
    qos: str
    publishers: tuple[str, ...]
    subscribers: tuple[str, ...]
    description: str

    @property
    def is_service(self) -> bool:
        return "/srv/" in self.msg_type

    @property
    def per_uav(self) -> bool:
        return "{k}" in self.name

    def profile(self) -> QoSProfile | None:
        """The publishers' QoS profile (None for a service)."""
        return QOS_PROFILES[self.qos] if self.qos else None

    def names(self, uavs: Iterable[int]) -> tuple[str, ...]:
        """The names as created: one per UAV of `uavs` (e.g. swarm.uavs(params.num_uavs))
        for a per-UAV topic."""
        return tuple(self.name.format(k=k) for k in uavs) if self.per_uav else (self.name,)


_PLANNER, _AGENT, _BRIDGE = ("planner",), ("agent",), ("mavlink_bridge",)
#: Every topic and service the suite's nodes create (the tools echo and record subscribe to
#: whatever they are given; rclpy's own /rosout, /parameter_events and parameter services are
#: not listed).
INTERFACE: tuple[TopicSpec, ...] = (
    TopicSpec(FORMATION, "geometry_msgs/msg/PoseArray", "LATCHED", _PLANNER,
              _AGENT + _BRIDGE,
              "the plan: poses[k] = target (x_k, 0, z_k) of UAV k, NaN x and z for a UAV not "
              "flown; header.stamp = the plan's stamp, its identity (ros/plan_msgs.py); "
              "header.frame_id = insar_track, or the survey strip it flies (`insar_track: "
              "strip i, sortie j, attempt a[, last]; heading ...; origin ...; length ...; "
              "station ...`, in that strip's frame). Only feasible plans are published"),
    TopicSpec(POWER, "std_msgs/msg/Float64MultiArray", "LATCHED", _PLANNER, _AGENT + _BRIDGE,
              "P_com[k][n] [W], row-major; layout [uav, slot, plan id]: the third dimension's "
              "label is the plan's identity, `plan /planner <sec>.<nanosec>`"),
    TopicSpec(FORMATION_START, "std_msgs/msg/Header", "LATCHED", _PLANNER, _AGENT + _BRIDGE,
              "the pass start, once every flown UAV's uav{k}/mavlink/pose is within "
              "capture_radius_m of its entry: stamp = the wall-clock start (time.time(), "
              "not ROS time), frame_id = the identity label of the plan it starts, with "
              "` at <metres> m` where the targets wait for it: the run-in's entry before the "
              "start line (negative), or past it for a pass that resumes mid-track (a "
              "planner started again, a swarm held behind its clock: ros/start_msgs.py); "
              "the one mission clock: a bridge flies its pass from it "
              "(pass_start planner, the default), an agent on a bridge-flown vehicle starts "
              "its slots by it (a self-flown agent keeps its own clock and does not subscribe)"),
    TopicSpec(MARKERS, "visualization_msgs/msg/MarkerArray", "LATCHED", _PLANNER, (),
              "the plan for RViz / Foxglove in frame insar_track (ros/markers.py)"),
    TopicSpec(FLOWN_MARKERS, "visualization_msgs/msg/MarkerArray", "DEPTH", _PLANNER, (),
              "each agent's latest uav{k}/pose and the path it flew (ros/markers.py)"),
    TopicSpec(GCS_HEARTBEAT, "std_msgs/msg/Header", "GCS_HEARTBEAT_QOS", _PLANNER, _BRIDGE,
              f"the ground station is alive, every {GCS_HEARTBEAT_PERIOD_S:g} s: stamp = the "
              "planner's wall clock, frame_id = the label of its current plan (plan /planner "
              "SEC.NANOSEC), before the first its full node name (ros/gcs_link.py); a bridge "
              "with gcs_timeout_s holds without it, and after such a hold waits for the plan it "
              "names"),
    TopicSpec(DIAGNOSTICS, "diagnostic_msgs/msg/DiagnosticArray", "DEPTH", _PLANNER + _BRIDGE,
              _PLANNER, "the planner's plan, formation publishers, swarm and per-UAV statuses; "
              "the bridge's per-vehicle link statuses, which the planner's swarm watch reads"),
    TopicSpec("uav{k}/pose", "geometry_msgs/msg/PoseStamped", "DEPTH", _AGENT, _PLANNER,
              "agent k's actual position, with its disturbance"),
    TopicSpec("uav{k}/achieved_rate", "std_msgs/msg/Float64", "RATE_DEPTH", _AGENT, _PLANNER,
              "bit/s agent k achieved in the slot just flown, one message per slot"),
    TopicSpec("uav{k}/offload", "std_msgs/msg/Float64MultiArray", "RATE_DEPTH", _AGENT,
              _PLANNER, f"agent k's slot just started, data = [{', '.join(OFFLOAD_FIELDS)}]: "
              "power applied [W], energy used so far, this slot included, and left of "
              "E_com^max [J]; one message per slot"),
    TopicSpec("uav{k}/plan", "std_msgs/msg/String", "LATCHED", _AGENT, _PLANNER,
              "the identity label of the plan agent k flies (`plan /planner <sec>.<nanosec>`), "
              "each time it adopts one (ros/plan_gate.py)"),
    TopicSpec("uav{k}/mavlink/pose", "geometry_msgs/msg/PoseStamped", "DEPTH", _BRIDGE,
              _PLANNER + _AGENT,
              "vehicle k's LOCAL_POSITION_NED in the track frame; the planner's pass start "
              "reads it, and an agent with position_source autopilot"),
    TopicSpec("uav{k}/mavlink/claim", "std_msgs/msg/String", "LATCHED", _BRIDGE, _BRIDGE,
              "`claim <bridge node> <sec>.<nanosec>`: a bridge that would fly vehicle k and its "
              "wall-clock start; the oldest claim flies (ros/claims.py)"),
    TopicSpec(REPLAN, "std_srvs/srv/Trigger", "", _PLANNER, (),
              "solve again with the current parameters"),
    TopicSpec(NEXT_SORTIE, "std_srvs/srv/Trigger", "", _PLANNER, (),
              "a survey (survey_file): the next sortie may go (the batteries changed); "
              "refused, saying why, while a sortie flies, before the survey began, after its "
              "last, or without survey_file"),
)


def swarm_namespace(node_namespace: str, k: int | None) -> str:
    """The namespace of the swarm's topics for a node in `node_namespace` flying UAV `k`
    (None: the whole swarm): the node's own, or its parent when it is the UAV's own
    (/uav1 or /field/uav1 for k = 1). ValueError (one line) when it is another UAV's, whose
    topics the node would then publish."""
    ns = "/" + node_namespace.strip("/")
    parent, _, last = ns.rpartition("/")
    if k is not None and last == uav_name(k):
        return parent or "/"
    if uav_index(last) is not None:  # any swarm's uav0..uav(MAX_UAVS - 1)
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
