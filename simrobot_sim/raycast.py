"""Ray casting and polygon rasterisation on a SIMROBOT occupancy matrix (pure numpy/numba).

The matrix is ``grid[x, y]`` (uint8): 0 free, 1 wall, 2-255 robot id. Cell ``(i, j)`` covers
``[i, i+1) x [j, j+1)`` in cell units, so a point ``p`` lies in cell ``floor(p)``.

Every caster returns the same quantity: the ray parameter ``t`` (cells) at which the ray *enters*
the first cell that is non-zero and not the caster's own robot id (0 when it starts inside one),
plus that cell's value; rays that reach ``max_range`` or leave the map give ``inf`` and 0.

Three casters:

* :func:`cast_rays_exact` — Amanatides-Woo grid traversal, one cell at a time. It visits every
  cell the ray touches, so it cannot slip between two cells that meet at a corner (an
  8-connected Bresenham line can). The reference.
* :func:`cast_rays_fast` — jumps through free space using a clearance field (Euclidean distance
  transform of the static walls, computed once), switches to the exact traversal only near
  walls, and tests robots exactly by traversing just the stretch of the ray inside their
  bounding circle. Same hits as the reference, far fewer cells visited.
* :func:`cast_ray_bresenham_python` — the seed's algorithm in plain Python (benchmark baseline).
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Jumping is worth its re-initialisation only when it skips at least this many cells.
JUMP_MIN = 4.0
_SQRT2 = math.sqrt(2.0)
_FAR = 1.0e9


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
    """Free distance (whole cells) a ray may travel from *any point* of each cell without entering
    a wall cell: centre-to-centre distance minus two half-diagonals, floored, capped at 255.
    uint8 so the table of a 1000x1000 map stays in cache (jumping is latency-bound)."""
    d = np.sqrt(squared_distance_transform(np.ascontiguousarray(walls, dtype=np.bool_)))
    return np.clip(np.floor(d - _SQRT2), 0, 255).astype(np.uint8)


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
    clear: np.ndarray,
    use_clear: bool,
):
    """Amanatides-Woo from ``t_start`` to ``t_end``. Returns (t_hit, value, t_stop, jump): a hit
    when value > 0; otherwise traversal stopped at ``t_stop``, either at the end (jump 0) or, with
    ``use_clear``, on entering a cell whose clearance ``jump`` >= JUMP_MIN lets the ray skip ahead.
    ``only_id`` > 0 counts only cells of that id (exact test of one robot)."""
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
    if dx > 0.0:
        sx = 1
        tdx = 1.0 / dx
        tmx = t_start + (cx + 1 - px) * tdx
    elif dx < 0.0:
        sx = -1
        tdx = -1.0 / dx
        tmx = t_start + (px - cx) * tdx
    else:
        sx = 0
        tdx = np.inf
        tmx = np.inf
    if dy > 0.0:
        sy = 1
        tdy = 1.0 / dy
        tmy = t_start + (cy + 1 - py) * tdy
    elif dy < 0.0:
        sy = -1
        tdy = -1.0 / dy
        tmy = t_start + (py - cy) * tdy
    else:
        sy = 0
        tdy = np.inf
        tmy = np.inf
    t = t_start
    while True:
        v = grid[cx, cy]
        if only_id > 0:
            if v == only_id:
                return t, v, t, 0.0
        elif v != 0 and v != self_id:
            return t, v, t, 0.0
        if use_clear:
            c = clear[cx, cy]
            if c >= JUMP_MIN:
                return np.inf, 0, t, float(c)
        if tmx < tmy:
            t = tmx
            tmx += tdx
            cx += sx
            if cx < 0 or cx >= nx:
                return np.inf, 0, t_end, 0.0
        else:
            t = tmy
            tmy += tdy
            cy += sy
            if cy < 0 or cy >= ny:
                return np.inf, 0, t_end, 0.0
        if t > t_end:
            return np.inf, 0, t_end, 0.0


@numba.njit(cache=True)
def cast_ray_exact(grid, ox, oy, dx, dy, max_range, self_id):
    """One ray, reference traversal. ``(dx, dy)`` is a unit vector. Returns (t, value)."""
    nx, ny = grid.shape
    t0, t1 = _clip_to_map(ox, oy, dx, dy, nx, ny, max_range)
    if t0 > t1:
        return np.inf, 0
    t, v, _, _ = _traverse(grid, ox, oy, dx, dy, t0, t1, self_id, 0, grid, False)
    if t > max_range:
        return np.inf, 0
    return t, v


@numba.njit(cache=True)
def _cast_walls_fast(grid, clear, ox, oy, dx, dy, t0, t1, self_id):
    # Jump while the clearance allows (one table look-up per jump), traverse cell by cell near walls.
    nx, ny = grid.shape
    t = t0
    while t <= t1:
        px = ox + t * dx
        py = oy + t * dy
        # t <= t1 keeps the point in the map box up to rounding: clamp instead of testing
        cx = min(max(int(px), 0), nx - 1)
        cy = min(max(int(py), 0), ny - 1)
        c = clear[cx, cy]
        if c >= JUMP_MIN:
            t += float(c)
            continue
        th, v, ts, jump = _traverse(grid, ox, oy, dx, dy, t, t1, self_id, 0, clear, True)
        if v > 0:
            return th, v
        if jump <= 0.0:
            break
        t = ts + jump
    return np.inf, 0


@numba.njit(cache=True)
def cast_scan_fast(grid, clear, ox, oy, directions, max_range, self_id, cand_x, cand_y, cand_r, cand_id, out_t, out_v):
    """All rays of one sensor from ``(ox, oy)`` (``directions`` (n, 2) unit vectors) with the fast
    caster. ``cand_*`` are robots that may be seen (centre, bounding radius covering every painted
    cell, id); the sensor's own robot is skipped by ``self_id``. Results go to ``out_t``/``out_v``
    (``inf``/0 for no hit within ``max_range``)."""
    nx, ny = grid.shape
    m = cand_id.shape[0]
    # keep the robots a ray of this sensor could reach; store them relative to the origin
    qx = np.empty(m)
    qy = np.empty(m)
    r2 = np.empty(m)
    rr = np.empty(m)
    ids = np.empty(m, dtype=np.int64)
    k = 0
    for j in range(m):
        if cand_id[j] == self_id:
            continue
        ax = cand_x[j] - ox
        ay = cand_y[j] - oy
        if math.sqrt(ax * ax + ay * ay) - cand_r[j] > max_range:
            continue
        qx[k] = ax
        qy[k] = ay
        rr[k] = cand_r[j]
        r2[k] = ax * ax + ay * ay - cand_r[j] * cand_r[j]
        ids[k] = cand_id[j]
        k += 1
    for i in range(directions.shape[0]):
        dx = directions[i, 0]
        dy = directions[i, 1]
        t0, t1 = _clip_to_map(ox, oy, dx, dy, nx, ny, max_range)
        if t0 > t1:
            out_t[i] = np.inf
            out_v[i] = 0
            continue
        best, best_v = _cast_walls_fast(grid, clear, ox, oy, dx, dy, t0, t1, self_id)
        # robots are not in the clearance field: a jump may cross one, so test them exactly
        for j in range(k):
            b = qx[j] * dx + qy[j] * dy
            if b + rr[j] < t0 or b - rr[j] > best:
                continue
            disc = b * b - r2[j]
            if disc < 0.0:
                continue
            s = math.sqrt(disc)
            ta = max(b - s, t0)
            tb = min(b + s, t1, best)
            if ta > tb:
                continue
            th, v, _, _ = _traverse(grid, ox, oy, dx, dy, ta, tb, self_id, ids[j], clear, False)
            if v > 0 and th < best:
                best = th
                best_v = v
        if best > max_range:
            out_t[i] = np.inf
            out_v[i] = 0
        else:
            out_t[i] = best
            out_v[i] = best_v


@numba.njit(cache=True)
def cast_scan_exact(grid, ox, oy, directions, max_range, self_id, out_t, out_v):
    """All rays of one sensor with the reference traversal (same contract as the fast one)."""
    for i in range(directions.shape[0]):
        t, v = cast_ray_exact(grid, ox, oy, directions[i, 0], directions[i, 1], max_range, self_id)
        out_t[i] = t
        out_v[i] = v


def cast_ray_bresenham_python(rows: list, ox: float, oy: float, angle: float, max_range: float) -> tuple[float, int]:
    """The seed's caster (usonic8.c/laser5.c) in plain Python: 8-connected Bresenham from the
    rounded sensor cell to the rounded end point, first non-zero cell wins; Euclidean distance
    between the two cells. ``rows`` is ``grid.tolist()``. Benchmark baseline only: it can slip
    between two cells that touch at a corner."""
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
        if v:
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


@numba.njit(cache=True)
def polygon_cells(vx: np.ndarray, vy: np.ndarray, nx: int, ny: int, out: np.ndarray) -> tuple[int, bool]:
    """Every cell the closed polygon (vertices in cells) overlaps: cells whose centre is inside
    plus every cell an edge passes through (exact traversal), so nothing thin is missed.
    Writes flat indices ``x * ny + y`` into ``out`` (must hold the bounding box) and returns
    (count, outside): ``outside`` is True when part of the polygon lies off the map (those cells
    are not listed)."""
    n = vx.shape[0]
    x_lo = int(math.floor(vx.min()))
    x_hi = int(math.floor(vx.max()))
    y_lo = int(math.floor(vy.min()))
    y_hi = int(math.floor(vy.max()))
    outside = x_lo < 0 or y_lo < 0 or x_hi >= nx or y_hi >= ny
    w = x_hi - x_lo + 1
    h = y_hi - y_lo + 1
    mark = np.zeros((w, h), dtype=np.bool_)
    # interior: crossing-number test of each cell centre, one scanline per column of centres
    xs = np.empty(n)
    for i in range(w):
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
        xs_sorted = np.sort(xs[:m])
        for k in range(0, m - 1, 2):
            j0 = int(math.ceil(xs_sorted[k] - 0.5))
            j1 = int(math.floor(xs_sorted[k + 1] - 0.5))
            for j in range(max(j0, y_lo), min(j1, y_hi) + 1):
                mark[i, j - y_lo] = True
    # boundary: cells crossed by each edge
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
        dx = (bx - ax) / length
        dy = (by - ay) / length
        ex = int(math.floor(bx))
        ey = int(math.floor(by))
        sx = 1 if dx > 0 else -1
        sy = 1 if dy > 0 else -1
        tdx = abs(1.0 / dx) if dx != 0.0 else np.inf
        tdy = abs(1.0 / dy) if dy != 0.0 else np.inf
        tmx = ((cx + 1 - ax) if dx > 0 else (ax - cx)) * tdx if dx != 0.0 else np.inf
        tmy = ((cy + 1 - ay) if dy > 0 else (ay - cy)) * tdy if dy != 0.0 else np.inf
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
            mark[cx - x_lo, cy - y_lo] = True
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
