"""Ray casting and polygon rasterisation on a SIMROBOT occupancy matrix (pure numpy/numba).

The matrix is ``grid[x, y]`` (uint8): 0 free, 1 wall, 2-255 robot id. Cell ``(i, j)`` covers
``[i, i+1) x [j, j+1)`` in cell units, so a point ``p`` lies in cell ``floor(p)``.

Every caster returns the same quantity: the ray parameter ``t`` (cells) at which the ray *enters*
the first cell that is non-zero and not the caster's own robot id (0 when it starts inside one),
plus that cell's value; rays that reach ``max_range`` or leave the map give ``inf`` and 0.

Four casters:

* :func:`cast_scan_exact` — Amanatides-Woo grid traversal, one cell at a time. It visits every
  cell the ray touches, so it cannot slip between two cells that meet at a corner (an
  8-connected Bresenham line can). The reference.
* :func:`cast_scan_fast` — walls: jumps through free space by a clearance table (Euclidean
  distance transform of the static walls, computed once per map), reuses the free discs found by
  the previous rays of the same scan (neighbouring rays cross the same free space), and walks
  cell by cell only near walls; robots: an exact traversal of just the stretch of each ray inside
  a nearby robot's bounding circle, only for the rays whose angle can meet it. Same hits as the
  reference, a small fraction of the cells visited.
* :func:`cast_scan_original` — the original SIMROBOT's sensor rules (``sensor_model: original``):
  a Bresenham line to a rounded end cell that also tests the next cell along x, distances between
  cell centres. Its contract differs from the three others (see its docstring).
* :func:`cast_ray_plain_bresenham_python` — a plain 8-connected Bresenham in plain Python, the
  speed baseline of the benchmark. It is *not* the original SIMROBOT's sensor rules (those are
  :func:`cast_scan_original`).

The fast caster takes its inputs grouped: the map (:class:`Occupancy`), one sensor's rays
(:class:`Fan`), the robots it may see (:class:`Candidates`) and its working memory
(:class:`ScanScratch`); its pieces (ray set-up, one robot, the walls) are inlined kernels.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable
from typing import Any, Literal, NamedTuple, TypedDict

import numba
import numpy as np

#: Jumping is worth its re-initialisation only when it skips at least this many cells.
JUMP_MIN = 3
#: Value of a wall cell in the clearance table.
WALL = 255
_FAR = 1.0e9


class _JitOptions(TypedDict):
    """Keyword options of ``numba.njit`` used here (typed, so ``njit(**options)`` type-checks)."""

    cache: bool
    error_model: Literal["python", "numpy"]
    fastmath: set[str]


#: Compile options of the fast caster's kernels: reciprocals, fused multiply-adds and
#: reassociation (results move by ulps, far inside the one-cell tolerance; measured ~14% faster
#: on the walls pass), but infinities and NaN keep IEEE semantics (no-hit is ``inf``). The
#: reference traversal keeps strict IEEE arithmetic.
_FAST: _JitOptions = {"cache": True, "error_model": "numpy", "fastmath": {"arcp", "contract", "afn", "nsz", "reassoc"}}


class Occupancy(NamedTuple):
    """The map a caster reads, in cells: ``matrix[x, y]`` (0 free, 1 wall, robot ids) and the
    static walls' :func:`clearance_field` (the fast caster jumps through free space with it)."""

    matrix: np.ndarray
    clearance: np.ndarray


class Fan(NamedTuple):
    """One sensor's rays at one instant, in cells and radians. Ray ``i`` leaves ``(origin_x,
    origin_y)`` along the unit vector ``directions[i]``, at angle ``first_angle + i * angle_step``
    (every sensor's rays are spread evenly); cells of ``own_id`` (the sensor's robot) are never
    seen; nothing is seen beyond ``max_range``."""

    origin_x: float
    origin_y: float
    directions: np.ndarray
    first_angle: float
    angle_step: float
    max_range: float
    own_id: int


class Candidates(NamedTuple):
    """Robots a fan may see: pivot ``x``, ``y`` and a bounding ``radius`` that covers every cell
    the robot occupies, ``box[k] = [x0, y0, x1, y1]`` of those cells, and the robot's ``id``."""

    x: np.ndarray
    y: np.ndarray
    radius: np.ndarray
    box: np.ndarray
    id: np.ndarray


class ScanScratch(NamedTuple):
    """Working memory of the fast caster, so a caller casting many scans allocates it once:
    ``t_enter``/``t_leave`` hold at least one entry per ray (the stretch of each ray on the map),
    ``discs`` the free discs reused between rays (any number of rows: more rows, more reuse)."""

    t_enter: np.ndarray
    t_leave: np.ndarray
    discs: np.ndarray


def no_candidates() -> Candidates:
    """No robot to test (a fan over walls alone)."""
    return Candidates(np.empty(0), np.empty(0), np.empty(0), np.empty((0, 4)), np.empty(0, dtype=np.int64))


@numba.njit(cache=True)
def scan_scratch(rays: int, discs: int = 256) -> ScanScratch:
    """Scratch for scans of up to ``rays`` rays (kernels make theirs with it too)."""
    return ScanScratch(np.empty(rays), np.empty(rays), np.empty((discs, 3)))


@numba.njit(cache=True)
def _edt_1d(f: np.ndarray, n: int, out: np.ndarray, v: np.ndarray, z: np.ndarray) -> None:
    # Felzenszwalb-Huttenlocher lower envelope of parabolas: squared distance in one dimension.
    k = 0
    v[0] = 0
    z[0] = -_FAR
    z[1] = _FAR
    for q in range(1, n):
        if f[q] >= _FAR:
            continue
        if f[v[0]] >= _FAR:
            v[0] = q
            continue
        while True:
            s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
            if s <= z[k] and k > 0:
                k -= 1
            else:
                break
        if s <= z[k]:
            # k == 0 and the new parabola dominates the only one kept
            v[0] = q
            z[1] = _FAR
            continue
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = _FAR
    if f[v[0]] >= _FAR:
        for q in range(n):
            out[q] = _FAR
        return
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        d = q - v[k]
        out[q] = d * d + f[v[k]]


@numba.njit(cache=True)
def squared_distance_transform(occupied: np.ndarray) -> np.ndarray:
    """Squared Euclidean distance (cells, centre to centre) from each cell to the nearest
    occupied cell; ``1e9`` when there is none. Exact, linear time (two 1-D passes)."""
    nx, ny = occupied.shape
    n = max(nx, ny)
    f = np.empty(n)
    out = np.empty(n)
    v = np.empty(n, dtype=np.int64)
    z = np.empty(n + 1)
    tmp = np.empty((nx, ny))
    for i in range(nx):
        for j in range(ny):
            f[j] = 0.0 if occupied[i, j] else _FAR
        _edt_1d(f, ny, out, v, z)
        for j in range(ny):
            tmp[i, j] = out[j]
    result = np.empty((nx, ny))
    for j in range(ny):
        for i in range(nx):
            f[i] = tmp[i, j]
        _edt_1d(f, nx, out, v, z)
        for i in range(nx):
            result[i, j] = min(out[i], _FAR)
    return result


def clearance_field(walls: np.ndarray) -> np.ndarray:
    """The fast caster's static table, uint8 in ``grid`` layout: :data:`WALL` for a wall cell,
    else the free distance (whole cells, capped at 254) a ray may travel from *any point* of the
    cell without entering a wall cell: the distance between the cell's square and the nearest
    wall square, floored. One byte per cell, so a 1000x1000 map's table stays in cache (jumping
    is latency-bound)."""
    walls = np.ascontiguousarray(walls, dtype=np.bool_)
    # square-to-square distance for offsets (di, dj) is |(max(|di|-1, 0), max(|dj|-1, 0))|: the
    # centre distance to the walls grown by one cell each way (tighter than centre distance
    # minus two half-diagonals by up to one cell, most next to axis-aligned walls)
    grown = walls.copy()
    grown[1:, :] |= walls[:-1, :]
    grown[:-1, :] |= walls[1:, :]
    grown2 = grown.copy()
    grown2[:, 1:] |= grown[:, :-1]
    grown2[:, :-1] |= grown[:, 1:]
    d = np.sqrt(squared_distance_transform(grown2))
    field: np.ndarray = np.clip(np.floor(d), 0, 254).astype(np.uint8)
    field[walls] = WALL
    return field


@numba.njit(cache=True, inline="always")
def _clip_to_map(ox: float, oy: float, dx: float, dy: float, nx: int, ny: int, t_max: float):
    # Parametric slab test against the map box [0,nx]x[0,ny]; returns (t_enter, t_exit).
    t0 = 0.0
    t1 = t_max
    if dx != 0.0:
        a = (0.0 - ox) / dx
        b = (nx - ox) / dx
        if a > b:
            a, b = b, a
        t0 = max(t0, a)
        t1 = min(t1, b)
    elif ox < 0.0 or ox >= nx:
        return 1.0, 0.0
    if dy != 0.0:
        a = (0.0 - oy) / dy
        b = (ny - oy) / dy
        if a > b:
            a, b = b, a
        t0 = max(t0, a)
        t1 = min(t1, b)
    elif oy < 0.0 or oy >= ny:
        return 1.0, 0.0
    return t0, t1


@numba.njit(cache=True, inline="always")
def _axis_start(d: float, p: float, c: int, t_start: float) -> tuple[int, float, float]:
    """Grid traversal set-up along one axis (Amanatides–Woo): the cell step, the ray length per
    cell, and the ray length at the first cell boundary, for direction ``d`` from ``p`` in cell ``c``."""
    if d > 0.0:
        per_cell = 1.0 / d
        return 1, per_cell, t_start + (c + 1 - p) * per_cell
    if d < 0.0:
        per_cell = -1.0 / d
        return -1, per_cell, t_start + (p - c) * per_cell
    return 0, np.inf, np.inf


@numba.njit(cache=True)
def _traverse(
    grid: np.ndarray,
    ox: float,
    oy: float,
    dx: float,
    dy: float,
    t_start: float,
    t_end: float,
    self_id: int,
    only_id: int,
):
    """Amanatides-Woo from ``t_start`` to ``t_end`` on the matrix: returns (t, value) of the first
    cell that is non-zero and not ``self_id`` — or, when ``only_id`` > 0, that holds ``only_id``
    (the exact test of one robot) — else (inf, 0)."""
    nx, ny = grid.shape
    px = ox + t_start * dx
    py = oy + t_start * dy
    cx = int(math.floor(px))
    cy = int(math.floor(py))
    # a point on the far map edge belongs to the last cell
    if cx >= nx:
        cx = nx - 1
    if cy >= ny:
        cy = ny - 1
    if cx < 0:
        cx = 0
    if cy < 0:
        cy = 0
    sx, tdx, tmx = _axis_start(dx, px, cx, t_start)
    sy, tdy, tmy = _axis_start(dy, py, cy, t_start)
    t = t_start
    while True:
        v = grid[cx, cy]
        if only_id > 0:
            if v == only_id:
                return t, v
        elif v != 0 and v != self_id:
            return t, v
        if tmx < tmy:
            t = tmx
            tmx += tdx
            cx += sx
            if cx < 0 or cx >= nx:
                return np.inf, 0
        else:
            t = tmy
            tmy += tdy
            cy += sy
            if cy < 0 or cy >= ny:
                return np.inf, 0
        if t > t_end:
            return np.inf, 0


def _renamed(func: Callable[..., Any], name: str) -> types.FunctionType:
    """``func``'s code under another name: numba files a kernel's cache entries by its function's
    name and first line, not by its options, so two kernels of one function would share (and
    overwrite) one entry, and either could load the other's machine code."""
    clone = types.FunctionType(func.__code__, func.__globals__, name, func.__defaults__, func.__closure__)
    clone.__qualname__ = name
    return clone


#: The same traversal compiled with the fast caster's options, for its exact robot tests.
_traverse_fast = numba.njit(**_FAST)(_renamed(_traverse.py_func, "_traverse_fast"))


@numba.njit(cache=True)
def cast_ray_exact(grid, ox, oy, dx, dy, max_range, self_id):
    """One ray, reference traversal. ``(dx, dy)`` is a unit vector. Returns (t, value)."""
    nx, ny = grid.shape
    t0, t1 = _clip_to_map(ox, oy, dx, dy, nx, ny, max_range)
    if t0 > t1:
        return np.inf, 0
    t, v = _traverse(grid, ox, oy, dx, dy, t0, t1, self_id, 0)
    if t > max_range:
        return np.inf, 0
    return t, v


@numba.njit(inline="always", **_FAST)
def _traverse_walls(field, ox, oy, dx, dy, t_start, t_end):
    """Amanatides-Woo on the static table only (robots are tested separately). Returns
    (t_hit or inf, t_stop, jump): stops on a wall cell, at ``t_end`` (jump 0), or on entering a cell
    whose clearance ``jump`` >= JUMP_MIN lets the ray skip ahead. One table read per cell."""
    nx, ny = field.shape
    px = ox + t_start * dx
    py = oy + t_start * dy
    cx = min(max(int(math.floor(px)), 0), nx - 1)
    cy = min(max(int(math.floor(py)), 0), ny - 1)
    sx, tdx, tmx = _axis_start(dx, px, cx, t_start)
    sy, tdy, tmy = _axis_start(dy, py, cy, t_start)
    t = t_start
    while True:
        c = field[cx, cy]
        if c >= JUMP_MIN:  # one test per cell: walls are the top value
            if c == WALL:
                return t, t, 0.0
            return np.inf, t, float(c)
        if tmx < tmy:
            t = tmx
            tmx += tdx
            cx += sx
            if cx < 0 or cx >= nx:
                return np.inf, t_end, 0.0
        else:
            t = tmy
            tmy += tdy
            cy += sy
            if cy < 0 or cy >= ny:
                return np.inf, t_end, 0.0
        if t > t_end:
            return np.inf, t_end, 0.0


@numba.njit(inline="always", **_FAST)
def _cast_walls_fast(field, ox, oy, dx, dy, t0, t1, discs, nd):
    # Jump while the clearance allows (one table look-up per jump), traverse cell by cell near walls.
    # Every jump's free disc (centre, radius) is appended to ``discs`` for the next ray to reuse.
    nx, ny = field.shape
    maxd = discs.shape[0]
    t = t0
    while t <= t1:
        px = ox + t * dx
        py = oy + t * dy
        if (px < 0.0 or py < 0.0 or px >= nx or py >= ny) and t > t0:
            return np.inf, nd  # left the map (a ray cannot come back into a box)
        # on the map edge (a ray entering from outside) a clamp finds the edge cell
        cx = min(max(int(px), 0), nx - 1)
        cy = min(max(int(py), 0), ny - 1)
        c = field[cx, cy]
        if c >= JUMP_MIN and c != WALL:
            if nd < maxd:
                discs[nd, 0] = px
                discs[nd, 1] = py
                discs[nd, 2] = c
                nd += 1
            t += float(c)
            continue
        th, ts, jump = _traverse_walls(field, ox, oy, dx, dy, t, t1)
        if th <= t1:
            return th, nd
        if jump <= 0.0:
            break
        if nd < maxd:
            discs[nd, 0] = ox + ts * dx
            discs[nd, 1] = oy + ts * dy
            discs[nd, 2] = jump
            nd += 1
        t = ts + jump
    return np.inf, nd


@numba.njit(inline="always", **_FAST)
def _reuse_discs(ox, oy, dx, dy, t, discs, nd):
    # Free discs found by earlier rays of this scan, in order along the previous ray: follow
    # them along this ray while each one covers where we are. Returns (new t, discs kept).
    keep = 0
    for k in range(nd):
        qx = discs[k, 0] - ox
        qy = discs[k, 1] - oy
        r = discs[k, 2]
        b = qx * dx + qy * dy
        disc = b * b - (qx * qx + qy * qy - r * r)
        if disc <= 0.0:
            break
        sq = math.sqrt(disc)
        if b - sq > t:
            break
        if b + sq > t:
            t = b + sq
        keep = k + 1
    return t, keep


@numba.njit(inline="always", **_FAST)
def _start_rays(shape, fan, out_t, out_v, scratch):
    # each ray's stretch on the map, and no hit yet
    nx, ny = shape
    ox = fan.origin_x
    oy = fan.origin_y
    d = fan.directions
    inside = 0.0 <= ox < nx and 0.0 <= oy < ny
    for i in range(d.shape[0]):
        if inside:
            # every traversal stops at the map edge by itself
            scratch.t_enter[i], scratch.t_leave[i] = 0.0, fan.max_range
        else:
            scratch.t_enter[i], scratch.t_leave[i] = _clip_to_map(ox, oy, d[i, 0], d[i, 1], nx, ny, fan.max_range)
        out_t[i] = np.inf
        out_v[i] = 0


@numba.njit(inline="always", **_FAST)
def _walls_pass(clearance, fan, out_t, out_v, scratch):
    # Walls, ray after ray, each only up to its robot hit, reusing the previous rays' free discs.
    ox = fan.origin_x
    oy = fan.origin_y
    nd = 0
    for i in range(fan.directions.shape[0]):
        dx = fan.directions[i, 0]
        dy = fan.directions[i, 1]
        t0 = scratch.t_enter[i]
        t1 = min(scratch.t_leave[i], out_t[i])
        if t0 > t1:
            continue
        ts, nd = _reuse_discs(ox, oy, dx, dy, t0, scratch.discs, nd)
        if ts <= t1:
            th, nd = _cast_walls_fast(clearance, ox, oy, dx, dy, ts, t1, scratch.discs, nd)
            if th < out_t[i]:
                out_t[i] = th
                out_v[i] = 1


@numba.njit(inline="always", **_FAST)
def _robot_window(qx, qy, c2, rad, n, first_angle, angle_step):
    """Which rays of a fan may meet a robot's bounding circle (centre ``(qx, qy)`` from the
    sensor, ``c2`` = distance squared minus radius squared): returns (windows, half, centre).
    One window means every ray: the sensor is inside the circle, the fan has a single ray, or the
    circle is too wide for the test to pay. Three windows: the rays within ``half`` (radians) of
    the angle ``centre`` (from the first ray, along the fan, in [0, 2 pi)), tried one turn down
    and up as well, as the window may wrap."""
    if c2 > 0.0 and n > 1 and angle_step != 0.0:
        # tan(asin(r/d)) = r/sqrt(d^2 - r^2) bounds the circle's half angle from above
        half = rad / math.sqrt(c2) + 1e-9
        if half < 1.5:
            two_pi = 2.0 * math.pi
            centre = (math.atan2(qy, qx) - first_angle) * (1.0 if angle_step > 0.0 else -1.0)
            centre -= two_pi * math.floor(centre / two_pi)
            return 3, half, centre
        return 1, half, 0.0
    return 1, 0.0, 0.0


@numba.njit(inline="always", **_FAST)
def _window_rays(k, windows, centre, half, step, n):
    """First and last ray index of window ``k`` of :func:`_robot_window` (first > last: none)."""
    if windows != 3:
        return 0, n - 1
    # the same angle one turn down or up only matters when the window wraps
    two_pi = 2.0 * math.pi
    off = centre + (k - 1) * two_pi
    if off + half < 0.0 or off - half > (n - 1) * step:
        return 1, 0
    return max(int(math.ceil((off - half) / step)), 0), min(int(math.floor((off + half) / step)), n - 1)


@numba.njit(inline="always", **_FAST)
def _slab(d, lo, hi, ta, tb):
    """Clip the ray stretch [ta, tb] to the slab between ``lo`` and ``hi`` (relative to the
    sensor) along one axis of direction component ``d`` (empty: ta > tb)."""
    if d != 0.0:
        u = lo / d
        w = hi / d
        return max(ta, min(u, w)), min(tb, max(u, w))
    if lo > 0.0 or hi < 0.0:
        return 1.0, 0.0
    return ta, tb


@numba.njit(**_FAST)
def cast_scan_fast_into(grid, fan, robots, out_t, out_v, scratch):
    """:func:`cast_scan_fast` with the caller's :class:`ScanScratch` (no allocation per scan)."""
    _start_rays(grid.matrix.shape, fan, out_t, out_v, scratch)
    # Robots (not in the static table), each exactly (a traversal of its cells inside its box), on
    # just the rays whose angle can meet its bounding circle. Robots first: a ray that meets one
    # needs the walls only up to it. This pass stays in this function, its arrays taken out of the
    # structures once: as an inlined piece, or as a function of its own, it measured 5-10 % slower
    # on a whole sensing pass (its scalar pieces are inlined helpers).
    matrix = grid.matrix
    ox = fan.origin_x
    oy = fan.origin_y
    directions = fan.directions
    max_range = fan.max_range
    own_id = fan.own_id
    cand_x = robots.x
    cand_y = robots.y
    cand_radius = robots.radius
    cand_box = robots.box
    cand_id = robots.id
    t_enter = scratch.t_enter
    t_leave = scratch.t_leave
    n = directions.shape[0]
    step = abs(fan.angle_step)
    for j in range(cand_id.shape[0]):
        robot_id = cand_id[j]
        if robot_id == own_id:
            continue
        qx = cand_x[j] - ox
        qy = cand_y[j] - oy
        rad = cand_radius[j]
        dist2 = qx * qx + qy * qy
        c2 = dist2 - rad * rad
        if c2 > 0.0 and c2 > (max_range + rad) * (max_range + rad) - rad * rad:
            continue  # farther than the range
        # no ray meets the robot before its bounding circle: rays already shorter are skipped
        # with one comparison (candidates come nearest first, so most far ones end here)
        t_near = math.sqrt(dist2) - rad
        bx0 = cand_box[j, 0] - ox
        by0 = cand_box[j, 1] - oy
        bx1 = cand_box[j, 2] - ox
        by1 = cand_box[j, 3] - oy
        windows, half, centre = _robot_window(qx, qy, c2, rad, n, fan.first_angle, fan.angle_step)
        for k in range(windows):
            first, last = _window_rays(k, windows, centre, half, step, n)
            for i in range(first, last + 1):
                if out_t[i] <= t_near:
                    continue
                dx = directions[i, 0]
                dy = directions[i, 1]
                # ray / box slabs
                ta, tb = _slab(dx, bx0, bx1, t_enter[i], min(t_leave[i], out_t[i]))
                ta, tb = _slab(dy, by0, by1, ta, tb)
                if ta > tb:
                    continue
                t_hit, value = _traverse_fast(matrix, ox, oy, dx, dy, ta, tb, own_id, robot_id)
                if value > 0 and t_hit < out_t[i]:
                    out_t[i] = t_hit
                    out_v[i] = value
    _walls_pass(grid.clearance, fan, out_t, out_v, scratch)
    for i in range(fan.directions.shape[0]):
        if out_t[i] > fan.max_range:
            out_t[i] = np.inf
            out_v[i] = 0


@numba.njit(**_FAST)
def cast_scan_fast(grid, fan, robots, out_t, out_v):
    """All rays of one :class:`Fan` over an :class:`Occupancy` with the fast caster; ``robots``
    (:class:`Candidates`) are the robots it may see. Results go to ``out_t``/``out_v`` (``inf``/0
    for no hit within the range)."""
    n = fan.directions.shape[0]
    cast_scan_fast_into(grid, fan, robots, out_t, out_v, scan_scratch(n))


@numba.njit(cache=True)
def cast_scan_exact(grid, ox, oy, directions, max_range, self_id, out_t, out_v):
    """All rays of one sensor with the reference traversal (same contract as the fast one)."""
    for i in range(directions.shape[0]):
        t, v = cast_ray_exact(grid, ox, oy, directions[i, 0], directions[i, 1], max_range, self_id)
        out_t[i] = t
        out_v[i] = v


@numba.njit(cache=True, inline="always")
def _seen(matrix, x, y, own_id):
    # what the original's trace sees in cell (x, y): its value, or 0 for free or the own robot
    v = matrix[x, y]
    return 0 if v == own_id else v


@numba.njit(cache=True)
def _midpoint_start(x0: int, y0: int, x1: int, y1: int) -> int:
    """The decision value of the original's midpoint line from (x0, y0) to (x1, y1) before its first step."""
    dx = abs(x1 - x0)
    dy = abs(y1 - y0)
    return 2 * dy - dx if dy < dx else 2 * dx - dy


@numba.njit(cache=True)
def _midpoint_step(x: int, y: int, d: int, x0: int, y0: int, x1: int, y1: int) -> tuple[int, int, int]:
    """One step of the original's midpoint (Bresenham) line from (x0, y0) to (x1, y1): always along
    the main axis, and along the other one too when the decision value ``d`` is above 0 (a tie,
    0, stays on the main axis). Returns the new cell and decision value."""
    dx = abs(x1 - x0)
    dy = abs(y1 - y0)
    x_major = dy < dx
    steps = dx if x_major else dy
    minor = dy if x_major else dx
    side_step = d > 0
    d += 2 * (minor - steps) if side_step else 2 * minor
    if x_major or side_step:
        x += 1 if x1 >= x0 else -1
    if not x_major or side_step:
        y += 1 if y1 >= y0 else -1
    return x, y, d


@numba.njit(cache=True)
def cast_ray_original(matrix: np.ndarray, cx: int, cy: int, ex: int, ey: int, own_id: int) -> tuple[float, int]:
    """One ray by the original SIMROBOT's rules, in cell indices: from the sensor's cell ``(cx,
    cy)`` to the end cell ``(ex, ey)`` by the original's midpoint Bresenham line (8-connected; at
    an exact midpoint it steps along the main axis only); after each step the new cell and then
    the next cell along x are tested, so a ray is two cells wide and may report a cell beyond its
    end. Returns the distance between the centres of the sensor's cell and the hit cell (cells)
    and the hit cell's value; ``(inf, 0)`` for none. The sensor's own cell counts (distance 0).
    The trace stops where the original's does: two cells from the left and right map edges, one
    from the bottom and top (the original expects a walled map)."""
    nx, ny = matrix.shape
    if 0 <= cx < nx and 0 <= cy < ny:
        v = _seen(matrix, cx, cy, own_id)
        if v != 0:
            return 0.0, v
    sx = 1 if ex >= cx else -1  # also the side of the extra cell: to the right for a vertical ray
    steps = max(abs(ex - cx), abs(ey - cy))
    d = _midpoint_start(cx, cy, ex, ey)
    x = cx
    y = cy
    for _ in range(steps):
        if x >= nx - 2 or y >= ny - 1 or x <= 1 or y <= 0:
            break
        x, y, d = _midpoint_step(x, y, d, cx, cy, ex, ey)
        v = _seen(matrix, x, y, own_id)
        if v != 0:
            return math.hypot(x - cx, y - cy), v
        v = _seen(matrix, x + sx, y, own_id)
        if v != 0:
            return math.hypot(x + sx - cx, y - cy), v
    return np.inf, 0


@numba.njit(cache=True, inline="always")
def original_end_cell(cell: int, reach: float) -> int:
    """The cell where an original ray ends, along one axis: ``reach`` cells from the centre of
    ``cell``, rounded as the original's C code rounds. Its cells count from 1 (ours from 0), and
    it rounds down when the fractional part is below one half, else up; the fractional part
    keeps the number's sign, so a negative coordinate (a ray ending beyond the left or bottom
    edge) is always rounded down, where halves-up rounding would round -0.3 to 0."""
    v = cell + 1 + reach  # the original's coordinate
    whole = math.floor(v)
    if v >= 0.0 and v - whole >= 0.5:
        whole += 1
    return int(whole) - 1


@numba.njit(cache=True)
def cast_scan_original(matrix: np.ndarray, fan: Fan, out_t: np.ndarray, out_v: np.ndarray) -> None:
    """All rays of a :class:`Fan` by the original's rules (:func:`cast_ray_original`): the sensor's
    cell is the one holding the fan's origin (the original rounds to the nearest cell centre, and
    its cell ``k`` is centred on ``k``: that is our cell ``floor``); each ray ends at the sensor
    cell's centre plus ``max_range`` along the ray, rounded to a cell (:func:`original_end_cell`).
    Distances are not cut at the range: the original's rays can echo up to about one cell beyond it."""
    cx = int(math.floor(fan.origin_x))
    cy = int(math.floor(fan.origin_y))
    for i in range(fan.directions.shape[0]):
        ex = original_end_cell(cx, fan.max_range * fan.directions[i, 0])
        ey = original_end_cell(cy, fan.max_range * fan.directions[i, 1])
        out_t[i], out_v[i] = cast_ray_original(matrix, cx, cy, ex, ey, fan.own_id)


def cast_ray_plain_bresenham_python(
    rows: list[list[int]], ox: float, oy: float, angle: float, max_range: float, self_id: int = 0
) -> tuple[float, int]:
    """A plain 8-connected Bresenham ray in plain Python, the benchmark's speed baseline: from the
    sensor's cell to the rounded end point, first non-zero cell wins; Euclidean distance between
    the two cells; cells of ``self_id`` are passed through. ``rows`` is ``grid.tolist()``. Not the
    original's rules (no extra cell along x, other rounding: it agrees with the original on about
    two thirds of laser rays), and it can slip between two cells that touch at a corner."""
    nx = len(rows)
    ny = len(rows[0])
    x0 = int(math.floor(ox))
    y0 = int(math.floor(oy))
    x1 = int(round(ox + max_range * math.cos(angle)))
    y1 = int(round(oy + max_range * math.sin(angle)))
    ddx = abs(x1 - x0)
    ddy = -abs(y1 - y0)
    sx = 1 if x0 < x1 else -1
    sy = 1 if y0 < y1 else -1
    err = ddx + ddy
    x, y = x0, y0
    while 0 <= x < nx and 0 <= y < ny:
        v = rows[x][y]
        if v and v != self_id:
            return math.hypot(x - x0, y - y0), v
        if x == x1 and y == y1:
            break
        e2 = 2 * err
        if e2 >= ddy:
            err += ddy
            x += sx
        if e2 <= ddx:
            err += ddx
            y += sy
    return math.inf, 0


@numba.njit(cache=True, inline="always")
def _sort_small(xs, m):
    """Insertion sort of ``xs[:m]`` in place: a handful of crossings, and no allocation."""
    for a in range(1, m):
        key = xs[a]
        b = a - 1
        while b >= 0 and xs[b] > key:
            xs[b + 1] = xs[b]
            b -= 1
        xs[b + 1] = key


@numba.njit(cache=True, inline="always")
def _mark_interior(vx, vy, x_lo, y_lo, y_hi, mark):
    """Mark the cells whose centre is inside the polygon: crossing-number test, one scanline per
    column of centres. ``mark`` covers the bounding box from cell ``(x_lo, y_lo)``."""
    n = vx.shape[0]
    xs = np.empty(n)
    for i in range(mark.shape[0]):
        cxp = x_lo + i + 0.5
        m = 0
        for e in range(n):
            ax = vx[e]
            ay = vy[e]
            bx = vx[(e + 1) % n]
            by = vy[(e + 1) % n]
            if (ax <= cxp) != (bx <= cxp):
                xs[m] = ay + (cxp - ax) * (by - ay) / (bx - ax)
                m += 1
        _sort_small(xs, m)
        for k in range(0, m - 1, 2):
            j0 = int(math.ceil(xs[k] - 0.5))
            j1 = int(math.floor(xs[k + 1] - 0.5))
            for j in range(max(j0, y_lo), min(j1, y_hi) + 1):
                mark[i, j - y_lo] = True


@numba.njit(cache=True, inline="always")
def _mark_edges(vx, vy, x_lo, y_lo, mark):
    """Mark every cell an edge of the polygon passes through (exact traversal)."""
    n = vx.shape[0]
    w, h = mark.shape
    for e in range(n):
        ax = vx[e]
        ay = vy[e]
        bx = vx[(e + 1) % n]
        by = vy[(e + 1) % n]
        length = math.hypot(bx - ax, by - ay)
        cx = int(math.floor(ax))
        cy = int(math.floor(ay))
        mark[cx - x_lo, cy - y_lo] = True
        if length == 0.0:
            continue
        ex = int(math.floor(bx))
        ey = int(math.floor(by))
        sx, tdx, tmx = _axis_start((bx - ax) / length, ax, cx, 0.0)
        sy, tdy, tmy = _axis_start((by - ay) / length, ay, cy, 0.0)
        steps = abs(ex - cx) + abs(ey - cy)
        for _ in range(steps):
            if tmx < tmy:
                if tmx > length:
                    break
                cx += sx
                tmx += tdx
            else:
                if tmy > length:
                    break
                cy += sy
                tmy += tdy
            if 0 <= cx - x_lo < w and 0 <= cy - y_lo < h:  # rounding can step past the last cell
                mark[cx - x_lo, cy - y_lo] = True


@numba.njit(cache=True)
def polygon_cells(vx: np.ndarray, vy: np.ndarray, nx: int, ny: int, out: np.ndarray) -> tuple[int, bool]:
    """Every cell the closed polygon (vertices in cells) overlaps: cells whose centre is inside
    plus every cell an edge passes through (exact traversal), so nothing thin is missed.
    Writes flat indices ``x * ny + y`` into ``out`` (must hold the bounding box) and returns
    (count, outside): ``outside`` is True when part of the polygon lies off the map (those cells
    are not listed)."""
    x_lo = int(math.floor(vx.min()))
    x_hi = int(math.floor(vx.max()))
    y_lo = int(math.floor(vy.min()))
    y_hi = int(math.floor(vy.max()))
    outside = x_lo < 0 or y_lo < 0 or x_hi >= nx or y_hi >= ny
    w = x_hi - x_lo + 1
    h = y_hi - y_lo + 1
    mark = np.zeros((w, h), dtype=np.bool_)
    _mark_interior(vx, vy, x_lo, y_lo, y_hi, mark)
    _mark_edges(vx, vy, x_lo, y_lo, mark)
    count = 0
    for i in range(w):
        x = x_lo + i
        if x < 0 or x >= nx:
            continue
        for j in range(h):
            y = y_lo + j
            if mark[i, j] and 0 <= y < ny:
                out[count] = x * ny + y
                count += 1
    return count, outside


@numba.njit(cache=True)
def polygon_outline_cells(vx: np.ndarray, vy: np.ndarray, nx: int, ny: int, out: np.ndarray) -> tuple[int, bool]:
    """The cells of the closed polygon's outline only, as the original paints a robot: each
    vertex's cell (the one holding it: the original rounds to its nearest cell centre), joined to
    the next by the original's midpoint line (:func:`_midpoint_step`). Same contract as
    :func:`polygon_cells`: flat indices ``x * ny + y`` into ``out``, and (count, outside)."""
    n = vx.shape[0]
    x_lo = int(math.floor(vx.min()))
    y_lo = int(math.floor(vy.min()))
    w = int(math.floor(vx.max())) - x_lo + 1
    h = int(math.floor(vy.max())) - y_lo + 1
    mark = np.zeros((w, h), dtype=np.bool_)
    for e in range(n):
        x0 = int(math.floor(vx[e]))
        y0 = int(math.floor(vy[e]))
        x1 = int(math.floor(vx[(e + 1) % n]))
        y1 = int(math.floor(vy[(e + 1) % n]))
        x, y, d = x0, y0, _midpoint_start(x0, y0, x1, y1)
        mark[x - x_lo, y - y_lo] = True
        for _ in range(max(abs(x1 - x0), abs(y1 - y0))):
            x, y, d = _midpoint_step(x, y, d, x0, y0, x1, y1)
            mark[x - x_lo, y - y_lo] = True
    count = 0
    outside = False
    for i in range(w):
        for j in range(h):
            if not mark[i, j]:
                continue
            x = x_lo + i
            y = y_lo + j
            if 0 <= x < nx and 0 <= y < ny:
                out[count] = x * ny + y
                count += 1
            else:
                outside = True
    return count, outside
