"""What the parts of one Simulator tab share: the studio and the robot the tab has picked."""

from __future__ import annotations

from studio.create.family import create_family, create_ros
from studio.create.ros_client import CreateRos, RobotState
from studio.shell.app import Studio
from studio.shell.processes import Child


class SimTab:
    """One browser tab's choice of robot (``selected``, a namespace) and the client that reaches it."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.selected: str | None = None

    @property
    def ros(self) -> CreateRos:
        """The studio's Create client: the app makes it at start-up, before any page is served."""
        ros = create_ros(self.studio)
        if ros is None:
            raise RuntimeError("the studio's ROS client has not started")
        return ros

    @property
    def worlds(self) -> dict[str, Child]:
        """namespace → Create world the studio started (the Create family's table)."""
        return create_family(self.studio).worlds

    def robot(self) -> RobotState | None:
        """The selected robot's latest readings (None: none selected, or its world is not followed)."""
        ros = create_ros(self.studio)
        return None if ros is None or self.selected is None else ros.robots.get(self.selected)

    def picked(self) -> str | None:
        """The selected namespace while its world is followed (None: no robot to command)."""
        return self.selected if self.robot() is not None else None
