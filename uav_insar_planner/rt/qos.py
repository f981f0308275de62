"""QoS profiles with rclpy's names, and their translation to Cyclone DDS QoS as
rmw_cyclonedds does it (create_readwrite_qos)."""
from __future__ import annotations

import enum
from dataclasses import dataclass

from cyclonedds.core import Policy
from cyclonedds.qos import Qos
from cyclonedds.util import duration


class ReliabilityPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2


class DurabilityPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2


class HistoryPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2


@dataclass
class QoSProfile:
    """The subset of rclpy.qos.QoSProfile our runtime maps to DDS (deadline, lifespan and
    liveliness stay at the ROS defaults: infinite / automatic)."""

    history: HistoryPolicy = HistoryPolicy.KEEP_LAST
    depth: int = 10
    reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE
    durability: DurabilityPolicy = DurabilityPolicy.VOLATILE

    def __init__(self, *, history: HistoryPolicy | None = None, depth: int | None = None,
                 reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE,
                 durability: DurabilityPolicy = DurabilityPolicy.VOLATILE) -> None:
        if history is None and depth is None:
            raise TypeError("QoSProfile needs a history or a depth, as in rclpy")
        self.history = HistoryPolicy(history if history is not None else HistoryPolicy.KEEP_LAST)
        self.depth = 10 if depth is None else int(depth)
        self.reliability = ReliabilityPolicy(reliability)
        self.durability = DurabilityPolicy(durability)
        if self.history == HistoryPolicy.KEEP_LAST and self.depth < 1:
            raise ValueError("KEEP_LAST needs depth >= 1")


qos_profile_system_default = QoSProfile(depth=10)
qos_profile_services_default = QoSProfile(depth=10)
qos_profile_parameters = QoSProfile(depth=1000)
qos_profile_parameter_events = QoSProfile(depth=1000)
qos_profile_sensor_data = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)


def as_profile(qos: QoSProfile | int) -> QoSProfile:
    """rclpy accepts a depth where a profile is expected."""
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, int) and not isinstance(qos, bool):
        return QoSProfile(depth=qos)
    raise TypeError(f"expected a QoSProfile or a history depth, got {qos!r}")


def to_dds(profile: QoSProfile, user_data: str, *, writer: bool) -> Qos:
    """Cyclone QoS for a ROS endpoint: as rmw_cyclonedds, plus XCDR1 forced on writers
    (rmw_cyclonedds reads only XCDR1)."""
    if profile.history == HistoryPolicy.KEEP_ALL:
        history = Policy.History.KeepAll
    else:
        history = Policy.History.KeepLast(profile.depth)
    policies = [
        history,
        Policy.WriterDataLifecycle(autodispose=False),
        Policy.Liveliness.Automatic(lease_duration=duration(infinite=True)),
        Policy.Userdata(data=user_data.encode()),
    ]
    if profile.reliability == ReliabilityPolicy.BEST_EFFORT:
        policies.append(Policy.Reliability.BestEffort)
    else:
        policies.append(Policy.Reliability.Reliable(max_blocking_time=duration(infinite=True)))
    if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL:
        # Without a matching durability service Cyclone replays only the last sample.
        policies += [Policy.Durability.TransientLocal, Policy.DurabilityService(
            cleanup_delay=0, history=history, max_samples=-1, max_instances=-1,
            max_samples_per_instance=-1)]
    else:
        policies.append(Policy.Durability.Volatile)
    if writer:
        policies.append(Policy.DataRepresentation(use_cdrv0_representation=True))
    return Qos(*policies)
