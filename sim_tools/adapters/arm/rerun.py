"""The arm in the Rerun views (its adapter's ``rerun`` part; the contract is in
:mod:`sim_tools.rerun_view.logger`): a 3-D world of meshes and markers, the flange's path, the
joints plotted as the arm's, and the legend of that world."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from arm_sim.spec import END_EFFECTOR_POSE_TOPIC, SCENE_MARKERS_TOPIC
from sim_tools.rerun_kit.contract import Handler, SimulatorDrawing
from sim_tools.rerun_kit.drawer import Drawer

LEGEND = (
    "**Arm**: meshes in their colours; axes x red, y green, z blue.\n\n"
    "- orange line: the flange's path (small axes: the flange now)\n"
    "- large axes with a name: a commanded target pose"
)


def draw_joints(view: Drawer, topic: str, msg) -> None:
    """An arm's joint states: positions, velocities and efforts, plotted as the ``arm``'s (in the
    root namespace)."""
    view.joints(topic, msg, "arm")


class ArmDrawing(SimulatorDrawing):
    """The arm's part of the views."""

    path_topics = (END_EFFECTOR_POSE_TOPIC,)
    static_marker_topics = (SCENE_MARKERS_TOPIC,)
    # Every JointState is an arm's (joint_states, and a controller's joint_command), but a topic
    # another simulator claims by name (SIMROBOT's wheel_cmd).
    handlers: ClassVar[Mapping[tuple[str | None, str], Handler]] = {(None, "sensor_msgs/msg/JointState"): draw_joints}
    legend_3d = LEGEND


DRAWING = ArmDrawing()
