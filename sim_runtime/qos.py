"""The QoS profiles every node uses, named for who uses them (REP-2003).

Publishers of sensor data and state are reliable and volatile (the system default): a reliable
publisher serves both reliable subscribers (``create_subscription(..., 10)``, RViz, Nav2) and
best-effort ones. Subscribers to sensors take :data:`SENSOR_SUBSCRIBER_QOS` (best effort), which
matches any publisher. Maps, robot descriptions and ``/tf_static`` are latched (transient local).
Commands are reliable both ways (:func:`create_command_subscription`); a best-effort command
publisher is heard once the world is started with
``-p qos_overrides./cmd_vel.subscription.reliability:=best_effort``.
"""

import copy
from collections.abc import Callable
from typing import Any

from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.subscription import Subscription

from sim_runtime.errors import InputError

#: Sensor and state publishers: reliable and volatile (REP-2003's system default), keeping the
#: last 100 samples rather than 10: a reliable reader that falls behind (a recorder on a busy
#: machine while a world runs at real_time_factor 0, 20x real time) loses nothing until it is 100
#: messages late, not 10. Measured by the soak: 1.4 % of a Create world's messages missing from
#: its bag at depth 10, 0.03 % at 100; the depth is no part of QoS matching.
SENSOR_PUBLISHER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Lets users change a sensor publisher's QoS at start, as with any rclcpp/rclpy driver:
#: ``-p qos_overrides./scan.publisher.reliability:=best_effort`` (read-only parameters).
SENSOR_QOS_OVERRIDES = QoSOverridingOptions(
    policy_kinds=(QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY)
)


#: What rclpy raises for an override it cannot apply (a wrong type, an unknown policy name).
_OVERRIDE_ERRORS = (AssertionError, AttributeError, RuntimeError, TypeError, ValueError, ParameterException)


def create_sensor_publisher(node: Node, msg_type: type, topic: str) -> Publisher:
    """A sensor or state publisher of ``node`` (:data:`SENSOR_PUBLISHER_QOS`) whose history, depth
    and reliability users may override at start with ``qos_overrides.<topic>.publisher.*``; an
    override rclpy cannot apply is an :class:`InputError` naming the topic."""
    try:  # a copy: rclpy writes the overrides into the profile it is given
        return node.create_publisher(
            msg_type, topic, copy.copy(SENSOR_PUBLISHER_QOS), qos_overriding_options=SENSOR_QOS_OVERRIDES
        )
    except _OVERRIDE_ERRORS as err:
        raise InputError(f"parameter 'qos_overrides' of {node.resolve_topic_name(topic)}: {err}") from None


#: Subscribers to sensor streams: best effort, keep last 5 (SensorDataQoS); matches any publisher.
SENSOR_SUBSCRIBER_QOS: QoSProfile = qos_profile_sensor_data

#: Publishers of commands (controllers, teleop, clients): every message matters.
COMMAND_PUBLISHER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Subscribers to commands (the worlds' cmd_vel, wheel_cmd, set_pose, the arm's inputs): reliable,
#: as ``ros2 topic pub``, teleop_twist_keyboard and Nav2 publish commands. A best-effort reader
#: drops a sample from a writer it has not matched yet and nothing resends it; a reliable one asks
#: for it once it has matched. ``ros2 topic pub --once`` from a fresh process (publish as soon as
#: its writer matched, exit 0.1 s later), load 13-25 on 2 cores: 77 of 100 arrived best effort,
#: 89 of 100 reliable; the rest left with their process before the world had discovered it
#: (``bench/commands_arrive.py``).
#: A reliable reader does not match a best-effort writer: such publishers need the override
#: ``qos_overrides.<topic>.subscription.reliability:=best_effort`` on the world.
COMMAND_SUBSCRIBER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Lets users change a command subscription's QoS at start (read-only parameters):
#: ``-p qos_overrides./cmd_vel.subscription.reliability:=best_effort`` for a best-effort joystick.
COMMAND_QOS_OVERRIDES = QoSOverridingOptions(
    policy_kinds=(QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY)
)


def create_command_subscription(
    node: Node, msg_type: type, topic: str, callback: Callable[[Any], None]
) -> Subscription:
    """A command subscription of ``node`` (:data:`COMMAND_SUBSCRIBER_QOS`) whose history, depth and
    reliability users may override at start with ``qos_overrides.<topic>.subscription.*``; an
    override rclpy cannot apply is an :class:`InputError` naming the topic."""
    try:  # a copy: rclpy writes the overrides into the profile it is given
        subscription = node.create_subscription(
            msg_type, topic, callback, copy.copy(COMMAND_SUBSCRIBER_QOS), qos_overriding_options=COMMAND_QOS_OVERRIDES
        )
    except _OVERRIDE_ERRORS as err:
        raise InputError(f"parameter 'qos_overrides' of {node.resolve_topic_name(topic)}: {err}") from None
    # A world (SimWorldNode) also takes its commands between the steps of a catch-up burst.
    taken_between_steps = getattr(node, "command_subscriptions", None)
    if isinstance(taken_between_steps, list):
        taken_between_steps.append(subscription)
    return subscription


#: Maps, robot descriptions, /tf_static, crash flags: late joiners still get the last message.
LATCHED_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)

#: /tf: as tf2's transform broadcaster (reliable, volatile, a deep queue for bursts of frames).
TF_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: /clock: reliable like rosgraph's clock publishers; 100 samples, as the sensors, so that a
#: recorder's lost packet can be resent while the world runs ahead (depth is no part of matching).
CLOCK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Listeners that take whatever is published (live view, benchmarks): best effort and volatile
#: match every publisher, reliable or not; a deep queue rides out bursts.
ANY_PUBLISHER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
