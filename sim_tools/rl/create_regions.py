"""Which places of a Create map the robot can drive between: the floor split into regions.

Random starts and goals (:mod:`sim_tools.rl.create_nav`) are drawn clear of the walls, but a place
inside a closed box is clear too: a goal there cannot be reached. The floor is cut into
``cell_m`` squares; a square is free when the body fits on its centre; free squares that touch
(sides, not corners) form one region.
"""

from __future__ import annotations

import functools
from collections import deque
from collections.abc import Sequence

import numpy as np

from create_sim.geometry import nearest_distance

#: Size of the squares the floor is cut into (m).
REGION_CELL_M = 0.05


class FloorRegions:
    """The free squares of a map (``walls``: (n, 4) segments) for a disc of ``radius_m``, labelled."""

    def __init__(self, walls: np.ndarray, radius_m: float, cell_m: float = REGION_CELL_M) -> None:
        segs = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
        self.cell_m = cell_m
        self.lo = np.minimum(segs[:, :2].min(axis=0), segs[:, 2:].min(axis=0)) if len(segs) else np.zeros(2)
        hi = np.maximum(segs[:, :2].max(axis=0), segs[:, 2:].max(axis=0)) if len(segs) else np.zeros(2)
        nx, ny = (np.ceil((hi - self.lo) / cell_m).astype(int) + 1).tolist()
        xs = (self.lo[0] + (np.arange(nx) + 0.5) * cell_m).tolist()
        ys = (self.lo[1] + (np.arange(ny) + 0.5) * cell_m).tolist()
        free = np.array([[nearest_distance(segs, x, y) >= radius_m for y in ys] for x in xs], dtype=bool)
        self.labels = _label(free)

    def region(self, x: float, y: float) -> int:
        """The region of the square under (x, y); -1: not free, or outside the walls' box."""
        i, j = np.floor((np.array([x, y]) - self.lo) / self.cell_m).astype(int).tolist()
        if not (0 <= i < self.labels.shape[0] and 0 <= j < self.labels.shape[1]):
            return -1
        return int(self.labels[i, j])

    def connected(self, a: Sequence[float], b: Sequence[float]) -> bool:
        """Whether the robot can drive from ``a`` to ``b`` (x, y each): free squares of one region."""
        region = self.region(a[0], a[1])
        return region >= 0 and region == self.region(b[0], b[1])


def _label(free: np.ndarray) -> np.ndarray:
    """One label per 4-connected component of ``free`` (-1 elsewhere), by breadth-first search."""
    labels = np.full(free.shape, -1, dtype=np.int64)
    nx, ny = free.shape
    count = 0
    for start in zip(*np.nonzero(free), strict=True):
        if labels[start] >= 0:
            continue
        labels[start] = count
        queue = deque([start])
        while queue:
            i, j = queue.popleft()
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if 0 <= a < nx and 0 <= b < ny and free[a, b] and labels[a, b] < 0:
                    labels[a, b] = count
                    queue.append((a, b))
        count += 1
    return labels


@functools.lru_cache(maxsize=16)
def map_regions(map_file: str, radius_m: float) -> FloorRegions:
    """The regions of a map file, computed once per process (many envs share a map)."""
    from create_sim.mapfile import load_map

    return FloorRegions(load_map(map_file).walls, radius_m)
