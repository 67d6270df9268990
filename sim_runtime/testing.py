"""Helpers for launch-free tests of nodes in one process (ours, and our users')."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription

from sim_runtime.run import drain, make_executor

__all__ = ["Collector", "drain", "make_executor", "spin_until", "wait_for_match"]


def spin_until(executor, predicate: Callable[[], bool], timeout: float = 5.0) -> bool:
    """Spin ``executor`` until ``predicate()`` is true or ``timeout`` wall seconds pass."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.01)
    return True


def wait_for_match(executor, endpoint: Publisher | Subscription, count: int = 1, timeout: float = 5.0) -> bool:
    """Spin until a publisher has ``count`` subscribers, or a subscription ``count`` publishers."""
    if isinstance(endpoint, Publisher):
        return spin_until(executor, lambda: endpoint.get_subscription_count() >= count, timeout)
    return spin_until(executor, lambda: endpoint.get_publisher_count() >= count, timeout)


class Collector:
    """Subscribes to ``topic`` and keeps every message received, in order."""

    def __init__(self, node: Node, msg_type: Any, topic: str, qos: QoSProfile | int = 10) -> None:
        self.msgs: list[Any] = []
        self.subscription = node.create_subscription(msg_type, topic, self.msgs.append, qos)

    @property
    def last(self) -> Any:
        """The newest message, or None before the first one."""
        return self.msgs[-1] if self.msgs else None

    def clear(self) -> None:
        """Forget the messages received so far."""
        self.msgs.clear()
