"""What the Arm page's parts share: the tab's choice of arm and the studio's arm client.

The page (:mod:`studio.arm.page`) is made of the joints (:mod:`~studio.arm.joints`), the target
pose and stored trajectories (:mod:`~studio.arm.motion`) and New arm world
(:mod:`~studio.arm.worlds`), each a part of the one page object over this base.
"""

from __future__ import annotations

import math

from nicegui import ui

from studio.arm.ros_client import ArmRos, ArmState
from studio.shell.app import Studio
from studio.shell.processes import Child


def made_arm_ros(studio: Studio) -> ArmRos | None:
    """The studio's arm client if it has been made."""
    made = studio.families.get("arm")
    return made if isinstance(made, ArmRos) else None


def arm_ros(studio: Studio) -> ArmRos | None:
    """The studio's arm client (made on first use, once the studio's ROS node runs)."""
    made = made_arm_ros(studio)
    if made is None and studio.ros is not None:
        made = studio.families["arm"] = ArmRos(studio.ros)
    return made


def arm_worlds(studio: Studio) -> dict[str, Child]:
    """namespace → arm world the studio started: a table of the arm family's own (the Create
    page shows the end of its own worlds only), which the studio's namespace checks and Ctrl-C see."""
    table = studio.families.get("arm_worlds")
    if not isinstance(table, dict):
        table = studio.families["arm_worlds"] = {}
        studio.family_worlds.append(table)
    return table


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
