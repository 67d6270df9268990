"""SIMROBOT world model: many differential-drive robots on a bitmap (pure numpy/numba, no ROS).

Units: the public API speaks metres, radians and rad/s in the world frame (the map's lower-left
corner is at ``origin``); internally everything is in map cells so the kernels index the matrix
directly. The matrix ``grid[x, y]`` holds 0 free, 1 wall and the robot ids (2, 3, ... in file
order), repainted as robots move so sensors see each other, exactly as the original's Table 1.

Where it departs from the original SIMROBOT (filled robot bodies, the lateral velocity, collisions,
the exact sensor model and the ``sensor_model: original`` option), and why: docs/differences.md.
"""

from __future__ import annotations

import copy
import math
import os
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from sim_runtime.angles import wrap_angle, wrap_angle_jit
from sim_runtime.errors import InputError
from sim_runtime.kernels import compiled_aside
from simrobot_sim import raycast
from simrobot_sim.spec import sensor_mount
from simrobot_sim.world_file import MAX_ROBOTS_UINT8, RobotSpec, WorldSpec

_SQRT2 = math.sqrt(2.0)
#: Below these many sensors (robots), sensing (motion) stays on one thread: such a pass takes
#: well under a millisecond, about what handing it to the threads and back costs.
PARALLEL_MIN_SENSORS = 64
PARALLEL_MIN_ROBOTS = 256
#: Work pieces per thread (sensors differ in cost: more pieces balance the threads).
_CHUNKS_PER_THREAD = 4
#: Side (cells) of the buckets used to find the robots a sensor may see.
_BUCKET = 64


def _use_threads(n: int) -> None:
    """Run numba's parallel passes on ``n`` threads.

    Threads that finished their share of a pass sleep instead of spinning: on a machine shared
    with other processes, spinning OpenMP threads take the cores the others need (measured under
    load: 2 spinning threads ran 4x slower than one; sleeping ones 1.3x faster). OpenMP reads
    OMP_WAIT_POLICY once, when numba first starts its threads, which the first call here does:
    set then, not when the model is imported; a setting of the user's own wins."""
    os.environ.setdefault("OMP_WAIT_POLICY", "passive")
    numba.set_num_threads(n)


class RobotTable(NamedTuple):
    """Every robot's state for the kernels, one row per robot (index ``r``, id ``r + 2``), in cells.

    ``pose[r] = (x, y, heading)`` with the heading in radians; ``wheel_speed[r] = (left, right)``
    and ``wheel_accel`` in rad/s and rad/s^2; ``wheel_radius``, ``half_track`` (half the wheel
    distance) and ``axle_offset`` (pivot ahead of the wheel axle) in cells. ``vertices[
    first_vertex[r]:first_vertex[r + 1]]`` is the robot's polygon around its pivot (cells, heading
    east). ``cells[r, :n_cells[r]]`` are the flat matrix indices the robot occupies, ``box[r] =
    (x0, y0, x1, y1)`` their bounds and ``radius[r]`` a circle about the pivot covering them at any
    heading."""

    pose: np.ndarray
    wheel_speed: np.ndarray
    wheel_accel: np.ndarray
    wheel_radius: np.ndarray
    half_track: np.ndarray
    axle_offset: np.ndarray
    power: np.ndarray
    crashed: np.ndarray
    vertices: np.ndarray
    first_vertex: np.ndarray
    cells: np.ndarray
    n_cells: np.ndarray
    box: np.ndarray
    radius: np.ndarray
    id: np.ndarray


class SensorTable(NamedTuple):
    """Every sensor, one row per sensor ``s``, in cells and radians: it sits on robot ``robot[s]``
    at ``position[s]`` (robot frame, x forward) looking along ``axis[s]`` (from the heading), sees
    up to ``max_range[s]``; its rays are ``first_ray[s]:first_ray[s + 1]`` of the ray arrays, at
    ``ray_offset`` from the axis (with its cosine and sine precomputed), rightmost first."""

    robot: np.ndarray
    position: np.ndarray
    axis: np.ndarray
    max_range: np.ndarray
    first_ray: np.ndarray
    ray_offset: np.ndarray
    ray_cos: np.ndarray
    ray_sin: np.ndarray


class Buckets(NamedTuple):
    """Robots sorted into square buckets of ``_BUCKET`` cells (``nbx`` x ``nby`` of them):
    bucket ``b = bx * nby + by`` holds robots ``items[start[b]:start[b + 1]]``."""

    start: np.ndarray
    items: np.ndarray
    nbx: int
    nby: int


class Readings(NamedTuple):
    """Every ray's result, in the sensors' ray order: distance (cells, ``inf`` for no hit) and
    what it hit (1 wall, a robot id, 0 nothing)."""

    distance: np.ndarray
    value: np.ndarray


class SenseScratch(NamedTuple):
    """Working memory of one sensing thread: the turned ray directions of a fan, the robots it
    may see, and the fast caster's scratch."""

    directions: np.ndarray
    candidates: raycast.Candidates
    scan: raycast.ScanScratch


@numba.njit(cache=True)
def _paint(gflat, cells, n, value):
    for k in range(n):
        gflat[cells[k]] = value


@numba.njit(cache=True)
def _outline(verts, v0, v1, x, y, h, vx, vy):
    c = math.cos(h)
    s = math.sin(h)
    m = v1 - v0
    for k in range(m):
        px = verts[v0 + k, 0]
        py = verts[v0 + k, 1]
        vx[k] = x + c * px - s * py
        vy[k] = y + s * px + c * py
    return m


@numba.njit(cache=True)
def _cell_box(vx, vy, out):
    # bounds of every cell the polygon overlaps (the sensors' exact test of a robot stays inside)
    out[0] = math.floor(vx.min())
    out[1] = math.floor(vy.min())
    out[2] = math.floor(vx.max()) + 1.0
    out[3] = math.floor(vy.max()) + 1.0


@numba.njit(cache=True, inline="always")
def _drive(robots, r, dt):
    # The robot's pose after one step of its wheel speeds (the original's mmodel with the lateral
    # velocity rotated into the world), from the heading before the step.
    robots.wheel_speed[r, 0] += robots.wheel_accel[r, 0] * dt
    robots.wheel_speed[r, 1] += robots.wheel_accel[r, 1] * dt
    w1 = robots.wheel_speed[r, 0]
    w2 = robots.wheel_speed[r, 1]
    v = robots.wheel_radius[r] * (w1 + w2) * 0.5
    omega = robots.wheel_radius[r] * (w2 - w1) / (2.0 * robots.half_track[r])
    v_lat = robots.axle_offset[r] * omega
    h = robots.pose[r, 2]
    c = math.cos(h)
    s = math.sin(h)
    x = robots.pose[r, 0] + dt * (v * c - v_lat * s)
    y = robots.pose[r, 1] + dt * (v * s + v_lat * c)
    return x, y, h + omega * dt


class MovePlan(NamedTuple):
    """Where every robot would go this step, worked out from its own state alone (so robots can be
    planned on any number of threads): ``moving[r]`` when its pose changes, the new ``pose``, the
    ``cells`` its polygon would occupy there (``n_cells`` of them; ``outside`` when part of it is
    off the map) and their ``box``."""

    moving: np.ndarray
    pose: np.ndarray
    cells: np.ndarray
    n_cells: np.ndarray
    outside: np.ndarray
    box: np.ndarray


def _move_plan(n: int, cells_per_robot: int) -> MovePlan:
    return MovePlan(
        np.zeros(n, dtype=np.bool_),
        np.zeros((n, 3)),
        np.zeros((n, cells_per_robot), dtype=np.int64),
        np.zeros(n, dtype=np.int64),
        np.zeros(n, dtype=np.bool_),
        np.zeros((n, 4)),
    )


@numba.njit(cache=True)
def _body_cells(vx, vy, nx, ny, out, outline):
    # the cells a robot's polygon occupies: all it overlaps, or (the original's) its outline only
    if outline:
        return raycast.polygon_outline_cells(vx, vy, nx, ny, out)
    return raycast.polygon_cells(vx, vy, nx, ny, out)


@numba.njit(cache=True, inline="always")
def _plan_one(shape, robots, r, dt, plan, vx, vy, outline):
    # robot r's move, if powered, not crashed and its pose changes (the wheel speeds take the
    # acceleration even when it does not)
    plan.moving[r] = False
    if not robots.power[r] or robots.crashed[r]:
        return
    x, y, hn = _drive(robots, r, dt)
    if x == robots.pose[r, 0] and y == robots.pose[r, 1] and hn == robots.pose[r, 2]:
        return
    m = _outline(robots.vertices, robots.first_vertex[r], robots.first_vertex[r + 1], x, y, hn, vx, vy)
    n, outside = _body_cells(vx[:m], vy[:m], shape[0], shape[1], plan.cells[r], outline)
    _cell_box(vx[:m], vy[:m], plan.box[r])
    plan.moving[r] = True
    plan.pose[r, 0] = x
    plan.pose[r, 1] = y
    plan.pose[r, 2] = hn
    plan.n_cells[r] = n
    plan.outside[r] = outside


@numba.njit(cache=True)
def _plan_range(shape, robots, dt, plan, first, last, vx, vy, outline):
    # robots first..last-1: one compiled function for one thread or many (bit-identical plans)
    for r in range(first, last):
        _plan_one(shape, robots, r, dt, plan, vx, vy, outline)


@numba.njit(cache=True)
def _plan_moves(shape, robots, dt, plan, outline):
    """Every robot's planned move (:class:`MovePlan`), on this thread; ``outline``: robots occupy
    only their outline's cells (:func:`_body_cells`)."""
    _plan_range(shape, robots, dt, plan, 0, robots.pose.shape[0], np.empty(64), np.empty(64), outline)


@numba.njit(cache=True, parallel=True)
def _plan_moves_parallel(shape, robots, dt, plan, chunks, outline):
    """:func:`_plan_moves` on all threads, robots in ``chunks`` contiguous runs (a robot's plan
    depends on its own state only, so it is the same whatever the threads)."""
    n = robots.pose.shape[0]
    # made before the loop: an allocation inside it could be hoisted and shared by the threads
    corners = np.empty((chunks, 2, 64))
    for c in numba.prange(chunks):
        first, last = c * n // chunks, (c + 1) * n // chunks
        _plan_range(shape, robots, dt, plan, first, last, corners[c, 0], corners[c, 1], outline)


@numba.njit(cache=True)
def _commit_moves(grid, robots, plan, hit_by):
    """Carry out the planned moves in id order (later robots see earlier ones' new positions, as
    the original's sequential update): a robot whose new cells are free moves and is repainted there,
    else it crashes where it was. ``hit_by[r]`` > 0 marks a robot crashed into by another this
    step (applied by the caller after the loop, as the original)."""
    gflat = grid.reshape(-1)
    for r in range(robots.pose.shape[0]):
        if not plan.moving[r]:
            continue
        own = robots.id[r]
        _paint(gflat, robots.cells[r], robots.n_cells[r], 0)
        n = plan.n_cells[r]
        blocked = plan.outside[r]
        for k in range(n):
            value = gflat[plan.cells[r, k]]
            if value != 0:
                blocked = True
                if value >= 2 and value != own:
                    hit_by[value - 2] = own
        if blocked:
            _paint(gflat, robots.cells[r], robots.n_cells[r], own)
            robots.crashed[r] = True
            continue
        _paint(gflat, plan.cells[r], n, own)
        robots.cells[r, :n] = plan.cells[r, :n]
        robots.n_cells[r] = n
        robots.box[r, :] = plan.box[r, :]
        robots.pose[r, 0] = plan.pose[r, 0]
        robots.pose[r, 1] = plan.pose[r, 1]
        robots.pose[r, 2] = wrap_angle_jit(plan.pose[r, 2])


@numba.njit(cache=True, inline="always")
def _disc_meets_cone(qx, qy, d2, r, e1x, e1y, e2x, e2y):
    # Does the disc (centre q, radius r) meet the convex cone from the origin between the unit
    # directions e1 and e2 (counter-clockwise)? Inside, or within r of one of its two edges.
    if e1x * qy - e1y * qx >= 0.0 and qx * e2y - qy * e2x >= 0.0:
        return True
    r2 = r * r
    for ex, ey in ((e1x, e1y), (e2x, e2y)):
        along = qx * ex + qy * ey
        across = qx * ey - qy * ex
        if (along >= 0.0 and across * across <= r2) or (along < 0.0 and d2 <= r2):
            return True
    return False


#: How a fan limits the robots it can see: a convex cone, a half-plane, or not at all.
_CONE, _HALF_PLANE, _ALL_AROUND = 0, 1, 2


class _Sector(NamedTuple):
    # the fan's sector: its kind, its middle direction (half-plane) and its edges (cone)
    kind: int
    mid_x: float
    mid_y: float
    e1x: float
    e1y: float
    e2x: float
    e2y: float


@numba.njit(cache=True, inline="always")
def _sensor_fan(robots, sensors, s, directions):
    # Sensor s's origin (cells) and axis angle, and its rays' directions turned into the world
    # (the fixed offsets' unit vectors rotated by heading + axis: no trig per ray).
    r = sensors.robot[s]
    h = robots.pose[r, 2]
    c = math.cos(h)
    sn = math.sin(h)
    px = sensors.position[s, 0]
    py = sensors.position[s, 1]
    ox = robots.pose[r, 0] + c * px - sn * py
    oy = robots.pose[r, 1] + sn * px + c * py
    a0 = sensors.first_ray[s]
    axis = h + sensors.axis[s]
    ca = math.cos(axis)
    sa = math.sin(axis)
    for k in range(sensors.first_ray[s + 1] - a0):
        directions[k, 0] = ca * sensors.ray_cos[a0 + k] - sa * sensors.ray_sin[a0 + k]
        directions[k, 1] = sa * sensors.ray_cos[a0 + k] + ca * sensors.ray_sin[a0 + k]
    return ox, oy, axis


@numba.njit(cache=True, inline="always")
def _fan_sector(sensors, s, axis, directions):
    # The region the fan's rays sweep, to keep only robots whose bounding circle can meet a ray:
    # a convex cone between the first and last ray, a half-plane for a 180 degree fan, else all.
    a0 = sensors.first_ray[s]
    last = sensors.first_ray[s + 1] - 1
    nr = last - a0 + 1
    span = abs(sensors.ray_offset[last] - sensors.ray_offset[a0])
    mid = axis + 0.5 * (sensors.ray_offset[a0] + sensors.ray_offset[last])
    kind = _CONE if span < math.pi - 1e-9 else (_HALF_PLANE if span <= math.pi + 1e-9 else _ALL_AROUND)
    if sensors.ray_offset[last] >= sensors.ray_offset[a0]:
        first, final = 0, nr - 1
    else:
        first, final = nr - 1, 0
    return _Sector(
        kind,
        math.cos(mid),
        math.sin(mid),
        directions[first, 0],
        directions[first, 1],
        directions[final, 0],
        directions[final, 1],
    )


@numba.njit(cache=True, inline="always")
def _bucket_in_reach(bx, by, ox, oy, reach, sector, rmax):
    # Can any robot sorted into bucket (bx, by) be seen? Whole buckets out of reach or behind a
    # 180 degree fan are skipped unread.
    gx = min(max(ox, bx * _BUCKET), (bx + 1) * _BUCKET) - ox
    gy = min(max(oy, by * _BUCKET), (by + 1) * _BUCKET) - oy
    if gx * gx + gy * gy > reach * reach:
        return False
    if sector.kind == _HALF_PLANE:
        fx = ((bx + 1) * _BUCKET if sector.mid_x > 0.0 else bx * _BUCKET) - ox
        fy = ((by + 1) * _BUCKET if sector.mid_y > 0.0 else by * _BUCKET) - oy
        if fx * sector.mid_x + fy * sector.mid_y < -rmax:
            return False
    return True


@numba.njit(cache=True, inline="always")
def _robot_in_sector(qx, qy, rj, max_range, sector):
    # May robot j (pivot q relative to the sensor, bounding radius rj) meet one of the rays?
    d2 = qx * qx + qy * qy
    if d2 > (max_range + rj) * (max_range + rj):
        return False  # beyond the range
    if sector.kind == _HALF_PLANE and qx * sector.mid_x + qy * sector.mid_y < -rj:
        return False  # behind a 180 degree fan
    return sector.kind != _CONE or _disc_meets_cone(qx, qy, d2, rj, sector.e1x, sector.e1y, sector.e2x, sector.e2y)


@numba.njit(cache=True, inline="always")
def _gather_candidates(robots, buckets, own, ox, oy, max_range, rmax, sector, cand):
    # The robots sensor origin (ox, oy) may see into ``cand``, nearest buckets first (square rings
    # around the sensor's bucket): the caster tests candidates in this order, so near robots
    # shorten the rays before far ones are tried. Returns their number.
    reach = max_range + rmax
    bx0 = max(int((ox - reach) // _BUCKET), 0)
    bx1 = min(int((ox + reach) // _BUCKET), buckets.nbx - 1)
    by0 = max(int((oy - reach) // _BUCKET), 0)
    by1 = min(int((oy + reach) // _BUCKET), buckets.nby - 1)
    cbx = min(max(int(ox // _BUCKET), bx0), bx1)
    cby = min(max(int(oy // _BUCKET), by0), by1)
    rings = max(cbx - bx0, bx1 - cbx, cby - by0, by1 - cby)
    m = 0
    for ring in range(rings + 1):
        for bx in range(max(cbx - ring, bx0), min(cbx + ring, bx1) + 1):
            edge = bx == cbx - ring or bx == cbx + ring
            # inside the ring's left and right columns only its top and bottom rows are new
            step = 1 if edge else max(2 * ring, 1)
            for by in range(cby - ring, cby + ring + 1, step):
                if by < by0 or by > by1 or not _bucket_in_reach(bx, by, ox, oy, reach, sector, rmax):
                    continue
                b = bx * buckets.nby + by
                for q in range(buckets.start[b], buckets.start[b + 1]):
                    j = buckets.items[q]
                    if j == own:
                        continue
                    rj = robots.radius[j]
                    if not _robot_in_sector(robots.pose[j, 0] - ox, robots.pose[j, 1] - oy, rj, max_range, sector):
                        continue
                    cand.x[m] = robots.pose[j, 0]
                    cand.y[m] = robots.pose[j, 1]
                    cand.radius[m] = rj
                    cand.box[m, 0] = robots.box[j, 0]
                    cand.box[m, 1] = robots.box[j, 1]
                    cand.box[m, 2] = robots.box[j, 2]
                    cand.box[m, 3] = robots.box[j, 3]
                    cand.id[m] = robots.id[j]
                    m += 1
    return m


@numba.njit(cache=True)
def _sense_scratch(robots, sensors):
    n_rob = robots.pose.shape[0]
    max_rays = 0
    for s in range(sensors.robot.shape[0]):
        max_rays = max(max_rays, sensors.first_ray[s + 1] - sensors.first_ray[s])
    candidates = raycast.Candidates(
        np.empty(n_rob), np.empty(n_rob), np.empty(n_rob), np.empty((n_rob, 4)), np.empty(n_rob, dtype=np.int64)
    )
    scan = raycast.scan_scratch(max_rays)
    return SenseScratch(np.empty((max_rays, 2)), candidates, scan)


@numba.njit(cache=True, inline="always")
def _sense_one(grid, robots, sensors, buckets, s, rmax, scratch, out):
    # Every ray of sensor s, with the fast caster, into ``out``.
    dirs = scratch.directions
    ox, oy, axis = _sensor_fan(robots, sensors, s, dirs)
    sector = _fan_sector(sensors, s, axis, dirs)
    r = sensors.robot[s]
    max_range = sensors.max_range[s]
    m = _gather_candidates(robots, buckets, r, ox, oy, max_range, rmax, sector, scratch.candidates)
    c = scratch.candidates
    a0 = sensors.first_ray[s]
    nr = sensors.first_ray[s + 1] - a0
    step = sensors.ray_offset[a0 + 1] - sensors.ray_offset[a0] if nr > 1 else 0.0
    fan = raycast.Fan(ox, oy, dirs[:nr], axis + sensors.ray_offset[a0], step, max_range, robots.id[r])
    seen = raycast.Candidates(c.x[:m], c.y[:m], c.radius[:m], c.box[:m], c.id[:m])
    raycast.cast_scan_fast_into(grid, fan, seen, out.distance[a0 : a0 + nr], out.value[a0 : a0 + nr], scratch.scan)


@numba.njit(cache=True)
def _sense_range(grid, robots, sensors, buckets, first, last, rmax, scratch, out):
    # sensors first..last-1: one compiled function whether one thread runs them all or many
    # threads share them, so the readings are bit for bit the same
    for s in range(first, last):
        _sense_one(grid, robots, sensors, buckets, s, rmax, scratch, out)


@numba.njit(cache=True)
def _sense(grid, robots, sensors, buckets, out):
    """Cast every ray of every sensor (fast caster) into ``out``; the robots a fan may see come
    from the buckets."""
    rmax = robots.radius.max() if robots.pose.shape[0] > 0 else 0.0
    _sense_range(grid, robots, sensors, buckets, 0, sensors.robot.shape[0], rmax, _sense_scratch(robots, sensors), out)


@numba.njit(cache=True, parallel=True)
def _sense_parallel(grid, robots, sensors, buckets, out, chunks):
    """:func:`_sense` on all threads: sensors in ``chunks`` contiguous runs, each with its own
    scratch. A sensor's readings depend on nothing but the world, so they are those of the serial
    cast whatever the threads."""
    rmax = robots.radius.max() if robots.pose.shape[0] > 0 else 0.0
    n_sensors = sensors.robot.shape[0]
    # made before the loop: an allocation inside it could be hoisted and shared by the threads
    scratches = [_sense_scratch(robots, sensors) for _ in range(chunks)]
    for c in numba.prange(chunks):
        first = c * n_sensors // chunks
        last = (c + 1) * n_sensors // chunks
        _sense_range(grid, robots, sensors, buckets, first, last, rmax, scratches[c], out)


@numba.njit(cache=True)
def _sense_original(matrix, robots, sensors, out, see_own):
    """Cast every ray of every sensor by the original SIMROBOT's rules (``sensor_model: original``);
    ``see_own``: a sensor sees its own robot's cells too, as the original's."""
    n_sensors = sensors.robot.shape[0]
    max_rays = 0
    for s in range(n_sensors):
        max_rays = max(max_rays, sensors.first_ray[s + 1] - sensors.first_ray[s])
    dirs = np.empty((max_rays, 2))
    for s in range(n_sensors):
        ox, oy, axis = _sensor_fan(robots, sensors, s, dirs)
        a0 = sensors.first_ray[s]
        nr = sensors.first_ray[s + 1] - a0
        step = sensors.ray_offset[a0 + 1] - sensors.ray_offset[a0] if nr > 1 else 0.0
        own = 0 if see_own else robots.id[sensors.robot[s]]
        fan = raycast.Fan(ox, oy, dirs[:nr], axis + sensors.ray_offset[a0], step, sensors.max_range[s], own)
        raycast.cast_scan_original(matrix, fan, out.distance[a0 : a0 + nr], out.value[a0 : a0 + nr])


@numba.njit(cache=True)
def _nearest(first_ray, rays, nearest):
    # every sensor's nearest ray (the first of equals), as an ultrasonic sensor reads
    for s in range(first_ray.shape[0] - 1):
        best = np.inf
        value = 0
        for k in range(first_ray[s], first_ray[s + 1]):
            if rays.distance[k] < best:
                best = rays.distance[k]
                value = rays.value[k]
        nearest.distance[s] = best
        nearest.value[s] = value


def ray_offsets(beamwidth: float, rays: int, sensor_model: str = "exact") -> np.ndarray:
    """Ray angles relative to the sensor axis, counter-clockwise from the rightmost ray. Exact
    model: evenly from -beamwidth/2 to +beamwidth/2 inclusive (one ray: along the axis). The
    original's: from -beamwidth/2 in steps of beamwidth/rays, so the left edge is left out
    (-30 to +28 degrees for 60 degrees and 30 rays; one ray: -beamwidth/2)."""
    if sensor_model == "original":
        return -0.5 * beamwidth + np.arange(rays) * (beamwidth / rays)
    if rays == 1:
        return np.zeros(1)
    return np.linspace(-0.5 * beamwidth, 0.5 * beamwidth, rays)


@dataclass(frozen=True)
class SensorInfo:
    """Where a sensor's rays live in the flat arrays, and its spec in SI units."""

    robot: int
    name: str
    kind: str
    first_ray: int
    rays: int
    range: float
    beamwidth: float
    position: tuple[float, float]
    axis: float
    #: Angles of the first and last ray from the axis and between neighbouring rays (rad).
    angle_min: float = 0.0
    angle_max: float = 0.0
    angle_increment: float = 0.0


@numba.njit(cache=True)
def _world_poses(pose: np.ndarray, resolution: float, origin: np.ndarray) -> np.ndarray:
    """Poses (n, 3) in cells → metres (x, y; heading as is). A kernel: the world's step records
    them every step, and numpy's three small array operations cost more than the arithmetic."""
    out = np.empty_like(pose)
    for i in range(pose.shape[0]):
        out[i, 0] = pose[i, 0] * resolution + origin[0]
        out[i, 1] = pose[i, 1] * resolution + origin[1]
        out[i, 2] = pose[i, 2]
    return out


class PoseHistory:
    """Every robot's pose per step in bounded memory: a ring of fixed-size chunks (float32
    x, y, heading). Memory is ``capacity`` steps x robots x 12 bytes at most."""

    def __init__(self, n_robots: int, capacity: int, chunk: int = 1024) -> None:
        self.n_robots = n_robots
        self.chunk = max(1, min(chunk, capacity))
        self.max_chunks = max(1, math.ceil(capacity / self.chunk))
        self._chunks: list[np.ndarray] = []
        self._fill = self.chunk  # forces a new chunk on first append
        self.dropped = 0

    def append(self, poses: np.ndarray) -> None:
        """Store one row per robot (``poses`` shape (n_robots, 3), metres/radians)."""
        if self._fill == self.chunk:
            if len(self._chunks) == self.max_chunks:
                oldest = self._chunks.pop(0)
                self.dropped += self.chunk
                self._chunks.append(oldest)  # reuse its memory
            else:
                self._chunks.append(np.empty((self.chunk, self.n_robots, 3), dtype=np.float32))
            self._fill = 0
        self._chunks[-1][self._fill] = poses
        self._fill += 1

    def __len__(self) -> int:
        return 0 if not self._chunks else (len(self._chunks) - 1) * self.chunk + self._fill

    def array(self) -> np.ndarray:
        """All kept rows, oldest first: shape (steps, n_robots, 3)."""
        if not self._chunks:
            return np.empty((0, self.n_robots, 3), dtype=np.float32)
        parts = [*self._chunks[:-1], self._chunks[-1][: self._fill]]
        return np.concatenate(parts, axis=0)

    def nbytes(self) -> int:
        """Memory held by the history arrays."""
        return sum(c.nbytes for c in self._chunks)


class SimrobotWorld:
    """The whole world: matrix, robots, sensors and history. Step it with :meth:`step`.

    Everything public is in metres, radians and seconds (world frame: the map's lower-left corner
    is at ``origin``). ``grid`` is the occupancy matrix itself, indexed by cell ``[x, y]``
    (0 free, 1 wall, robot ids). The kernels' cell-unit state lives in the private tables."""

    def __init__(
        self,
        spec: WorldSpec,
        *,
        wide_ids: bool = False,
        threads: int | None = None,
        outline_bodies: bool = False,
        see_own_robot: bool = False,
    ) -> None:
        """Place every robot of ``spec``. More than 254 robots need ``wide_ids=True`` (a uint16
        matrix; the ROS node keeps the original's uint8 ids so obstacle numbers fit ``UInt8``).
        ``threads``: how many threads sense and move the robots (default: the world file's
        ``threads``; 0 = every core numba may use, ``NUMBA_NUM_THREADS`` caps it). Results are
        bit for bit the same whatever the number; small worlds stay on one thread.

        Two of the original's rules, off by default: ``outline_bodies``, a robot occupies only the
        cells of its polygon's outline (sensors see and robots collide with that alone);
        ``see_own_robot`` (``sensor_model: original`` only), a sensor sees its own robot's cells
        too, reading 0 when it lies on them."""
        if see_own_robot and spec.sensor_model != "original":
            raise InputError(f"{spec.source}: seeing a sensor's own robot needs sensor_model: original")
        #: Robots occupy their outline's cells only (the original's painting), not every cell they overlap.
        self.outline_bodies = bool(outline_bodies)
        #: Sensors see their own robot (the original's rule; ``sensor_model: original`` only).
        self.see_own_robot = bool(see_own_robot)
        n = len(spec.robots)
        if n > MAX_ROBOTS_UINT8 and not wide_ids:
            raise InputError(
                f"{spec.source}: robots: {n} robots, but ids are uint8 as the original's matrix "
                f"(2-255): at most {MAX_ROBOTS_UINT8} robots"
            )
        if n > 65533:
            raise InputError(f"{spec.source}: robots: {n} robots is more than 65533")
        self.spec = spec
        self.resolution = float(spec.resolution)
        self.origin = np.array(spec.origin, dtype=float)
        self.dt = float(spec.dt)
        #: ``exact`` (ours) or ``original`` (the original SIMROBOT's sensor rules).
        self.sensor_model = spec.sensor_model
        wanted = spec.threads if threads is None else threads
        if isinstance(wanted, bool) or not isinstance(wanted, int) or wanted < 0:
            raise InputError(f"{spec.source}: threads: expected an integer >= 0 (0 = all cores), got {wanted!r}")
        #: Threads used for sensing and motion (1: serial).
        # numba.config sets its settings through globals() at import: mypy cannot see them
        most = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
        self.threads = min(wanted or most, most)
        self.names = [r.name for r in spec.robots]
        self.index = {name: i for i, name in enumerate(self.names)}
        self.ids = np.arange(2, n + 2, dtype=np.int64)
        dtype = np.uint8 if n <= MAX_ROBOTS_UINT8 else np.uint16
        self.grid = np.ascontiguousarray(spec.walls, dtype=dtype)
        nx, ny = self.grid.shape
        self._grid = raycast.Occupancy(self.grid, raycast.clearance_field(spec.walls))
        self._nbx = nx // _BUCKET + 1
        self._nby = ny // _BUCKET + 1
        #: Wheel speeds [left, right] (rad/s) and accelerations (rad/s^2) of every robot.
        self.vel = np.zeros((n, 2))
        self.accel = np.zeros((n, 2))
        self.power = np.array([r.power for r in spec.robots], dtype=np.bool_)
        self.crashed = np.zeros(n, dtype=np.bool_)
        self.colors = np.array([r.color for r in spec.robots], dtype=float).reshape(n, 3)
        self._robots = self._robot_table(spec.robots)
        self._plan = _move_plan(n, self._robots.cells.shape[1])
        self._build_sensors(spec.robots)
        for i, robot in enumerate(spec.robots):
            self._place(i, robot)
        self._start_pose = self._robots.pose.copy()
        self.step_count = 0
        self.history = PoseHistory(n, spec.history_steps)
        self.history.append(self.poses())
        self._sensed_at = -1

    # -- construction -----------------------------------------------------------------------
    def _robot_table(self, robots: tuple[RobotSpec, ...]) -> RobotTable:
        res = self.resolution
        n = len(robots)
        shapes = [np.asarray(r.shape, dtype=float) * r.scale / res for r in robots]
        if any(len(s) > 64 for s in shapes):
            raise InputError(f"{self.spec.source}: robots: a shape has more than 64 vertices")
        first_vertex = np.zeros(n + 1, dtype=np.int64)
        first_vertex[1:] = np.cumsum([len(s) for s in shapes])
        # covers every cell the polygon overlaps, whatever the heading
        radius = np.array([np.hypot(s[:, 0], s[:, 1]).max() + _SQRT2 + 1e-6 for s in shapes])
        side = int(2 * math.ceil(radius.max() if n else 1) + 3)
        return RobotTable(
            pose=np.zeros((n, 3)),
            wheel_speed=self.vel,
            wheel_accel=self.accel,
            wheel_radius=np.array([r.R / res for r in robots]),
            half_track=np.array([r.la / res for r in robots]),
            axle_offset=np.array([r.lb / res for r in robots]),
            power=self.power,
            crashed=self.crashed,
            vertices=np.concatenate(shapes) if shapes else np.zeros((0, 2)),
            first_vertex=first_vertex,
            cells=np.zeros((n, side * side), dtype=np.int64),
            n_cells=np.zeros(n, dtype=np.int64),
            box=np.zeros((n, 4)),
            radius=radius,
            id=self.ids,
        )

    def _build_sensors(self, robots: tuple[RobotSpec, ...]) -> None:
        res = self.resolution
        infos: list[SensorInfo] = []
        offsets: list[np.ndarray] = []
        mounts: list[tuple[float, float, float]] = []
        first = 0
        for i, robot in enumerate(robots):
            for s in robot.sensors:
                mounts.append(sensor_mount(robot, s))
                off = ray_offsets(s.beamwidth, s.rays, self.sensor_model)
                step = 0.0 if s.rays == 1 else s.beamwidth / (s.rays if self.sensor_model == "original" else s.rays - 1)
                infos.append(
                    SensorInfo(
                        i,
                        s.name,
                        s.kind,
                        first,
                        s.rays,
                        s.range,
                        s.beamwidth,
                        s.position,
                        s.axis,
                        float(off[0]),
                        float(off[-1]),
                        step,
                    )
                )
                offsets.append(off)
                first += s.rays
        self.sensors = infos
        self.sensor_index = {(self.names[s.robot], s.name): k for k, s in enumerate(infos)}
        first_ray = np.zeros(len(infos) + 1, dtype=np.int64)
        first_ray[1:] = np.cumsum([s.rays for s in infos])
        ray_offset = np.concatenate(offsets) if offsets else np.zeros(0)
        self._sensors = SensorTable(
            robot=np.array([s.robot for s in infos], dtype=np.int64),
            # the sensor sits on the body, so it scales with the robot; its range does not (seed)
            position=np.array([[x / res, y / res] for x, y, _axis in mounts]).reshape(-1, 2),
            axis=np.array([s.axis for s in infos], dtype=float),
            max_range=np.array([s.range / res for s in infos], dtype=float),
            first_ray=first_ray,
            ray_offset=ray_offset,
            ray_cos=np.cos(ray_offset),
            ray_sin=np.sin(ray_offset),
        )
        self._readings = Readings(np.full(first, np.inf), np.zeros(first, dtype=np.int64))
        self._nearest = Readings(np.full(len(infos), np.inf), np.zeros(len(infos), dtype=np.int64))

    def _place(self, i: int, robot: RobotSpec) -> None:
        nx, ny = self.grid.shape
        rob = self._robots
        x, y = (np.array(robot.position) - self.origin) / self.resolution
        rob.pose[i] = (x, y, wrap_angle(robot.heading))
        vx, vy = self._outline(i)
        tmp = np.empty(rob.cells.shape[1], dtype=np.int64)
        n, outside = _body_cells(vx, vy, nx, ny, tmp, self.outline_bodies)
        where = f"{self.spec.source}: robots[{i}] ({robot.name!r}).position {list(robot.position)}"
        if outside:
            raise InputError(f"{where}: the robot does not fit inside the map")
        flat = self.grid.reshape(-1)
        values = flat[tmp[:n]]
        if np.any(values == 1):
            raise InputError(f"{where}: the robot is placed on an obstacle (wall)")
        others = sorted({int(v) for v in values if v >= 2})
        if others:
            other = self.names[others[0] - 2]
            raise InputError(f"{where}: the robot overlaps robot {other!r} (robots[{others[0] - 2}])")
        flat[tmp[:n]] = i + 2
        rob.cells[i, :n] = tmp[:n]
        rob.n_cells[i] = n
        _cell_box(vx, vy, rob.box[i])

    def _outline(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        # robot i's polygon in cells at its current pose
        rob = self._robots
        v = rob.vertices[rob.first_vertex[i] : rob.first_vertex[i + 1]]
        x, y, h = rob.pose[i]
        c, s = math.cos(h), math.sin(h)
        return x + c * v[:, 0] - s * v[:, 1], y + s * v[:, 0] + c * v[:, 1]

    # -- commands (SI units) ----------------------------------------------------------------
    def robot(self, name: str) -> int:
        """Index of the robot called ``name`` (its id is index + 2)."""
        try:
            return self.index[name]
        except KeyError:
            raise InputError(f"no robot named {name!r}; robots: {', '.join(self.names)}") from None

    def set_wheel_speeds(self, i: int, left: float, right: float) -> None:
        """The original's ``setvel``: wheel angular velocities (rad/s). NaN/inf raise InputError."""
        if not (math.isfinite(left) and math.isfinite(right)):
            raise InputError(f"robot {self.names[i]!r}: wheel speeds must be finite, got [{left}, {right}]")
        self.vel[i] = (left, right)

    def set_wheel_accels(self, i: int, left: float, right: float) -> None:
        """The original's ``setaccel``: added to the wheel speeds every step (rad/s^2) until changed."""
        if not (math.isfinite(left) and math.isfinite(right)):
            raise InputError(f"robot {self.names[i]!r}: wheel accelerations must be finite, got [{left}, {right}]")
        self.accel[i] = (left, right)

    def wheel_speeds_for(self, i: int, v: float, omega: float) -> tuple[float, float]:
        """The original's ``invmodel``: wheel speeds (rad/s) giving forward speed ``v`` (m/s) and yaw
        rate ``omega`` (rad/s) exactly. With ``lb`` != 0 the body also drifts sideways by
        ``lb * omega`` (a differential drive cannot avoid it)."""
        res = self.resolution
        r = self._robots.wheel_radius[i] * res
        la = self._robots.half_track[i] * res
        return (v - la * omega) / r, (v + la * omega) / r

    def set_cmd_vel(self, i: int, v: float, omega: float) -> None:
        """Forward speed (m/s) and yaw rate (rad/s) through the inverse model."""
        if not (math.isfinite(v) and math.isfinite(omega)):
            raise InputError(f"robot {self.names[i]!r}: cmd_vel must be finite, got v={v}, omega={omega}")
        with np.errstate(over="ignore", invalid="ignore"):  # checked just below
            speeds = self.wheel_speeds_for(i, v, omega)
        if not all(math.isfinite(s) for s in speeds):  # e.g. 1e308 m/s overflows in cells/s
            raise InputError(f"robot {self.names[i]!r}: cmd_vel v={v}, omega={omega} gives wheel speeds {speeds}")
        self.vel[i] = speeds

    def set_power(self, i: int, on: bool) -> None:
        """The original's ``setpower``: an unpowered robot keeps its place."""
        self.power[i] = bool(on)

    def clear_crash(self, i: int) -> None:
        """The original's ``clearcf``: the robot may move again (from its last free pose)."""
        self.crashed[i] = False

    # -- simulation -------------------------------------------------------------------------
    def step(self) -> np.ndarray:
        """Advance one step of ``dt``; returns the indices of robots that crashed in it."""
        before = self.crashed.copy()
        hit_by = np.zeros(len(self.names), dtype=np.int64)
        plan = self._plan
        if self.threads > 1 and len(self.names) >= PARALLEL_MIN_ROBOTS:
            _use_threads(self.threads)
            chunks = self.threads * _CHUNKS_PER_THREAD
            _plan_moves_parallel(self.grid.shape, self._robots, self.dt, plan, chunks, self.outline_bodies)
        else:
            _plan_moves(self.grid.shape, self._robots, self.dt, plan, self.outline_bodies)
        _commit_moves(self.grid, self._robots, plan, hit_by)
        # robot-on-robot crashes both (applied after everyone moved, as the original)
        self.crashed |= hit_by > 0
        self.step_count += 1
        self.history.append(self.poses())
        return np.flatnonzero(self.crashed & ~before)

    def sense(self) -> None:
        """Cast every sensor's rays at the current poses (cached until the next step)."""
        if self._sensed_at == self.step_count or len(self.sensors) == 0:
            return
        if self.sensor_model == "original":
            _sense_original(self.grid, self._robots, self._sensors, self._readings, self.see_own_robot)
        elif self.threads > 1 and len(self.sensors) >= PARALLEL_MIN_SENSORS:
            _use_threads(self.threads)
            chunks = min(self.threads * _CHUNKS_PER_THREAD, len(self.sensors))
            _sense_parallel(self._grid, self._robots, self._sensors, self._buckets(), self._readings, chunks)
        else:
            _sense(self._grid, self._robots, self._sensors, self._buckets(), self._readings)
        _nearest(self._sensors.first_ray, self._readings, self._nearest)
        self._sensed_at = self.step_count

    def compile_kernels(self) -> None:
        """Step and sense a copy of this world once: every numba kernel it uses (serial or threaded,
        its sensor model, its id width) is compiled, or loaded from numba's cache, now rather than
        at its first step. This world is untouched.

        When numba has to compile (its cache is cold: the first start after an install), the
        sensing kernels are compiled by a second process while this one compiles the motion's,
        and then loaded from the cache: about half the wait on two cores or more."""
        twin = copy.deepcopy(self)
        with compiled_aside(twin, "sense", enabled=len(self.sensors) > 0):
            twin.step()
        twin.sense()

    def _buckets(self) -> Buckets:
        # every robot sorted into the bucket of its pivot, so a sensor reads only nearby buckets
        pose = self._robots.pose
        nbx, nby = self._nbx, self._nby
        bx = np.clip((pose[:, 0] // _BUCKET).astype(np.int64), 0, nbx - 1)
        by = np.clip((pose[:, 1] // _BUCKET).astype(np.int64), 0, nby - 1)
        key = bx * nby + by
        order = np.argsort(key, kind="stable")
        counts = np.bincount(key, minlength=nbx * nby)
        start = np.zeros(nbx * nby + 1, dtype=np.int64)
        np.cumsum(counts, out=start[1:])
        return Buckets(start, order.astype(np.int64), nbx, nby)

    def ranges(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Laser reading of sensor ``k``: distances (m, ``inf`` = no hit) of every ray,
        counter-clockwise from the rightmost, and obstacle numbers (1 wall, id robot, 0 none)."""
        self.sense()
        a, b = self._sensors.first_ray[k], self._sensors.first_ray[k + 1]
        return self._readings.distance[a:b] * self.resolution, self._readings.value[a:b]

    def nearest(self, k: int) -> tuple[float, int]:
        """Ultrasonic reading of sensor ``k``: nearest ray's distance (m, ``inf``) and obstacle."""
        self.sense()
        return float(self._nearest.distance[k] * self.resolution), int(self._nearest.value[k])

    def read(self, robot: str, sensor: str) -> tuple[float, int] | tuple[np.ndarray, np.ndarray]:
        """Read a sensor by names, as the original's ``readusonic``/``readlaser``."""
        try:
            k = self.sensor_index[(robot, sensor)]
        except KeyError:
            raise InputError(f"robot {robot!r} has no sensor {sensor!r}") from None
        return self.nearest(k) if self.sensors[k].kind == "ultrasonic" else self.ranges(k)

    def sensor_origin(self, k: int) -> tuple[float, float, float]:
        """World pose (m, m, rad) of sensor ``k``'s frame: position on the robot, axis heading."""
        s = self.sensors[k]
        x, y, h = self._robots.pose[s.robot]
        c, sn = math.cos(h), math.sin(h)
        px, py = self._sensors.position[k]
        return (
            self.origin[0] + (x + c * px - sn * py) * self.resolution,
            self.origin[1] + (y + sn * px + c * py) * self.resolution,
            h + s.axis,
        )

    # -- state (SI units) -------------------------------------------------------------------
    def poses(self) -> np.ndarray:
        """World poses (n, 3): x, y in metres, heading in radians [-pi, pi)."""
        return _world_poses(self._robots.pose, self.resolution, self.origin)

    def body_velocity(self, i: int) -> tuple[float, float, float]:
        """Forward, lateral (m/s) and yaw rate (rad/s) the robot is moving with (0 when stopped)."""
        if not self.power[i] or self.crashed[i]:
            return 0.0, 0.0, 0.0
        w1, w2 = self.vel[i]
        rob = self._robots
        r, la, lb = rob.wheel_radius[i], rob.half_track[i], rob.axle_offset[i]
        omega = r * (w2 - w1) / (2.0 * la)
        return r * (w1 + w2) * 0.5 * self.resolution, lb * omega * self.resolution, omega

    def outline(self, i: int) -> np.ndarray:
        """Robot ``i``'s polygon in world metres, shape (vertices, 2)."""
        vx, vy = self._outline(i)
        polygon: np.ndarray = np.column_stack([vx, vy]) * self.resolution + self.origin
        return polygon

    def tracks(self) -> dict[str, np.ndarray]:
        """Every robot's kept track: ``{name: (steps, 2)}`` in metres."""
        h = self.history.array()
        return {name: h[:, i, :2].astype(float) for i, name in enumerate(self.names)}

    def start_poses(self) -> np.ndarray:
        """Every robot's pose when the world was built (n, 3): metres, radians, as :meth:`poses`."""
        out = self._start_pose.copy()
        out[:, :2] = out[:, :2] * self.resolution + self.origin
        return out

    def odometry(self) -> np.ndarray:
        """Every robot's pose in the frame of its start pose (n, 3): x forward and y left of where
        it started (m), heading change (rad, not wrapped). Exact wheel odometry."""
        pose = self._robots.pose
        start = self._start_pose
        res = self.resolution
        out = np.empty_like(pose)
        for i in range(len(pose)):
            sx, sy, sh = start[i]
            dx, dy = (pose[i, 0] - sx) * res, (pose[i, 1] - sy) * res
            c, s = math.cos(sh), math.sin(sh)
            out[i] = (c * dx + s * dy, -s * dx + c * dy, pose[i, 2] - sh)
        return out

    def shape(self, i: int) -> np.ndarray:
        """Robot ``i``'s polygon around its pivot, heading +x, scaled (m), shape (vertices, 2)."""
        rob = self._robots
        return rob.vertices[rob.first_vertex[i] : rob.first_vertex[i + 1]] * self.resolution

    def ray_angles(self, k: int) -> np.ndarray:
        """World angle (rad) of every ray of sensor ``k`` now, counter-clockwise from the rightmost."""
        sens = self._sensors
        return self.sensor_origin(k)[2] + sens.ray_offset[sens.first_ray[k] : sens.first_ray[k + 1]]
