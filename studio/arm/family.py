"""The arm family (:class:`studio.shell.app.Family`): the Arm page, the arm client on the
studio's node, and the arm worlds the studio started."""

from __future__ import annotations

from studio.arm.ros_client import ArmRos
from studio.shell.app import Family
from studio.shell.ros import StudioRos


class ArmFamily(Family[ArmRos]):
    name = "arm"

    def make_client(self, ros: StudioRos) -> ArmRos:
        return ArmRos(ros)
