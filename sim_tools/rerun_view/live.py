"""Live Rerun view of a running world or arm node (parameter ``rerun: true``; off by default).

:func:`attach_live_view` subscribes, inside the node's own process, to every topic the node
publishes (with the publisher's own QoS, so latched maps arrive) and, every few seconds, to other
topics of drawable types that appear in the graph (a controller's ``cmd_vel``…), and feeds each
message to the same :class:`~sim_tools.rerun_view.logger.RerunLogger` that ``bag_to_rerun`` uses.
"""

from __future__ import annotations

import copy
import functools
from dataclasses import dataclass, field
from typing import Any

import rerun as rr
from rclpy.node import Node

from sim_runtime.qos import ANY_PUBLISHER_QOS
from sim_tools.rerun_kit.ros import type_name
from sim_tools.rerun_view.convert import APPLICATION_ID
from sim_tools.rerun_view.logger import RerunLogger, supported_types

SUBSCRIPTION_DEPTH = 100
DISCOVERY_PERIOD = 2.0
"""Seconds (wall clock) between looks for new topics published by other nodes."""


@dataclass
class LiveView:
    """What :func:`attach_live_view` set up: the recording, the logger, the subscriptions."""

    node: Node
    recording: rr.RecordingStream
    logger: RerunLogger
    subscriptions: dict[str, Any] = field(default_factory=dict)
    message_count: int = 0
    _layout_sent: int = -1
    _timer: Any = None

    def subscribe(self, topic: str, msg_type: type, qos) -> None:
        """Draw ``topic`` (of ``msg_type``) from now on."""
        if topic in self.subscriptions or topic == "/clock":
            return
        self.logger.add_topics({topic: type_name(msg_type)})
        self.subscriptions[topic] = self.node.create_subscription(
            msg_type, topic, functools.partial(self._on_message, topic), qos
        )
        self.update_layout()

    def update_layout(self) -> None:
        """Send the blueprint again if a robot (its own tab) or a plot group appeared since."""
        if self.logger.layout_version != self._layout_sent:
            self._layout_sent = self.logger.layout_version
            self.recording.send_blueprint(self.logger.blueprint(), make_active=True, make_default=True)

    def discover(self) -> None:
        """Subscribe to drawable topics that other nodes publish (best effort: matches any publisher);
        update the layout."""
        self.update_layout()
        from sim_runtime.bag.reader import UnknownMessageType, message_class

        drawn = supported_types()
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self.subscriptions or len(types) != 1 or types[0] not in drawn:
                continue
            try:
                cls = message_class(types[0], topic)
            except UnknownMessageType:
                continue
            self.subscribe(topic, cls, ANY_PUBLISHER_QOS)

    def _on_message(self, topic: str, msg: object) -> None:
        sim_time = getattr(self.node, "sim_time", None)
        now_ns = int(round(sim_time * 1e9)) if sim_time is not None else self.node.get_clock().now().nanoseconds
        self.logger.log(topic, msg, now_ns)
        self.message_count += 1

    def close(self) -> None:
        """Stop drawing: drop the subscriptions and timer, flush the recording."""
        if self._timer is not None:
            self.node.destroy_timer(self._timer)
        for sub in self.subscriptions.values():
            self.node.destroy_subscription(sub)
        self.subscriptions.clear()
        self.recording.flush()


def attach_live_view(
    node: Node,
    spawn: bool = True,
    connect: str | None = None,
    *,
    recording: rr.RecordingStream | None = None,
    discover: bool = True,
) -> LiveView:
    """Stream ``node``'s topics to Rerun as they are published.

    Where the data goes: ``recording`` if given (tests pass one saving to a file), else a new
    recording connected to the viewer at ``connect`` (a gRPC URL such as
    ``rerun+http://127.0.0.1:9876/proxy``), else (``spawn``) a newly spawned viewer. With
    ``discover``, topics of other nodes of a drawable type are picked up as they appear.
    """
    if recording is None:
        recording = rr.RecordingStream(APPLICATION_ID, recording_id=None)
        if connect is not None:
            recording.connect_grpc(connect)
        elif spawn:
            recording.spawn()
    view = LiveView(node, recording, RerunLogger(recording))
    drawn = supported_types()
    for pub in list(node.publishers):
        if type_name(pub.msg_type) in drawn:
            # The publisher's own QoS (latched maps arrive), with room for the bursts of a world
            # stepped in bulk (node.step(n), real_time_factor 0).
            qos = copy.copy(pub.qos_profile)
            qos.depth = max(qos.depth, SUBSCRIPTION_DEPTH)
            # rclpy annotates Publisher.msg_type as a message instance; it holds the message class.
            view.subscribe(pub.topic_name, pub.msg_type, qos)  # type: ignore[arg-type]
    view.update_layout()
    if discover:
        view._timer = node.create_timer(DISCOVERY_PERIOD, view.discover)
    return view
