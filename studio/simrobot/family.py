"""The SIMROBOT family (:class:`studio.shell.app.Family`): the SIMROBOT page and its world
editor, the SIMROBOT client on the studio's node, and the SIMROBOT worlds the studio started."""

from __future__ import annotations

from collections.abc import Sequence

from studio.shell.app import Family, Register, Studio
from studio.shell.ros import StudioRos
from studio.simrobot.ros_client import SimrobotRos


class SimrobotFamily(Family[SimrobotRos]):
    name = "simrobot"

    def __init__(self, pages: Sequence[Register] = ()) -> None:
        super().__init__(pages)
        self.selected: str | None = None  # the world last picked or started: a new tab's default

    def make_client(self, ros: StudioRos) -> SimrobotRos:
        return SimrobotRos(ros)


def side(studio: Studio) -> SimrobotFamily:
    """The studio's SIMROBOT family: what both SIMROBOT pages share."""
    return studio.family(SimrobotFamily)
