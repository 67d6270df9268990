"""2-D geometry kernels for the Create world: ray casting against wall segments and circle contacts.

Walls are line segments ``(N, 4)`` float64 ``[x1, y1, x2, y2]``. Rays are culled with a uniform grid
(:class:`SegmentGrid`): each cell lists the segments that cross it, a ray walks the cells it passes
through (Amanatides–Woo) and stops as soon as its nearest hit lies inside the cell it has tested.
A per-call "mailbox" array keeps a segment that spans several cells from being tested twice.

Everything hot is a ``numba.njit(cache=True)`` kernel. The grid is a NamedTuple of arrays and
numbers that the kernels take as one argument (numba compiles its field accesses away). Every
kernel clamps the cell indices it computes to the grid, NaN and huge coordinates included, so no
input can make one read outside an array.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numba
import numpy as np

# A ray passing exactly through the shared endpoint of two walls must hit (no gaps at junctions).
_SEGMENT_PARAM_TOL = 1e-12
_PARALLEL_TOL = 1e-14


@numba.njit(cache=True, inline="always")
def ray_segment_distance(
    ox: float, oy: float, dx: float, dy: float, x1: float, y1: float, x2: float, y2: float, limit: float
) -> float:
    """Distance along the unit ray (ox, oy)+t(dx, dy), 0 ≤ t < limit, to the segment; else inf.

    ``limit`` (the nearest hit so far) lets a caster skip the second half of the test.
    """
    sx = x2 - x1
    sy = y2 - y1
    ax = x1 - ox
    ay = y1 - oy
    denom = dx * sy - dy * sx
    if abs(denom) <= _PARALLEL_TOL * (abs(sx) + abs(sy)):
        # Parallel: only a collinear segment lying ahead is hit, at its nearer end (edge-on wall).
        if abs(ax * dy - ay * dx) > 1e-12 * (1.0 + abs(ax) + abs(ay)):
            return np.inf
        t1 = ax * dx + ay * dy
        t2 = (x2 - ox) * dx + (y2 - oy) * dy
        lo = min(t1, t2)
        hi = max(t1, t2)
        if hi < 0.0 or max(lo, 0.0) >= limit:
            return np.inf
        return max(lo, 0.0)
    inv = 1.0 / denom
    t = (ax * sy - ay * sx) * inv
    if t < 0.0 or t >= limit:
        return np.inf
    u = (ax * dy - ay * dx) * inv
    if u < -_SEGMENT_PARAM_TOL or u > 1.0 + _SEGMENT_PARAM_TOL:
        return np.inf
    return t


@numba.njit(cache=True, inline="always")
def point_segment_closest(px: float, py: float, x1: float, y1: float, x2: float, y2: float):
    """Closest point on the segment to (px, py): returns (cx, cy, distance).

    When the closest point is an end of the segment it is that end exactly, so callers can tell a
    corner contact from a side contact by comparing with the end points.
    """
    sx = x2 - x1
    sy = y2 - y1
    len2 = sx * sx + sy * sy
    u = 0.0
    if len2 > 0.0:
        u = ((px - x1) * sx + (py - y1) * sy) / len2
    if u <= 0.0:
        return x1, y1, math.hypot(px - x1, py - y1)
    if u >= 1.0:
        return x2, y2, math.hypot(px - x2, py - y2)
    cx = x1 + u * sx
    cy = y1 + u * sy
    return cx, cy, math.hypot(px - cx, py - cy)


@numba.njit(cache=True)
def nearest_distance(segs, px, py) -> float:
    """Exact distance from (px, py) to the nearest segment, checking them all (inf if none)."""
    best = np.inf
    for s in range(segs.shape[0]):
        d = point_segment_closest(px, py, segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3])[2]
        if d < best:
            best = d
    return best


# ---------------------------------------------------------------------------------------------
# Uniform grid over segments
# ---------------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _segment_touches_box(x1, y1, x2, y2, bx0, by0, bx1, by1, eps) -> bool:
    """Separating-axis test of a segment against an axis-aligned box (grown by eps)."""
    if max(x1, x2) < bx0 - eps or min(x1, x2) > bx1 + eps:
        return False
    if max(y1, y2) < by0 - eps or min(y1, y2) > by1 + eps:
        return False
    nx = y2 - y1
    ny = x1 - x2
    scale = eps * (abs(nx) + abs(ny))
    f00 = (bx0 - x1) * nx + (by0 - y1) * ny
    f01 = (bx0 - x1) * nx + (by1 - y1) * ny
    f10 = (bx1 - x1) * nx + (by0 - y1) * ny
    f11 = (bx1 - x1) * nx + (by1 - y1) * ny
    if f00 > scale and f01 > scale and f10 > scale and f11 > scale:
        return False
    return not (f00 < -scale and f01 < -scale and f10 < -scale and f11 < -scale)


MAX_GRID_CELLS = 1_000_000
"""Upper bound on a segment grid's cell count (a huge sparse map gets coarser cells instead)."""


@numba.njit(cache=True, inline="always")
def _cell_index(coord: float, origin: float, cell: float, count: int, nudge: float) -> int:
    """Index of the cell holding ``coord`` (``nudge`` cells added first), clamped to 0..count-1.

    Clamped as a float before the int conversion, so NaN and coordinates far off the grid give a
    valid index instead of an undefined integer.
    """
    f = np.floor((coord - origin) / cell + nudge)  # a float: numba's math.floor gives an int
    if not f > 0.0:  # also NaN
        return 0
    if f >= count - 1:
        return count - 1
    return int(f)


@numba.njit(cache=True)
def _build_grid(segs, x0, y0, cell, nx, ny):
    """CSR lists (cell_start, cell_items) of the segments crossing each cell, cell = iy*nx + ix."""
    n = segs.shape[0]
    eps = cell * 1e-6
    counts = np.zeros(nx * ny + 1, dtype=np.int64)
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    items = np.empty(0, dtype=np.int32)
    fill = np.empty(0, dtype=np.int64)
    for pass_no in range(2):
        if pass_no == 1:
            for c in range(nx * ny):
                start[c + 1] = start[c] + counts[c]
            items = np.empty(start[nx * ny], dtype=np.int32)
            fill = start[:-1].copy()
        for s in range(n):
            x1, y1, x2, y2 = segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3]
            ix0 = _cell_index(min(x1, x2), x0, cell, nx, -1e-6)
            ix1 = _cell_index(max(x1, x2), x0, cell, nx, 1e-6)
            iy0 = _cell_index(min(y1, y2), y0, cell, ny, -1e-6)
            iy1 = _cell_index(max(y1, y2), y0, cell, ny, 1e-6)
            for iy in range(iy0, iy1 + 1):
                for ix in range(ix0, ix1 + 1):
                    bx0 = x0 + ix * cell
                    by0 = y0 + iy * cell
                    if _segment_touches_box(x1, y1, x2, y2, bx0, by0, bx0 + cell, by0 + cell, eps):
                        c = iy * nx + ix
                        if pass_no == 0:
                            counts[c] += 1
                        else:
                            items[fill[c]] = s
                            fill[c] += 1
    return start, items


@numba.njit(cache=True, inline="always")
def _clip_to_box(ox, oy, dx, dy, x0, y0, x1, y1, max_range):
    """Ray parameters (t_in, t_out) where a ray from outside the box [x0, x1] × [y0, y1] enters
    and leaves it within max_range (slab test); t_in > t_out when it misses."""
    t_in = 0.0
    t_out = max_range
    if dx != 0.0:
        ta = (x0 - ox) / dx
        tb = (x1 - ox) / dx
        t_in = max(t_in, min(ta, tb))
        t_out = min(t_out, max(ta, tb))
    elif ox < x0 or ox > x1:
        return np.inf, -np.inf
    if dy != 0.0:
        ta = (y0 - oy) / dy
        tb = (y1 - oy) / dy
        t_in = max(t_in, min(ta, tb))
        t_out = min(t_out, max(ta, tb))
    elif oy < y0 or oy > y1:
        return np.inf, -np.inf
    return t_in, t_out


@numba.njit(cache=True, inline="always")
def _first_boundary(o, d, i, origin, cell):
    """Along one axis, for a ray at ``o`` moving ``d`` per unit in cell ``i``: the cell step (±1,
    0 if it never crosses), the ray parameter at the next cell boundary and its increment per cell."""
    if d == 0.0:
        return 0, np.inf, np.inf
    inv = 1.0 / d
    step = 1 if d > 0.0 else -1
    t_max = (origin + (i + (1 if d > 0.0 else 0)) * cell - o) * inv
    return step, t_max, abs(cell * inv)


@numba.njit(cache=True)
def grid_cast(grid, mailbox, stamp, ox, oy, dx, dy, max_range) -> float:
    """Nearest hit of one unit ray within max_range (inf if none), walking the grid's cells.

    ``mailbox`` (one int64 per segment) holds the stamp of the last ray that tested each segment,
    so pass a new ``stamp`` for every ray.
    """
    nx = grid.nx
    ny = grid.ny
    if nx <= 0 or ny <= 0 or not (math.isfinite(ox) and math.isfinite(oy)):
        return np.inf
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return np.inf
    segs = grid.segments
    start = grid.cell_start
    items = grid.cell_items
    x0 = grid.origin_x_m
    y0 = grid.origin_y_m
    cell = grid.cell_m
    t_in = 0.0
    t_out = max_range
    if not (x0 <= ox <= x0 + nx * cell and y0 <= oy <= y0 + ny * cell):
        # Origin off the grid: clip the ray to the grid's box.
        t_in, t_out = _clip_to_box(ox, oy, dx, dy, x0, y0, x0 + nx * cell, y0 + ny * cell, max_range)
        if t_in > t_out:
            return np.inf
    ix = _cell_index(ox + dx * t_in, x0, cell, nx, 0.0)
    iy = _cell_index(oy + dy * t_in, y0, cell, ny, 0.0)
    step_x, t_max_x, t_delta_x = _first_boundary(ox, dx, ix, x0, cell)
    step_y, t_max_y, t_delta_y = _first_boundary(oy, dy, iy, y0, cell)
    best = np.inf
    # Each pass moves one cell, so nx + ny passes cross the whole grid (a bound for any input).
    for _ in range(nx + ny):
        c = iy * nx + ix
        for k in range(start[c], start[c + 1]):
            s = items[k]
            if mailbox[s] == stamp:
                continue
            mailbox[s] = stamp
            t = ray_segment_distance(ox, oy, dx, dy, segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3], best)
            if t < best:
                best = t
        t_exit = min(t_max_x, t_max_y)
        if best <= t_exit or t_exit > t_out:
            break
        if t_max_x < t_max_y:
            ix += step_x
            if ix < 0 or ix >= nx:
                break
            t_max_x += t_delta_x
        else:
            iy += step_y
            if iy < 0 or iy >= ny:
                break
            t_max_y += t_delta_y
    if best > max_range:
        return np.inf
    return best


@numba.njit(cache=True)
def grid_cast_fan(grid, ox, oy, heading, cos_off, sin_off, max_range):
    """Distances of rays from one origin at angles heading + offset (inf = no hit within range).

    Offsets come as their cosines and sines so a sensor's fixed fan needs no trigonometry per
    ray: each direction is the offset rotated by the heading.
    """
    n_rays = min(cos_off.shape[0], sin_off.shape[0])
    out = np.empty(n_rays)
    mailbox = np.full(grid.segments.shape[0], -1, dtype=np.int64)
    ch = math.cos(heading)
    sh = math.sin(heading)
    for i in range(n_rays):
        dx = ch * cos_off[i] - sh * sin_off[i]
        dy = sh * cos_off[i] + ch * sin_off[i]
        out[i] = grid_cast(grid, mailbox, i, ox, oy, dx, dy, max_range)
    return out


@numba.njit(cache=True)
def circle_crossing_angles(lines, cx, cy, radius, out):
    """World angles (seen from the centre) where segments cross the circle; returns how many.

    ``out`` needs room for 2 per segment (crossings beyond its size are dropped). A segment
    wholly inside or outside the circle gives none.
    """
    count = 0
    for s in range(lines.shape[0]):
        x1 = lines[s, 0] - cx
        y1 = lines[s, 1] - cy
        sx = lines[s, 2] - lines[s, 0]
        sy = lines[s, 3] - lines[s, 1]
        a = sx * sx + sy * sy
        if a == 0.0:
            continue
        b = 2.0 * (x1 * sx + y1 * sy)
        c = x1 * x1 + y1 * y1 - radius * radius
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            continue
        root = math.sqrt(disc)
        for u in ((-b - root) / (2.0 * a), (-b + root) / (2.0 * a)):
            if 0.0 <= u <= 1.0 and count < out.shape[0]:
                out[count] = math.atan2(y1 + u * sy, x1 + u * sx)
                count += 1
    return count


@numba.njit(cache=True)
def brute_cast_fan(segs, ox, oy, angles, max_range):
    """Reference caster: every ray against every segment (no culling)."""
    out = np.empty(angles.shape[0])
    for i in range(angles.shape[0]):
        dx = math.cos(angles[i])
        dy = math.sin(angles[i])
        best = np.inf
        for s in range(segs.shape[0]):
            t = ray_segment_distance(ox, oy, dx, dy, segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3], best)
            if t < best:
                best = t
        out[i] = best if best <= max_range else np.inf
    return out


class Contacts(NamedTuple):
    """Rows filled by :func:`grid_contacts`: one per wall near a point (room for every wall)."""

    point_x: np.ndarray  # closest point on the wall
    point_y: np.ndarray
    distance: np.ndarray  # from the query point to that closest point
    segment: np.ndarray  # int64 index of the wall
    at_end: np.ndarray  # bool: the closest point is an end of the wall (a corner), not its side


@numba.njit(cache=True)
def new_contacts(n_segments: int) -> Contacts:
    """Room for the contacts of a map with ``n_segments`` walls."""
    n = max(n_segments, 1)
    return Contacts(np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64), np.empty(n, np.bool_))


@numba.njit(cache=True)
def grid_contacts(grid, px, py, reach, out):
    """Closest points of every segment within ``reach`` of (px, py), into the Contacts ``out``.

    Returns how many rows were filled. Points off the grid are near nothing (the grid covers
    every segment); a NaN point is near nothing.
    """
    nx = grid.nx
    ny = grid.ny
    if nx <= 0 or ny <= 0 or not (math.isfinite(px) and math.isfinite(py) and reach >= 0.0):
        return 0
    segs = grid.segments
    start = grid.cell_start
    items = grid.cell_items
    x0 = grid.origin_x_m
    y0 = grid.origin_y_m
    cell = grid.cell_m
    if px + reach < x0 or px - reach > x0 + nx * cell or py + reach < y0 or py - reach > y0 + ny * cell:
        return 0
    ix0 = _cell_index(px - reach, x0, cell, nx, 0.0)
    ix1 = _cell_index(px + reach, x0, cell, nx, 0.0)
    iy0 = _cell_index(py - reach, y0, cell, ny, 0.0)
    iy1 = _cell_index(py + reach, y0, cell, ny, 0.0)
    capacity = out.segment.shape[0]
    count = 0
    for iy in range(iy0, iy1 + 1):
        for ix in range(ix0, ix1 + 1):
            c = iy * nx + ix
            for k in range(start[c], start[c + 1]):
                s = items[k]
                duplicate = False
                for j in range(count):
                    if out.segment[j] == s:
                        duplicate = True
                        break
                if duplicate:
                    continue
                x1, y1, x2, y2 = segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3]
                cx, cy, d = point_segment_closest(px, py, x1, y1, x2, y2)
                if d <= reach and count < capacity:
                    out.point_x[count] = cx
                    out.point_y[count] = cy
                    out.distance[count] = d
                    out.segment[count] = s
                    out.at_end[count] = (cx == x1 and cy == y1) or (cx == x2 and cy == y2)
                    count += 1
    return count


class SegmentGrid(NamedTuple):
    """Wall segments plus the uniform grid that culls them for rays and contact queries.

    Cell (ix, iy) covers ``[origin_x_m + ix·cell_m, … + cell_m) × [origin_y_m + iy·cell_m, …)``;
    its segments are ``cell_items[cell_start[c]:cell_start[c + 1]]`` with ``c = iy·nx + ix``.
    """

    segments: np.ndarray  # (N, 4) float64 [x1, y1, x2, y2]
    origin_x_m: float
    origin_y_m: float
    cell_m: float
    nx: int
    ny: int
    cell_start: np.ndarray  # (nx·ny + 1,) int64, CSR offsets into cell_items
    cell_items: np.ndarray  # int32 segment indices, grouped by cell

    @classmethod
    def build(cls, segs: np.ndarray, cell: float | None = None) -> SegmentGrid:
        """Grid over ``segs``; the default cell size puts about two cells per segment, ≥ 5 cm.

        The grid never has more than :data:`MAX_GRID_CELLS` cells (huge sparse maps get coarser
        cells). Segments must be finite: ValueError otherwise.
        """
        segs = np.ascontiguousarray(segs, dtype=np.float64).reshape(-1, 4)
        if segs.shape[0] == 0:
            return cls(segs, 0.0, 0.0, 1.0, 0, 0, np.zeros(1, np.int64), np.zeros(0, np.int32))
        if not np.isfinite(segs).all():
            raise ValueError("segment coordinates must be finite")
        lo = np.minimum(segs[:, :2].min(axis=0), segs[:, 2:].min(axis=0))
        hi = np.maximum(segs[:, :2].max(axis=0), segs[:, 2:].max(axis=0))
        extent = np.maximum(hi - lo, 1e-3)
        if not np.isfinite(extent).all():
            raise ValueError("segments span more than a float can hold")
        if cell is None:
            lengths = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])
            area = float(extent[0] * extent[1])
            cell = max(math.sqrt(area / (2.0 * segs.shape[0])), 0.5 * float(np.median(lengths)), 0.05)
            cell = min(cell, float(extent.max()))
        cell = float(cell)
        if not (math.isfinite(cell) and cell > 0.0):
            raise ValueError(f"grid cell size {cell} must be finite and > 0")
        # Keep the grid bounded for huge sparse maps (in floats first: the cell counts may not fit an int).
        while float(math.ceil(extent[0] / cell) + 1) * float(math.ceil(extent[1] / cell) + 1) > MAX_GRID_CELLS:
            cell *= 2.0
        shape = np.ceil(extent / cell).astype(np.int64) + 1
        origin = lo - 0.5 * (shape * cell - extent)
        nx, ny = int(shape[0]), int(shape[1])
        start, items = _build_grid(segs, float(origin[0]), float(origin[1]), cell, nx, ny)
        return cls(segs, float(origin[0]), float(origin[1]), cell, nx, ny, start, items)

    def cast(self, ox: float, oy: float, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distances from (ox, oy) along world ``angles``; inf where nothing is hit within range."""
        angles = np.asarray(angles, dtype=np.float64)
        return self.cast_fan(ox, oy, 0.0, np.cos(angles), np.sin(angles), max_range)

    def cast_fan(
        self, ox: float, oy: float, heading: float, cos_off: np.ndarray, sin_off: np.ndarray, max_range: float
    ) -> np.ndarray:
        """Like :meth:`cast` for a sensor's fixed fan: angles heading + offsets (as cos, sin)."""
        ranges: np.ndarray = grid_cast_fan(
            self, float(ox), float(oy), float(heading), cos_off, sin_off, float(max_range)
        )
        return ranges


def numpy_cast_fan(segs: np.ndarray, ox: float, oy: float, angles: np.ndarray, max_range: float) -> np.ndarray:
    """Vectorised numpy rays × segments matrix (the baseline the benchmark compares against)."""
    dx = np.cos(angles)[:, None]
    dy = np.sin(angles)[:, None]
    sx = (segs[:, 2] - segs[:, 0])[None, :]
    sy = (segs[:, 3] - segs[:, 1])[None, :]
    ax = (segs[:, 0] - ox)[None, :]
    ay = (segs[:, 1] - oy)[None, :]
    denom = dx * sy - dy * sx
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ax * sy - ay * sx) / denom
        u = (ax * dy - ay * dx) / denom
    hit = (denom != 0) & (t >= 0) & (u >= 0) & (u <= 1)
    dist: np.ndarray = np.where(hit, t, np.inf).min(axis=1)
    dist[dist > max_range] = np.inf
    return dist


# ---------------------------------------------------------------------------------------------
# Occupancy grid of the walls (for map consumers: RViz, planners, the studio)
# ---------------------------------------------------------------------------------------------

WALL_THICKNESS_M = 0.03
"""How thick a wall is drawn (RViz markers, the occupancy grid). To the physics and the sensors a
wall is a line, as in the original, which assumes walls 1-2 cm thick."""

MAX_MAP_CELLS = 16_000_000
"""Most cells an occupancy grid of the walls may have: a finer resolution over a huge map is
coarsened (doubled until it fits)."""

_PIECE_CELLS = 16.0  # long walls are rasterised in pieces this long, so each piece's box stays small


class WallRaster(NamedTuple):
    """Walls as occupancy: ``occupied[row, column]``, row 0 the lowest y (OccupancyGrid layout);
    cell (column, row) covers ``origin + resolution·[column, column + 1) × [row, row + 1)``."""

    occupied: np.ndarray  # (height, width) bool
    resolution_m: float
    origin_x_m: float
    origin_y_m: float


#: Walls rasterised per kernel call: between calls the caller's progress callback runs (a line
#: for a long start-up) and Python handles signals (a Ctrl-C is honoured within one chunk).
RASTER_CHUNK_WALLS = 20_000

Progress = Callable[[int, int], None]
"""Called as ``progress(done, total)`` between chunks of work (it may raise to stop it)."""


def rasterise_walls(
    segs: np.ndarray,
    resolution: float,
    thickness: float = WALL_THICKNESS_M,
    progress: Progress | None = None,
) -> WallRaster:
    """Every cell that a wall of ``thickness`` (centred on its segment) overlaps, however little:
    a wall never has a gap in the grid. Cell edges fall on multiples of the resolution; the grid
    spans the walls plus their half thickness (no walls: a 0 x 0 grid at the origin). A
    resolution giving more than :data:`MAX_MAP_CELLS` cells is doubled until it fits.

    The walls are marked by a numba kernel, :data:`RASTER_CHUNK_WALLS` at a time, ``progress``
    called after each chunk."""
    segs = np.ascontiguousarray(segs, dtype=np.float64).reshape(-1, 4)
    half = 0.5 * thickness
    if segs.shape[0] == 0:
        return WallRaster(np.zeros((0, 0), dtype=bool), resolution, 0.0, 0.0)
    occupied, origin, resolution = _raster_layout(segs, resolution, half)
    total = segs.shape[0]
    for start in range(0, total, RASTER_CHUNK_WALLS):
        chunk = segs[start : start + RASTER_CHUNK_WALLS]
        _mark_walls(occupied, chunk, float(origin[0]), float(origin[1]), resolution, half, _PIECE_CELLS * resolution)
        if progress is not None:
            progress(start + chunk.shape[0], total)
    return WallRaster(occupied, resolution, float(origin[0]), float(origin[1]))


@numba.njit(cache=True)
def _mark_walls(occupied, segs, ox, oy, resolution, half, longest):  # pragma: no cover - numba
    """Mark every wall of ``segs`` (cut into pieces at most ``longest`` long, as np.linspace cuts
    them) in ``occupied``: the kernel of :func:`rasterise_walls`, the same cells as
    :func:`_rasterise_reference`."""
    height, width = occupied.shape
    limit = half * (1.0 + 1e-9)
    for k in range(segs.shape[0]):
        x1, y1, x2, y2 = segs[k, 0], segs[k, 1], segs[k, 2], segs[k, 3]
        n = max(int(math.ceil(math.hypot(x2 - x1, y2 - y1) / longest)), 1)
        step = 1.0 / n
        ax, ay = x1, y1
        for j in range(n):
            u = 1.0 if j + 1 == n else (j + 1) * step  # np.linspace(0, 1, n + 1)[j + 1]
            bx, by = x1 + u * (x2 - x1), y1 + u * (y2 - y1)
            _mark_piece_kernel(occupied, height, width, ax, ay, bx, by, ox, oy, resolution, half, limit)
            ax, ay = bx, by


@numba.njit(cache=True, inline="always")
def _mark_piece_kernel(occupied, height, width, x1, y1, x2, y2, ox, oy, resolution, half, limit):  # pragma: no cover
    c0x = max(int(math.floor((min(x1, x2) - half - ox) / resolution)) - 1, 0)
    c0y = max(int(math.floor((min(y1, y2) - half - oy) / resolution)) - 1, 0)
    c1x = min(int(math.floor((max(x1, x2) + half - ox) / resolution)) + 1, width - 1)
    c1y = min(int(math.floor((max(y1, y2) + half - oy) / resolution)) + 1, height - 1)
    h = 0.5 * resolution
    nx, ny = y2 - y1, x1 - x2  # the line's normal: the square meets the line if its corners straddle it
    reach = h * (abs(nx) + abs(ny))
    mx, my = 0.5 * (x1 + x2), 0.5 * (y1 + y2)
    wx, wy = h + 0.5 * abs(x2 - x1), h + 0.5 * abs(y2 - y1)
    # A square is at least (|side| - reach) / length from the line: beyond this (with a margin
    # for rounding) it is too far from the segment as well, and the exact test is skipped.
    far = reach + limit * math.hypot(nx, ny) * (1.0 + 1e-6) + 1e-12
    dx, dy = x2 - x1, y2 - y1
    margin = limit + h  # half a cell more than can matter: rounding never drops a cell
    for row in range(c0y, c1y + 1):
        cy = oy + (row + 0.5) * resolution
        # Only the columns near the part of the piece within reach of this row (a diagonal
        # piece's box is mostly empty); every cell kept still takes the exact test below.
        ya, yb = cy - h - margin, cy + h + margin
        if dy == 0.0:
            if y1 < ya or y1 > yb:
                continue
            xa, xb = min(x1, x2), max(x1, x2)
        else:
            ta, tb = (ya - y1) / dy, (yb - y1) / dy
            t0, t1 = max(min(ta, tb), 0.0), min(max(ta, tb), 1.0)
            if t0 > t1:
                continue
            xa, xb = min(x1 + t0 * dx, x1 + t1 * dx), max(x1 + t0 * dx, x1 + t1 * dx)
        first = max(c0x, int(math.floor((xa - margin - ox) / resolution)) - 1)
        last = min(c1x, int(math.floor((xb + margin - ox) / resolution)) + 1)
        for col in range(first, last + 1):
            if occupied[row, col]:
                continue
            cx = ox + (col + 0.5) * resolution
            side = (cx - x1) * nx + (cy - y1) * ny
            if abs(side) <= reach and abs(cx - mx) <= wx and abs(cy - my) <= wy:
                occupied[row, col] = True
                continue
            if abs(side) > far:
                continue
            best = min(_point_square(x1, y1, cx, cy, h), _point_square(x2, y2, cx, cy, h))
            best = min(best, _point_segment(cx - h, cy - h, x1, y1, x2, y2))
            best = min(best, _point_segment(cx - h, cy + h, x1, y1, x2, y2))
            best = min(best, _point_segment(cx + h, cy - h, x1, y1, x2, y2))
            best = min(best, _point_segment(cx + h, cy + h, x1, y1, x2, y2))
            if best <= limit:
                occupied[row, col] = True


@numba.njit(cache=True, inline="always")
def _point_square(px, py, cx, cy, h):  # pragma: no cover - numba
    return np.hypot(max(abs(px - cx) - h, 0.0), max(abs(py - cy) - h, 0.0))


@numba.njit(cache=True, inline="always")
def _point_segment(px, py, x1, y1, x2, y2):  # pragma: no cover - numba
    sx, sy = x2 - x1, y2 - y1
    length2 = sx * sx + sy * sy
    u = 0.0 if length2 == 0.0 else min(max(((px - x1) * sx + (py - y1) * sy) / length2, 0.0), 1.0)
    return np.hypot(px - (x1 + u * sx), py - (y1 + u * sy))


def _raster_layout(segs: np.ndarray, resolution: float, half: float) -> tuple[np.ndarray, np.ndarray, float]:
    """An empty grid over the walls plus ``half`` their thickness, its origin (m) and its
    resolution (doubled until the grid has at most :data:`MAX_MAP_CELLS` cells)."""
    points = segs.reshape(-1, 2)
    lo = points.min(axis=0) - half
    hi = points.max(axis=0) + half
    while True:
        first = np.floor(lo / resolution)
        shape = (np.floor(hi / resolution) - first + 1).astype(np.int64)
        if float(shape[0]) * float(shape[1]) <= MAX_MAP_CELLS:
            break
        resolution *= 2.0
    return np.zeros((int(shape[1]), int(shape[0])), dtype=bool), first * resolution, resolution


def _rasterise_reference(segs: np.ndarray, resolution: float, thickness: float = WALL_THICKNESS_M) -> WallRaster:
    """The rasteriser as numpy over each piece of wall (slow: the kernel's reference in tests)."""
    segs = np.ascontiguousarray(segs, dtype=np.float64).reshape(-1, 4)
    half = 0.5 * thickness
    if segs.shape[0] == 0:
        return WallRaster(np.zeros((0, 0), dtype=bool), resolution, 0.0, 0.0)
    occupied, origin, resolution = _raster_layout(segs, resolution, half)
    for piece in _wall_pieces(segs, _PIECE_CELLS * resolution):
        _mark_piece(occupied, piece, origin, resolution, half)
    return WallRaster(occupied, resolution, float(origin[0]), float(origin[1]))


def _wall_pieces(segs: np.ndarray, longest: float) -> np.ndarray:
    """The segments cut into pieces at most ``longest`` long (same lines, end to end)."""
    pieces = []
    for x1, y1, x2, y2 in segs:
        n = max(int(math.ceil(math.hypot(x2 - x1, y2 - y1) / longest)), 1)
        u = np.linspace(0.0, 1.0, n + 1)
        xs, ys = x1 + u * (x2 - x1), y1 + u * (y2 - y1)
        pieces.append(np.column_stack([xs[:-1], ys[:-1], xs[1:], ys[1:]]))
    return np.concatenate(pieces)


def _mark_piece(occupied: np.ndarray, piece: np.ndarray, origin: np.ndarray, resolution: float, half: float) -> None:
    """Set the cells within ``half`` of one straight piece of wall (exact square-to-segment distance)."""
    height, width = occupied.shape
    x1, y1, x2, y2 = piece
    c0 = np.clip(np.floor((np.minimum([x1, y1], [x2, y2]) - half - origin) / resolution).astype(int) - 1, 0, None)
    c1 = np.floor((np.maximum([x1, y1], [x2, y2]) + half - origin) / resolution).astype(int) + 1
    c1 = np.minimum(c1, [width - 1, height - 1])
    cols = np.arange(c0[0], c1[0] + 1)
    rows = np.arange(c0[1], c1[1] + 1)
    cx = origin[0] + (cols[None, :] + 0.5) * resolution
    cy = origin[1] + (rows[:, None] + 0.5) * resolution
    near = _square_segment_distance(cx, cy, 0.5 * resolution, x1, y1, x2, y2) <= half * (1.0 + 1e-9)
    occupied[c0[1] : c1[1] + 1, c0[0] : c1[0] + 1] |= near


def _square_segment_distance(
    cx: np.ndarray, cy: np.ndarray, h: float, x1: float, y1: float, x2: float, y2: float
) -> np.ndarray:
    """Distance between the segment and each axis-aligned square (centre cx, cy; half side h):
    0 where they meet (separating axes: the boxes overlap and the square's corners straddle the
    line), else the least of the segment's ends to the square and the square's corners to the
    segment (two convex shapes apart are nearest at a vertex of one of them)."""
    cx, cy = np.broadcast_arrays(cx, cy)
    best = np.minimum(_point_square_distance(x1, y1, cx, cy, h), _point_square_distance(x2, y2, cx, cy, h))
    for sx, sy in ((-h, -h), (-h, h), (h, -h), (h, h)):
        best = np.minimum(best, _point_segment_distance(cx + sx, cy + sy, x1, y1, x2, y2))
    nx, ny = y2 - y1, x1 - x2  # the line's normal: the square meets the line if its corners straddle it
    side = (cx - x1) * nx + (cy - y1) * ny
    reach = h * (abs(nx) + abs(ny))
    crosses = np.abs(side) <= reach
    within = (np.abs(cx - 0.5 * (x1 + x2)) <= h + 0.5 * abs(x2 - x1)) & (
        np.abs(cy - 0.5 * (y1 + y2)) <= h + 0.5 * abs(y2 - y1)
    )
    return np.where(crosses & within, 0.0, best)


def _point_square_distance(px: float, py: float, cx: np.ndarray, cy: np.ndarray, h: float) -> np.ndarray:
    return np.hypot(np.maximum(np.abs(px - cx) - h, 0.0), np.maximum(np.abs(py - cy) - h, 0.0))


def _point_segment_distance(px: np.ndarray, py: np.ndarray, x1: float, y1: float, x2: float, y2: float) -> np.ndarray:
    sx, sy = x2 - x1, y2 - y1
    length2 = sx * sx + sy * sy
    u = np.zeros_like(px) if length2 == 0.0 else np.clip(((px - x1) * sx + (py - y1) * sy) / length2, 0.0, 1.0)
    return np.hypot(px - (x1 + u * sx), py - (y1 + u * sy))
