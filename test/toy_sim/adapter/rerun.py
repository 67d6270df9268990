"""How the toy is drawn in the Rerun views (its adapter's ``rerun`` part; the contract is in
:mod:`sim_tools.rerun_view.logger`): a point robot whose only pose is its odometry, drawn as a
small triangle pointing ahead, with a view 3 m wide following it."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import rerun as rr

from sim_tools.rerun_kit.contract import RobotLook, SimulatorDrawing
from sim_tools.rerun_kit.ros import basename, namespace

POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "nav_msgs/msg/Odometry")
TRIANGLE_M = np.array([[0.12, 0.0], [-0.06, 0.06], [-0.06, -0.06], [0.12, 0.0]], dtype=np.float32)
"""The body: a closed triangle, tip forward (m, in the robot's frame)."""


def body(color: tuple[int, int, int]) -> rr.AsComponents:
    """The toy's triangle in its colour."""
    return rr.LineStrips2D([TRIANGLE_M], radii=rr.Radius.ui_points(2.0), colors=[color], draw_order=30)


LOOK = RobotLook(body=body, heading_m=0.2, heading_width_ui=1.0, label_offset_m=0.1, follow_half_width_m=1.5)


class ToyDrawing(SimulatorDrawing):
    """The toy's part of the views: its robots' look, nothing else of its own."""

    look = LOOK

    def owns_robot(self, namespace_: str, topics: Mapping[str, str]) -> bool:
        """A namespace whose one pose topic is ``odom``: the toy publishes nothing else."""
        poses = {basename(t) for t, kind in topics.items() if namespace(t) == namespace_ and kind in POSE_TYPES}
        return poses == {"odom"}


DRAWING = ToyDrawing()
