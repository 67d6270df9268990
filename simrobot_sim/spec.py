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

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the world file's specs import nothing from here: no cycle at run time
    from simrobot_sim.world_file import RobotSpec, SensorSpec

# ------------------------------------------------------------------------------ topics and markers
ROBOTS_TOPIC = "robots"
"""MarkerArray of every robot's outline (in the world's namespace)."""
ROBOTS_NS = "robots"
"""Namespace of the outlines on ``robots``; marker ``i`` outlines robot ``i``."""
ROBOT_STATES_TOPIC = "robot_states"
"""Float64MultiArray of the whole world in one message: sim time, robot and sensor counts, then
``ROBOT_STATE_FIELDS`` numbers per robot, then each sensor's nearest hit."""
ROBOT_STATE_FIELDS = 5
"""Numbers per robot in ``robot_states``: x, y, heading, crashed, power."""
OBSTACLE_SUFFIX = "obstacle"
"""An ultrasonic sensor ``<robot>/<sensor>`` also publishes the obstacle it sees on
``<robot>/<sensor>/obstacle``."""


# ------------------------------------------------------------------------------ frames and mounts
FOOTPRINT_FRAME = "base_footprint"
"""REP-120's ground projection of each robot's ``base_link`` (``<robot>/base_footprint``): a
planar robot's ``base_link`` is on the floor, so a fixed identity transform below it."""


def sensor_mount(robot: RobotSpec, sensor: SensorSpec) -> tuple[float, float, float]:
    """Where ``sensor`` sits on ``robot``'s base_link: x, y (m) and axis (rad). The position is on
    the body, so it scales with the robot (its range does not)."""
    return sensor.position[0] * robot.scale, sensor.position[1] * robot.scale, sensor.axis


def frame_name(prefix: str, robot: str, leaf: str) -> str:
    """Frame ``leaf`` (``base_link``, ``odom`` or a sensor's name) of ``robot``, with the world's
    ``prefix`` in front: ``sim1/r1/sens1``."""
    return f"{prefix}{robot}/{leaf}"
