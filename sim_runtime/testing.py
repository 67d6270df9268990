"""Helpers for launch-free tests of nodes in one process (ours, and our users')."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription

from sim_runtime.run import drain, make_executor

__all__ = ["WAIT_CEILING_S", "Collector", "TfBuffer", "drain", "make_executor", "spin_until", "wait_for_match"]

#: How long a wait gives up after, in wall seconds: a ceiling for a busy machine, not a speed
#: claim (a wait that succeeds returns as soon as its predicate holds).
WAIT_CEILING_S = 30.0


def spin_until(executor: Executor, predicate: Callable[[], bool], timeout: float = WAIT_CEILING_S) -> bool:
    """Spin ``executor`` until ``predicate()`` is true or ``timeout`` wall seconds pass."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.01)
    return True


def wait_for_match(
    executor: Executor, endpoint: Publisher | Subscription, count: int = 1, timeout: float = WAIT_CEILING_S
) -> bool:
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


class TfBuffer:
    """A small stand-in for tf2_ros's buffer in tests (tf2_ros is not on PyPI): keeps the latest
    transform of every frame from ``/tf`` and ``/tf_static`` and chains them.

    Use: ``buffer = TfBuffer(node)``, spin the node's executor, then
    ``buffer.transform_points("map", "laser", xy)``.
    """

    def __init__(self, node: Node) -> None:
        from tf2_msgs.msg import TFMessage

        from sim_runtime.qos import LATCHED_QOS, TF_QOS

        self.parent: dict[str, str] = {}
        self.matrix: dict[str, Any] = {}
        self.stamp: dict[str, float] = {}
        self.subscriptions = [
            node.create_subscription(TFMessage, "/tf", self._store, TF_QOS),
            node.create_subscription(TFMessage, "/tf_static", self._store, LATCHED_QOS),
        ]

    def _store(self, msg: Any) -> None:
        import numpy as np

        from sim_runtime.msgs import matrix_from_quaternion, time_from_msg

        for t in msg.transforms:
            m = np.eye(4)
            m[:3, :3] = matrix_from_quaternion(t.transform.rotation)
            tr = t.transform.translation
            m[:3, 3] = (tr.x, tr.y, tr.z)
            self.parent[t.child_frame_id] = t.header.frame_id
            self.matrix[t.child_frame_id] = m
            self.stamp[t.child_frame_id] = time_from_msg(t.header.stamp)

    def chain(self, frame: str) -> list[str]:
        """``frame`` and its ancestors up to the root of its tree."""
        out = [frame]
        while out[-1] in self.parent:
            out.append(self.parent[out[-1]])
            if len(out) > 100:
                raise ValueError(f"TF loop at {out[-1]!r}")
        return out

    def lookup(self, target: str, source: str) -> Any:
        """4x4 matrix mapping points in ``source`` to ``target`` (both frames must share a root)."""
        import numpy as np

        def to_root(frame: str) -> Any:
            m = np.eye(4)
            for f in self.chain(frame)[:-1]:
                m = self.matrix[f] @ m
            return m

        if self.chain(target)[-1] != self.chain(source)[-1]:
            raise LookupError(
                f"{source!r} and {target!r} are not connected: roots {self.chain(source)[-1]!r}, "
                f"{self.chain(target)[-1]!r}"
            )
        return np.linalg.inv(to_root(target)) @ to_root(source)

    def can_transform(self, target: str, source: str) -> bool:
        """Whether both frames are known and share a root."""
        return self.chain(target)[-1] == self.chain(source)[-1]
