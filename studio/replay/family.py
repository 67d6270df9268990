"""The Replay family (:class:`studio.shell.app.Family`): the Replay page, which reads bags
from the workspace: it follows no world on ROS and starts none."""

from __future__ import annotations

from studio.shell.app import Family, FamilyClient
from studio.shell.ros import StudioRos


class ReplayFamily(Family[FamilyClient]):
    name = "replay"

    def make_client(self, ros: StudioRos) -> None:
        return None
