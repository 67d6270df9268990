"""What the Arm page's parts share: the tab's choice of arm and the studio's arm client.

The page (:mod:`studio.arm.page`) is made of the joints (:mod:`~studio.arm.joints`), the target
pose and stored trajectories (:mod:`~studio.arm.motion`) and New arm world
(:mod:`~studio.arm.worlds`), each a part of the one page object over this base.
"""

from __future__ import annotations

import math

from nicegui import ui

from studio.arm.family import ArmFamily
from studio.arm.ros_client import ArmRos, ArmState
from studio.shell.app import Studio
from studio.shell.processes import Child


def arm_ros(studio: Studio) -> ArmRos | None:
    """The studio's arm client (None until the app has started)."""
    return studio.family(ArmFamily).client


def arm_worlds(studio: Studio) -> dict[str, Child]:
    """namespace → arm world the studio started: the arm family's own table (the Create page
    shows the end of its own worlds only), which the studio's namespace checks and Ctrl-C see."""
    return studio.family(ArmFamily).worlds


class ArmPageBase:
    """The state the parts share."""

    studio: Studio
    selected: str | None  # the arm's topic prefix
    built_joints: tuple = ()  # the layout the joint rows were built for ((): none built)
    last_command = -math.inf  # monotonic time of the last command (the sliders wait before following the arm)
    endings_shown: set[Child]
    arm_select: ui.select

    def ros(self) -> ArmRos | None:
        return arm_ros(self.studio)

    def arm(self) -> ArmState | None:
        ros = self.ros()
        return None if ros is None or self.selected is None else ros.arms.get(self.selected)

    def commanded(self) -> tuple[ArmRos, str] | None:
        """The client and the arm prefix a command goes to (None: no arm selected)."""
        ros = self.ros()
        if ros is None or self.selected is None or self.selected not in ros.arms:
            return None
        return ros, self.selected
