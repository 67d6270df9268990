"""SIMROBOT's spec: the facts about its robots that more than one part of the project reads.

A SIMROBOT robot is described by its world file (shape, sensors, colour), so what is fixed here is
how a sensor's mount follows from that description, how frames and topics are named, and the
names of the world's markers and state message. The model, the world node (``/tf_static``), the
Rerun views and the studio read them from here. Lengths in metres, angles in radians.

>>> from simrobot_sim.world_file import RobotSpec, SensorSpec
>>> sensor_mount(RobotSpec("r1", (0.0, 0.0), scale=2.0), SensorSpec("s", "ultrasonic", (0.05, 0.01), 0.3))
(0.1, 0.02, 0.3)
>>> frame_name("sim1/", "r1", "s")
'sim1/r1/s'
"""

from __future__ import annotations

from typing import Protocol


class _Scaled(Protocol):
    """What a mount needs of a robot (world_file.RobotSpec): the spec imports nothing of the
    simulator, whose world file reads its names from here."""

    @property
    def scale(self) -> float: ...


class _Mounted(Protocol):
    """What a mount needs of a sensor (world_file.SensorSpec)."""

    @property
    def position(self) -> tuple[float, float]: ...

    @property
    def axis(self) -> float: ...


# ------------------------------------------------------------------------------ topics and markers
# Relative names: the world's resolve under its namespace (``/sim1/robots``), a robot's under the
# robot's name there (``/sim1/r1/odom``: :func:`robot_topic`).
MAP_TOPIC = "map"
"""The bitmap as a latched OccupancyGrid (in the world's namespace)."""
ROBOTS_TOPIC = "robots"
"""MarkerArray of every robot's outline (in the world's namespace)."""
ROBOTS_NS = "robots"
"""Namespace of the outlines on ``robots``; marker ``i`` outlines robot ``i``."""
ROBOT_STATES_TOPIC = "robot_states"
"""Float64MultiArray of the whole world in one message: sim time, robot and sensor counts, then
``ROBOT_STATE_FIELDS`` numbers per robot, then each sensor's nearest hit."""
ROBOT_STATE_FIELDS = 5
"""Numbers per robot in ``robot_states``: x, y, heading, crashed, power."""
CMD_VEL_TOPIC = "cmd_vel"
"""A robot's velocity command (Twist, or TwistStamped with ``cmd_vel_stamped``)."""
WHEEL_CMD_TOPIC = "wheel_cmd"
"""A robot's wheel speeds as the original's algorithms set them (JointState ``velocity`` [left, right])."""
ODOM_TOPIC = "odom"
"""A robot's odometry (Odometry); also the leaf of its odometry frame."""
POSE_TOPIC = "pose"
"""A robot's true pose in the map (PoseStamped)."""
CRASHED_TOPIC = "crashed"
"""Whether a robot is stopped by a collision (latched Bool)."""
POWER_TOPIC = "power"
"""Whether a robot's power is on (latched Bool)."""
SET_POWER_SERVICE = "set_power"
"""Switches a robot's power (SetBool)."""
CLEAR_CRASH_SERVICE = "clear_crash"
"""Lets a crashed robot move again (Trigger)."""
ROBOT_ENDPOINTS = (
    CMD_VEL_TOPIC,
    WHEEL_CMD_TOPIC,
    ODOM_TOPIC,
    POSE_TOPIC,
    CRASHED_TOPIC,
    POWER_TOPIC,
    SET_POWER_SERVICE,
    CLEAR_CRASH_SERVICE,
)
"""Every topic and service leaf under a robot's name: no sensor may be called so."""
OBSTACLE_SUFFIX = "obstacle"
"""An ultrasonic sensor ``<robot>/<sensor>`` also publishes the obstacle it sees on
``<robot>/<sensor>/obstacle``."""


# ------------------------------------------------------------------------------ frames and mounts
FOOTPRINT_FRAME = "base_footprint"
"""REP-120's ground projection of each robot's ``base_link`` (``<robot>/base_footprint``): a
planar robot's ``base_link`` is on the floor, so a fixed identity transform below it."""


def sensor_mount(robot: _Scaled, sensor: _Mounted) -> tuple[float, float, float]:
    """Where ``sensor`` sits on ``robot``'s base_link: x, y (m) and axis (rad). The position is on
    the body, so it scales with the robot (its range does not)."""
    return sensor.position[0] * robot.scale, sensor.position[1] * robot.scale, sensor.axis


def robot_topic(robot: str, leaf: str) -> str:
    """Topic or service ``leaf`` (one of ``ROBOT_ENDPOINTS`` or a sensor's name) of ``robot``,
    relative to the world's namespace: ``r1/odom``."""
    return f"{robot}/{leaf}"


def frame_name(prefix: str, robot: str, leaf: str) -> str:
    """Frame ``leaf`` (``base_link``, ``odom`` or a sensor's name) of ``robot``, with the world's
    ``prefix`` in front: ``sim1/r1/sens1``."""
    return f"{prefix}{robot}/{leaf}"
