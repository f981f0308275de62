"""Publisher, Subscription and Timer with rclpy's API, on Cyclone DDS."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from .graph import gid_of
from .messages import type_hash
from .qos import QoSProfile, to_dds

ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any


def endpoint_user_data(ros_type: str, extra: str = "") -> str:
    return f"{extra}typehash={type_hash(ros_type)};"


class Publisher:
    """rclpy.publisher.Publisher."""

    def __init__(self, node: Any, msg_type: type, topic_name: str, qos: QoSProfile,
                 callback_group: Any) -> None:
        self.msg_type = msg_type
        self.topic_name = topic_name
        self.qos_profile = qos
        self.callback_group = callback_group
        topic = node.context.topic("rt" + topic_name, msg_type)
        self._writer = DataWriter(node.context.require_ok(), topic, to_dds(
            qos, endpoint_user_data(msg_type._ros_type), writer=True))
        self.gid = gid_of(self._writer)

    def publish(self, msg: Any) -> None:
        """Send one message; TypeError for a message of another type (as rclpy)."""
        if not isinstance(msg, self.msg_type):
            raise TypeError(f"expected {self.msg_type._ros_type}, got {type(msg).__name__}")
        self._writer.write(msg)

    def get_subscription_count(self) -> int:
        return len(self._writer.get_matched_subscriptions())

    def wait_for_all_acked(self, timeout_sec: float = -1) -> bool:
        ns = -1 if timeout_sec is None or timeout_sec < 0 else int(timeout_sec * 1e9)
        return bool(self._writer.wait_for_acks(ns if ns >= 0 else 2**63 - 1))

    def _entities(self) -> list[Any]:
        return [self._writer]

    def destroy(self) -> None:
        self._writer.__del__()


class Subscription:
    """rclpy.subscription.Subscription; the executor takes one sample per callback."""

    def __init__(self, node: Any, msg_type: type, topic_name: str, callback: Callable,
                 qos: QoSProfile, callback_group: Any) -> None:
        self.msg_type = msg_type
        self.topic_name = topic_name
        self.callback = callback
        self.qos_profile = qos
        self.callback_group = callback_group
        topic = node.context.topic("rt" + topic_name, msg_type)
        self._reader = DataReader(node.context.require_ok(), topic, to_dds(
            qos, endpoint_user_data(msg_type._ros_type), writer=False))
        self.condition = ReadCondition(self._reader, ANY_STATE)
        self.gid = gid_of(self._reader)

    def _take(self) -> Any:
        """The next valid message, or None."""
        while True:
            samples = self._reader.take(N=1)
            if not samples:
                return None
            if samples[0].sample_info.valid_data:
                return samples[0]

    def _execute(self, msg: Any) -> None:
        self.callback(msg)

    def get_publisher_count(self) -> int:
        return len(self._reader.get_matched_publications())

    def _entities(self) -> list[Any]:
        return [self._reader]

    def destroy(self) -> None:
        self.condition.__del__()
        self._reader.__del__()


class Timer:
    """rclpy.timer.Timer on the monotonic clock; a late timer skips missed periods."""

    def __init__(self, callback: Callable | None, period_sec: float, callback_group: Any,
                 autostart: bool = True) -> None:
        if period_sec <= 0:
            raise ValueError("timer period must be > 0")
        self.callback = callback
        self.callback_group = callback_group
        self.timer_period_ns = int(period_sec * 1e9)
        self._lock = threading.Lock()
        self._canceled = not autostart
        self._next = time.monotonic_ns() + self.timer_period_ns
        self._on_change: Callable[[], None] | None = None

    def next_call_ns(self) -> int | None:
        return None if self._canceled else self._next

    def is_ready(self) -> bool:
        return not self._canceled and time.monotonic_ns() >= self._next

    def _execute(self, _data: Any = None) -> None:
        with self._lock:
            now = time.monotonic_ns()
            self._next += self.timer_period_ns
            if self._next <= now:  # skip periods we missed instead of firing a burst
                self._next = now + self.timer_period_ns - (now - self._next) % self.timer_period_ns
        if self.callback is not None:
            self.callback()

    def cancel(self) -> None:
        self._canceled = True

    def is_canceled(self) -> bool:
        return self._canceled

    def reset(self) -> None:
        self._canceled = False
        self._next = time.monotonic_ns() + self.timer_period_ns
        if self._on_change:
            self._on_change()

    def time_until_next_call(self) -> int | None:
        return None if self._canceled else max(0, self._next - time.monotonic_ns())

    def time_since_last_call(self) -> int:
        return time.monotonic_ns() - (self._next - self.timer_period_ns)

    @property
    def timer_period_sec(self) -> float:
        return self.timer_period_ns / 1e9

    def destroy(self) -> None:
        self._canceled = True
