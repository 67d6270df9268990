"""The map maker's document: map elements with undo/redo, snapping and hit testing (no GUI here).

Elements are immutable tuples in world metres and radians; each edit replaces the element list
and pushes the old one on the undo stack, so undo/redo are exact.
"""

from __future__ import annotations

import itertools
import math
from typing import NamedTuple

import numpy as np

from create_sim.mapfile import CreateMap


class Segment(NamedTuple):
    """A wall (the robot cannot cross it) or a painted line (the cliff sensors see it)."""

    kind: str  # "wall" or "line"
    x1: float
    y1: float
    x2: float
    y2: float


class Beacon(NamedTuple):
    """A coloured beacon the camera sees; ``rgb`` in 0..1."""

    x: float
    y: float
    rgb: tuple[float, float, float]
    id: str


class VirtualWall(NamedTuple):
    """A virtual-wall emitter at (x, y) facing ``theta``; ``setting`` 1, 2 or 3 (range)."""

    x: float
    y: float
    theta: float
    setting: int


Element = Segment | Beacon | VirtualWall

UNDO_LIMIT = 200


def snap(value: float, step: float) -> float:
    """``value`` rounded to the grid ``step`` (0 = no snapping); rounded to 1e-9 so 0.1 stays 0.1."""
    if step <= 0.0:
        return value
    return round(round(value / step) * step, 9)


def rectangle(x1: float, y1: float, x2: float, y2: float) -> list[Segment]:
    """Four walls with vertical and horizontal sides, corners at two opposite points."""
    corners = [(x1, y1), (x2, y1), (x2, y2), (x1, y2)]
    return [Segment("wall", *corners[i], *corners[(i + 1) % 4]) for i in range(4)]


def polyline(points: list[tuple[float, float]], kind: str = "wall") -> list[Segment]:
    """Segments from each point to the next (the multi-segment wall tool)."""
    return [Segment(kind, *a, *b) for a, b in itertools.pairwise(points) if a != b]


def _point_segment_distance(px: float, py: float, s: Segment) -> float:
    dx, dy = s.x2 - s.x1, s.y2 - s.y1
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else max(0.0, min(1.0, ((px - s.x1) * dx + (py - s.y1) * dy) / length2))
    return math.hypot(px - (s.x1 + t * dx), py - (s.y1 + t * dy))


def distance_to(element: Element, x: float, y: float) -> float:
    """Distance (m) from (x, y) to the element as drawn (segment, or the beacon/emitter point)."""
    if isinstance(element, Segment):
        return _point_segment_distance(x, y, element)
    return math.hypot(x - element.x, y - element.y)


def moved(element: Element, dx: float, dy: float) -> Element:
    """The element shifted by (dx, dy)."""
    if isinstance(element, Segment):
        return element._replace(x1=element.x1 + dx, y1=element.y1 + dy, x2=element.x2 + dx, y2=element.y2 + dy)
    return element._replace(x=element.x + dx, y=element.y + dy)


class MapDocument:
    """The element list being edited, with undo and redo."""

    def __init__(self) -> None:
        self.elements: list[Element] = []
        self._undo: list[list[Element]] = []
        self._redo: list[list[Element]] = []

    # ---------------------------------------------------------------- edits (each one undoable)
    def _edit(self, elements: list[Element]) -> None:
        self._undo.append(self.elements)
        del self._undo[:-UNDO_LIMIT]
        self._redo.clear()
        self.elements = elements

    def add(self, *elements: Element) -> None:
        """Append elements (one undo step for all of them)."""
        if elements:
            self._edit([*self.elements, *elements])

    def replace(self, index: int, element: Element) -> None:
        """Put ``element`` in place of the one at ``index`` (the edit form, a move)."""
        new = list(self.elements)
        new[index] = element
        self._edit(new)

    def remove(self, index: int) -> None:
        """Delete the element at ``index``."""
        self._edit([e for i, e in enumerate(self.elements) if i != index])

    def clear(self) -> None:
        """Delete everything (undoable, unlike the original's Clear)."""
        if self.elements:
            self._edit([])

    def load(self, world: CreateMap) -> None:
        """Replace the document with a parsed map (undoable)."""
        self._edit(elements_from_map(world))

    def undo(self) -> bool:
        """Go back one edit; False when there is nothing to undo."""
        if not self._undo:
            return False
        self._redo.append(self.elements)
        self.elements = self._undo.pop()
        return True

    def redo(self) -> bool:
        """Redo the last undone edit; False when there is nothing to redo."""
        if not self._redo:
            return False
        self._undo.append(self.elements)
        self.elements = self._redo.pop()
        return True

    # ---------------------------------------------------------------- queries
    def nearest(self, x: float, y: float, tolerance: float) -> int | None:
        """Index of the element closest to (x, y) within ``tolerance`` metres, or None."""
        best, best_d = None, tolerance
        for i, element in enumerate(self.elements):
            d = distance_to(element, x, y)
            if d <= best_d:
                best, best_d = i, d
        return best

    def next_beacon_id(self) -> str:
        """``b1``, ``b2``, …: the first id of that form not yet used (the original's default ids)."""
        used = {e.id for e in self.elements if isinstance(e, Beacon)}
        n = 1
        while f"b{n}" in used:
            n += 1
        return f"b{n}"

    def to_map(self) -> CreateMap:
        """The document as a :class:`CreateMap` (each kind in drawing order)."""
        return map_from_elements(self.elements)


def elements_from_map(world: CreateMap) -> list[Element]:
    """A parsed map as editor elements: walls, lines, beacons, virtual walls, in file order per kind."""
    elements: list[Element] = [Segment("wall", *map(float, w)) for w in world.walls]
    elements += [Segment("line", *map(float, w)) for w in world.lines]
    for xy, rgb, beacon_id in zip(world.beacon_xy, world.beacon_rgb, world.beacon_ids, strict=True):
        r, g, b = (float(c) for c in rgb)
        elements.append(Beacon(float(xy[0]), float(xy[1]), (r, g, b), beacon_id))
    elements += [VirtualWall(float(x), float(y), float(t), int(s)) for x, y, t, s in world.virtwalls]
    return elements


def map_from_elements(elements: list[Element]) -> CreateMap:
    """Editor elements as a :class:`CreateMap` (what the map file writer takes)."""
    segments = {
        kind: [e[1:] for e in elements if isinstance(e, Segment) and e.kind == kind] for kind in ("wall", "line")
    }
    beacons = [e for e in elements if isinstance(e, Beacon)]
    vwalls = [e for e in elements if isinstance(e, VirtualWall)]
    return CreateMap(
        walls=np.array(segments["wall"], dtype=np.float64).reshape(-1, 4),
        lines=np.array(segments["line"], dtype=np.float64).reshape(-1, 4),
        beacon_xy=np.array([(b.x, b.y) for b in beacons], dtype=np.float64).reshape(-1, 2),
        beacon_rgb=np.array([b.rgb for b in beacons], dtype=np.float64).reshape(-1, 3),
        beacon_ids=[b.id for b in beacons],
        virtwalls=np.array([tuple(v) for v in vwalls], dtype=np.float64).reshape(-1, 4),
    )
