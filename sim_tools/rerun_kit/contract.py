"""What a simulator's drawing declares: the ``rerun`` part of its adapter, read by the kit.

The contract as a whole (what an adapter's ``rerun`` module holds and how the views use it) is
documented in :mod:`sim_tools.rerun_view.logger`; this module holds its types.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar, NamedTuple

import numpy as np
import rerun as rr

from sim_tools.rerun_kit.tf import Mount

Handler = Callable[[Any, str, Any], None]
"""Draws one message: ``(drawer, topic, msg)``; ``drawer`` is the :class:`~sim_tools.rerun_kit.drawer.Drawer`."""


def dot(color: tuple[int, int, int]) -> rr.AsComponents:
    """A robot's body as a dot: a world's outline is a few pixels across at map zoom."""
    return rr.Points2D([[0.0, 0.0]], radii=rr.Radius.ui_points(5.0), colors=[color], draw_order=38)


@dataclass(frozen=True)
class RobotLook:
    """How a simulator's robots are drawn; lengths in metres on the map."""

    body: Callable[[tuple[int, int, int]], rr.AsComponents]
    """The body in the robot's frame, in the robot's colour."""
    heading_m: float
    """Length of the heading arrow (until the world's outline says the robot's size)."""
    heading_width_ui: float
    """Its width in UI points (thin on a small robot, not to hide its dot)."""
    label_offset_m: float
    """The label hangs this far below the centre (on screen), clear of the body."""
    follow_half_width_m: float
    """Half the width of the view following the robot: what its sensors reach."""
    mounts: Mapping[str, Mount] = field(default_factory=dict)
    """Sensor frame leaf → mount, for a bag without ``/tf_static``."""


DEFAULT_LOOK = RobotLook(body=dot, heading_m=0.1, heading_width_ui=1.5, label_offset_m=0.07, follow_half_width_m=0.6)
"""A robot no simulator claims (and SIMROBOT's, whose world outlines it): a dot, a short heading
arrow, a view 1.2 m wide (its sonars reach 0.3 m)."""


class PlotTab(NamedTuple):
    """One tab of the plots: its key (``plots/<key>/…``), title with units, y range (None: the
    data's), and rank (tabs are shown by rank)."""

    key: str
    title: str
    y_range: tuple[float, float] | None
    rank: int


class DetectorStyle(NamedTuple):
    """How a detector's switching is shown: its event level and whether it is a contact (drawn
    red, and marked on the map where it happened)."""

    level: rr.TextLogLevel
    contact: bool


class Outline(NamedTuple):
    """A robot's outline drawn by its world: where and in which colour."""

    centre: np.ndarray
    color: tuple[int, int, int]
    size_m: float
    number: int
    """The robot's obstacle number (what others' sensors report seeing it as)."""


def outline_at(outlines: list[Outline], x: float, y: float, within_m: float) -> Outline | None:
    """The outline whose centre is nearest (x, y), if within ``within_m``."""
    if not outlines:
        return None
    dist = [math.hypot(o.centre[0] - x, o.centre[1] - y) for o in outlines]
    best = int(np.argmin(dist))
    return outlines[best] if dist[best] <= within_m else None


class SimulatorDrawing:
    """A simulator's part in the Rerun views. Its adapter's ``rerun`` module holds one as
    ``DRAWING``; every attribute and method has a default meaning "nothing of its own".

    Topic names below are last segments (``overhead_pose`` matches ``/r1/overhead_pose``)."""

    look: ClassVar[RobotLook | None] = None
    """How the robots it owns (:meth:`owns_robot`) are drawn."""
    truth_pose_topics: ClassVar[tuple[str, ...]] = ()
    """PoseStamped topics that are a robot's ground-truth pose (odometry is compared with it)."""
    map_marker_topics: ClassVar[tuple[str, ...]] = ()
    """MarkerArray topics that are the map: static, drawn as ``top/map/<topic>/<ns>/<id>``, and
    the extent of the map views."""
    wall_namespaces: ClassVar[tuple[str, ...]] = ()
    """Namespaces of the map's walls: faded markers are cut at their extent."""
    faded_markers: ClassVar[Mapping[str, float]] = MappingProxyType({})
    """Marker namespace → opacity: drawn faint, thin and cut at the walls."""
    static_marker_topics: ClassVar[tuple[str, ...]] = ()
    """Latched MarkerArray topics (a scene): static, visible at every time."""
    path_topics: ClassVar[tuple[str, ...]] = ()
    """PoseStamped topics drawn in 3-D with the path they followed (an end effector)."""
    outline_topics: ClassVar[tuple[str, ...]] = ()
    """MarkerArray topics outlining the robots in their colours (see :meth:`outlines`): robots
    wait for their colour until their outline is seen."""
    outline_match_m: ClassVar[float] = 0.0
    """An outline belongs to the robot whose pose is nearest its centre, within this."""
    quiet_topics: ClassVar[tuple[str, ...]] = ()
    """Topics with nothing to draw, skipped without a warning."""
    plot_tabs: ClassVar[tuple[PlotTab, ...]] = ()
    """Plot tabs of its own quantities (those of the message families are the kit's)."""
    handlers: ClassVar[Mapping[tuple[str | None, str], Handler]] = MappingProxyType({})
    """``(topic, pkg/msg/Type)`` → how it is drawn, instead of the kit's family for that type;
    ``(None, type)``: every topic of that type that no drawing claims by name."""
    legend_3d: ClassVar[str | None] = None
    """The legend of a 3-D world (markdown)."""

    def owns_robot(self, namespace: str, topics: Mapping[str, str]) -> bool:
        """Whether the robot in ``namespace`` (``""``: the root) is one of its robots, drawn with
        :attr:`look`; ``topics`` is every topic known (name → type)."""
        return False

    def outlines(self, markers: Iterable[Any]) -> list[Outline]:
        """The robots' outlines in a message of an :attr:`outline_topics` topic."""
        return []

    def scan_colors(self, msg: Any, hit: np.ndarray) -> np.ndarray | None:
        """Colours (N, 3) of a LaserScan's hits (``hit``: which ranges are), if its intensities say more."""
        return None

    def detector_style(self, name: str) -> DetectorStyle | None:
        """How the detector ``name`` (a frame or topic leaf) is shown, if it is one of its kinds."""
        return None

    def grid_shade(self, topics: Mapping[str, str]) -> int | None:
        """Grey (0–255) of an OccupancyGrid's occupied cells in a world with ``topics``."""
        return None

    def legend_notes(self, leaves: set[str]) -> list[str]:
        """Notes on the robots' labels, for a world with topics ending in ``leaves``."""
        return []

    def legend_lines(self, topics: Mapping[str, str]) -> list[tuple[int, str]]:
        """Legend lines (rank, markdown) of what it draws, for a world with ``topics``."""
        return []
