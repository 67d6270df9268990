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
        self.controllers: dict[str, Child] = {}  # namespace → its controller (a node, or a bridge and Octave)
        self.stopping: dict[str, Child] = {}  # namespace → controller Stop was pressed for, until it has ended
        self.selected: str | None = None  # the Create last picked or started: every page's default

    def children(self) -> list[Child]:
        return [*self.controllers.values(), *self.worlds.values(), *self.stopping.values()]

    def default_robot(self, names: list[str], current: str | None) -> str | None:
        """What a robot selector shows: its current choice, else the studio's, else the first."""
        for choice in (current, self.selected):
            if choice in names:
                return choice
        return names[0] if names else None

    def make_client(self, ros: StudioRos) -> CreateRos:
        return CreateRos(ros)


def create_family(studio: Studio) -> CreateFamily:
    return studio.family(CreateFamily)


def create_ros(studio: Studio) -> CreateRos | None:
    """The studio's Create client (None until the app has started)."""
    return studio.family(CreateFamily).client
