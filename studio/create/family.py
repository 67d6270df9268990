"""The Create family (:class:`studio.shell.app.Family`): the Simulator, Map maker and Config
maker pages, the Create client on the studio's node, and the Create worlds the studio started."""

from __future__ import annotations

from studio.create.ros_client import CreateRos
from studio.shell.app import Family, Studio
from studio.shell.ros import StudioRos


class CreateFamily(Family[CreateRos]):
    name = "create"

    def make_client(self, ros: StudioRos) -> CreateRos:
        return CreateRos(ros)


def create_family(studio: Studio) -> CreateFamily:
    return studio.family(CreateFamily)


def create_ros(studio: Studio) -> CreateRos | None:
    """The studio's Create client (None until the app has started)."""
    return studio.family(CreateFamily).client
