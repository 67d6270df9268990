"""2-D geometry kernels for the Create world: ray casting against wall segments and circle contacts.

Walls are line segments ``(N, 4)`` float64 ``[x1, y1, x2, y2]``. Rays are culled with a uniform grid
(:class:`SegmentGrid`): each cell lists the segments that cross it, a ray walks the cells it passes
through (Amanatides–Woo) and stops as soon as its nearest hit lies inside the cell it has tested.
A per-call "mailbox" array keeps a segment that spans several cells from being tested twice.

Everything hot is a ``numba.njit(cache=True)`` kernel over plain arrays so that one call casts a
whole LIDAR scan; the Python class only builds and holds the arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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
    """Closest point on the segment to (px, py): returns (cx, cy, distance)."""
    sx = x2 - x1
    sy = y2 - y1
    len2 = sx * sx + sy * sy
    u = 0.0
    if len2 > 0.0:
        u = ((px - x1) * sx + (py - y1) * sy) / len2
        u = min(max(u, 0.0), 1.0)
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
    if f00 < -scale and f01 < -scale and f10 < -scale and f11 < -scale:
        return False
    return True


@numba.njit(cache=True)
def _build_grid(segs, x0, y0, cell, nx, ny):
    """CSR lists (cell_start, cell_items) of the segments crossing each cell, cell = iy*nx + ix."""
    n = segs.shape[0]
    eps = cell * 1e-6
    counts = np.zeros(nx * ny + 1, dtype=np.int64)
    for pass_no in range(2):
        if pass_no == 1:
            start = np.zeros(nx * ny + 1, dtype=np.int64)
            for c in range(nx * ny):
                start[c + 1] = start[c] + counts[c]
            items = np.empty(start[nx * ny], dtype=np.int32)
            fill = start[:-1].copy()
        for s in range(n):
            x1, y1, x2, y2 = segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3]
            ix0 = max(int(math.floor((min(x1, x2) - x0) / cell - 1e-6)), 0)
            ix1 = min(int(math.floor((max(x1, x2) - x0) / cell + 1e-6)), nx - 1)
            iy0 = max(int(math.floor((min(y1, y2) - y0) / cell - 1e-6)), 0)
            iy1 = min(int(math.floor((max(y1, y2) - y0) / cell + 1e-6)), ny - 1)
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


@numba.njit(cache=True)
def grid_cast(segs, meta, start, items, mailbox, stamp, ox, oy, dx, dy, max_range) -> float:
    """Nearest hit of one unit ray within max_range (inf if none), walking the grid cells.

    ``meta`` = [x0, y0, cell, nx, ny]; ``mailbox`` (one int64 per segment) holds the stamp of the
    last ray that tested each segment, so pass a new ``stamp`` for every ray.
    """
    nx = int(meta[3])
    ny = int(meta[4])
    if nx == 0 or ny == 0:
        return np.inf
    x0 = meta[0]
    y0 = meta[1]
    cell = meta[2]
    x1 = x0 + nx * cell
    y1 = y0 + ny * cell
    t_in = 0.0
    t_out = max_range
    if not (x0 <= ox <= x1 and y0 <= oy <= y1):
        # Origin off the grid: clip the ray to the grid's box (slab test).
        if dx != 0.0:
            ta = (x0 - ox) / dx
            tb = (x1 - ox) / dx
            t_in = max(t_in, min(ta, tb))
            t_out = min(t_out, max(ta, tb))
        elif ox < x0 or ox > x1:
            return np.inf
        if dy != 0.0:
            ta = (y0 - oy) / dy
            tb = (y1 - oy) / dy
            t_in = max(t_in, min(ta, tb))
            t_out = min(t_out, max(ta, tb))
        elif oy < y0 or oy > y1:
            return np.inf
        if t_in > t_out:
            return np.inf
    px = ox + dx * t_in
    py = oy + dy * t_in
    ix = min(max(int((px - x0) / cell), 0), nx - 1)
    iy = min(max(int((py - y0) / cell), 0), ny - 1)
    # Ray parameter at the next x / y cell boundary, and its increment per cell.
    if dx != 0.0:
        inv_dx = 1.0 / dx
        step_x = 1 if dx > 0.0 else -1
        t_max_x = (x0 + (ix + (1 if dx > 0.0 else 0)) * cell - ox) * inv_dx
        t_delta_x = abs(cell * inv_dx)
    else:
        step_x = 0
        t_max_x = np.inf
        t_delta_x = np.inf
    if dy != 0.0:
        inv_dy = 1.0 / dy
        step_y = 1 if dy > 0.0 else -1
        t_max_y = (y0 + (iy + (1 if dy > 0.0 else 0)) * cell - oy) * inv_dy
        t_delta_y = abs(cell * inv_dy)
    else:
        step_y = 0
        t_max_y = np.inf
        t_delta_y = np.inf
    best = np.inf
    while True:
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
def grid_cast_fan(segs, meta, start, items, ox, oy, heading, cos_off, sin_off, max_range):
    """Distances of rays from one origin at angles heading + offset (inf = no hit within range).

    Offsets come as their cosines and sines so a sensor's fixed fan needs no trigonometry per
    ray: each direction is the offset rotated by the heading.
    """
    out = np.empty(cos_off.shape[0])
    mailbox = np.full(segs.shape[0], -1, dtype=np.int64)
    ch = math.cos(heading)
    sh = math.sin(heading)
    for i in range(cos_off.shape[0]):
        dx = ch * cos_off[i] - sh * sin_off[i]
        dy = sh * cos_off[i] + ch * sin_off[i]
        out[i] = grid_cast(segs, meta, start, items, mailbox, i, ox, oy, dx, dy, max_range)
    return out


@numba.njit(cache=True)
def circle_crossing_angles(lines, cx, cy, radius, out):
    """World angles (seen from the centre) where segments cross the circle; returns how many.

    ``out`` needs room for 2 per segment. A segment wholly inside or outside the circle gives none.
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
            if 0.0 <= u <= 1.0:
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


@numba.njit(cache=True)
def grid_contacts(segs, meta, start, items, px, py, reach, out):
    """Closest points of every segment within ``reach`` of (px, py).

    Fills rows of ``out`` (shape (>=N, 4)) with [cx, cy, distance, segment index] and returns how
    many. Points off the grid are near nothing (the grid covers every segment).
    """
    nx = int(meta[3])
    ny = int(meta[4])
    if nx == 0 or ny == 0:
        return 0
    x0 = meta[0]
    y0 = meta[1]
    cell = meta[2]
    ix0 = max(int(math.floor((px - reach - x0) / cell)), 0)
    ix1 = min(int(math.floor((px + reach - x0) / cell)), nx - 1)
    iy0 = max(int(math.floor((py - reach - y0) / cell)), 0)
    iy1 = min(int(math.floor((py + reach - y0) / cell)), ny - 1)
    count = 0
    for iy in range(iy0, iy1 + 1):
        for ix in range(ix0, ix1 + 1):
            c = iy * nx + ix
            for k in range(start[c], start[c + 1]):
                s = items[k]
                duplicate = False
                for j in range(count):
                    if out[j, 3] == s:
                        duplicate = True
                        break
                if duplicate:
                    continue
                cx, cy, d = point_segment_closest(px, py, segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3])
                if d <= reach:
                    out[count, 0] = cx
                    out[count, 1] = cy
                    out[count, 2] = d
                    out[count, 3] = s
                    count += 1
    return count


@dataclass(frozen=True)
class SegmentGrid:
    """Segments plus the uniform grid that culls them for rays and contact queries."""

    segs: np.ndarray  # (N, 4) float64
    meta: np.ndarray  # [x0, y0, cell, nx, ny]
    start: np.ndarray  # (nx*ny + 1,) int64
    items: np.ndarray  # int32 segment indices, CSR by cell

    @classmethod
    def build(cls, segs: np.ndarray, cell: float | None = None) -> SegmentGrid:
        """Grid over ``segs``; the default cell size puts about two cells per segment, ≥ 5 cm."""
        segs = np.ascontiguousarray(segs, dtype=np.float64).reshape(-1, 4)
        if segs.shape[0] == 0:
            return cls(segs, np.array([0.0, 0.0, 1.0, 0.0, 0.0]), np.zeros(1, np.int64), np.zeros(0, np.int32))
        lo = np.minimum(segs[:, :2].min(axis=0), segs[:, 2:].min(axis=0))
        hi = np.maximum(segs[:, :2].max(axis=0), segs[:, 2:].max(axis=0))
        extent = np.maximum(hi - lo, 1e-3)
        if cell is None:
            lengths = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])
            area = float(extent[0] * extent[1])
            cell = max(math.sqrt(area / (2.0 * segs.shape[0])), 0.5 * float(np.median(lengths)), 0.05)
            cell = min(cell, float(extent.max()))
        shape = np.ceil(extent / cell).astype(np.int64) + 1
        # Keep the grid bounded for huge sparse maps.
        while shape[0] * shape[1] > 1_000_000:
            cell *= 2.0
            shape = np.ceil(extent / cell).astype(np.int64) + 1
        origin = lo - 0.5 * (shape * cell - extent)
        start, items = _build_grid(segs, float(origin[0]), float(origin[1]), float(cell), int(shape[0]), int(shape[1]))
        meta = np.array([origin[0], origin[1], cell, shape[0], shape[1]], dtype=np.float64)
        return cls(segs, meta, start, items)

    def cast(self, ox: float, oy: float, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distances from (ox, oy) along world ``angles``; inf where nothing is hit within range."""
        angles = np.asarray(angles, dtype=np.float64)
        return self.cast_fan(ox, oy, 0.0, np.cos(angles), np.sin(angles), max_range)

    def cast_fan(
        self, ox: float, oy: float, heading: float, cos_off: np.ndarray, sin_off: np.ndarray, max_range: float
    ) -> np.ndarray:
        """Like :meth:`cast` for a sensor's fixed fan: angles heading + offsets (as cos, sin)."""
        return grid_cast_fan(
            self.segs,
            self.meta,
            self.start,
            self.items,
            float(ox),
            float(oy),
            float(heading),
            cos_off,
            sin_off,
            float(max_range),
        )


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
    dist = np.where(hit, t, np.inf).min(axis=1)
    dist[dist > max_range] = np.inf
    return dist
