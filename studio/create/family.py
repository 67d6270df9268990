"""The Create family (:class:`studio.shell.app.Family`): the Simulator, Map maker and Config
maker pages, the Create client on the studio's node, and the Create worlds the studio started."""

from __future__ import annotations

from collections.abc import Sequence

from studio.create.ros_client import CreateRos
from studio.shell.app import Family, Register, Studio
from studio.shell.processes import Child
from studio.shell.ros import StudioRos


class CreateFamily(Family[CreateRos]):
    name = "create"

    def __init__(self, pages: Sequence[Register] = ()) -> None:
        super().__init__(pages)
        self.stopping: dict[str, Child] = {}  # namespace → controller Stop was pressed for, until it has ended

    def children(self) -> list[Child]:
        return [*self.worlds.values(), *self.stopping.values()]

    def make_client(self, ros: StudioRos) -> CreateRos:
        return CreateRos(ros)


def create_family(studio: Studio) -> CreateFamily:
    return studio.family(CreateFamily)


def create_ros(studio: Studio) -> CreateRos | None:
    """The studio's Create client (None until the app has started)."""
    return studio.family(CreateFamily).client
