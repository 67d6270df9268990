"""Numba kernels for the Create's ray sensors (sonar, LIDAR, virtual-wall receiver, camera).

Each is one call per reading: the field/view test and the wall occlusion ray for every candidate,
so a reading costs microseconds however many emitters or beacons the map has. A target counts as
hidden only if a wall is hit more than ``tol`` before it (the original compared floats exactly).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from create_sim.geometry import SegmentGrid, grid_cast, grid_cast_fan, grid_contacts, new_contacts
from sim_runtime.angles import wrap_angle_jit as wrap_angle


@numba.njit(cache=True)
def _hidden(grid, mailbox, stamp, ox, oy, tx, ty, tol) -> bool:
    dx = tx - ox
    dy = ty - oy
    dist = math.hypot(dx, dy)
    if dist <= tol:
        return False
    hit = grid_cast(grid, mailbox, stamp, ox, oy, dx / dist, dy / dist, dist)
    hidden: bool = hit < dist - tol
    return hidden


@numba.njit(cache=True)
def virtual_wall_seen(grid, rx, ry, emitters, halo, field_ranges, field_angles, tol) -> bool:
    """Whether the receiver (rx, ry) is in any emitter's halo or triangular field, unoccluded.

    ``emitters`` rows are [x, y, theta, setting]; setting s (1, 2, 3) selects
    ``field_ranges[s - 1]`` (m) and ``field_angles[s - 1]`` (full opening, rad). The field is the
    triangle from the emitter to the two points at that range, ± half the opening.
    """
    mailbox = np.full(grid.segments.shape[0], -1, dtype=np.int64)
    for k in range(emitters.shape[0]):
        ex = emitters[k, 0]
        ey = emitters[k, 1]
        beam = emitters[k, 2]
        setting = min(max(int(emitters[k, 3]), 1), 3) - 1
        dx = rx - ex
        dy = ry - ey
        inside = math.hypot(dx, dy) < halo
        if not inside:
            half = 0.5 * field_angles[setting]
            off_axis = abs(wrap_angle(math.atan2(dy, dx) - beam))
            along = dx * math.cos(beam) + dy * math.sin(beam)
            inside = off_axis <= half and along <= field_ranges[setting] * math.cos(half)
        if inside and not _hidden(grid, mailbox, k, rx, ry, ex, ey, tol):
            return True
    return False


@numba.njit(cache=True)
def camera_view(grid, cx, cy, heading, targets, max_range, half_fov, tol):
    """Targets within range and ±half_fov of the camera with no wall between.

    Returns (indices, distances, bearings), bearings relative to the heading, left positive.
    """
    n = targets.shape[0]
    index = np.empty(n, dtype=np.int64)
    dist = np.empty(n)
    bearing = np.empty(n)
    mailbox = np.full(grid.segments.shape[0], -1, dtype=np.int64)
    count = 0
    for k in range(n):
        dx = targets[k, 0] - cx
        dy = targets[k, 1] - cy
        d = math.hypot(dx, dy)
        b = wrap_angle(math.atan2(dy, dx) - heading)
        if d > max_range or abs(b) > half_fov:
            continue
        if _hidden(grid, mailbox, k, cx, cy, targets[k, 0], targets[k, 1], tol):
            continue
        index[count] = k
        dist[count] = d
        bearing[count] = b
        count += 1
    return index[:count], dist[:count], bearing[:count]


@numba.njit(cache=True)
def range_fan(grid, ox, oy, heading, cos_off, sin_off, offset, lo, hi, noise, too_close):
    """Range readings of a fixed fan of beams, REP-117 style, in one call.

    Distances are measured from (ox, oy) less ``offset`` (sonar: from the centre, read from the
    body's edge). No hit within ``hi`` → +inf; a true distance below ``lo`` → ``too_close``;
    otherwise distance + noise, kept within [lo, hi] so in-range stays in range. ``noise`` has
    one value per beam (beams beyond its length get none).
    """
    raw = grid_cast_fan(grid, ox, oy, heading, cos_off, sin_off, hi + offset)
    out = np.empty(raw.shape[0])
    for i in range(raw.shape[0]):
        d = raw[i] - offset
        if d == np.inf:
            out[i] = np.inf
        elif d < lo:
            out[i] = too_close
        else:
            out[i] = min(max(d + (noise[i] if i < noise.shape[0] else 0.0), lo), hi)
    return out


@numba.njit(cache=True)
def range_fan_unpacked(
    segments,
    origin_x_m,
    origin_y_m,
    cell_m,
    nx,
    ny,
    cell_start,
    cell_items,
    ox,
    oy,
    heading,
    cos_off,
    sin_off,
    offset,
    lo,
    hi,
    noise,
    too_close,
):
    """:func:`range_fan` called as ``range_fan_unpacked(*grid, …)`` (see ``physics.advance_unpacked``)."""
    grid = SegmentGrid(segments, origin_x_m, origin_y_m, cell_m, nx, ny, cell_start, cell_items)
    return range_fan(grid, ox, oy, heading, cos_off, sin_off, offset, lo, hi, noise, too_close)


@numba.njit(cache=True)
def bumper_hits(grid, x, y, heading, reach, front_half):
    """(left, right) bumpers pressed by walls within ``reach`` of the centre (x, y).

    A contact within ``front_half`` of straight ahead presses both; one further round on either
    side, up to 90°, presses that side's bumper; contacts behind the axle press none.
    """
    contacts = new_contacts(grid.segments.shape[0])
    n = grid_contacts(grid, x, y, reach, contacts)
    left = False
    right = False
    for i in range(n):
        phi = wrap_angle(math.atan2(contacts.point_y[i] - y, contacts.point_x[i] - x) - heading)
        if abs(phi) < front_half:
            return True, True
        if front_half <= phi < 0.5 * math.pi:
            left = True
        elif -0.5 * math.pi < phi <= -front_half:
            right = True
    return left, right


@numba.njit(cache=True)
def bumper_hits_unpacked(
    segments, origin_x_m, origin_y_m, cell_m, nx, ny, cell_start, cell_items, x, y, heading, reach, front_half
):
    """:func:`bumper_hits` called as ``bumper_hits_unpacked(*grid, …)`` (see ``physics.advance_unpacked``)."""
    grid = SegmentGrid(segments, origin_x_m, origin_y_m, cell_m, nx, ny, cell_start, cell_items)
    return bumper_hits(grid, x, y, heading, reach, front_half)


@numba.njit(cache=True)
def cliff_windows_crossed(crossings, heading, windows):
    """Which cliff windows (rows [lo, hi] of angles from the heading, inclusive) hold one of the
    ``crossings`` (world angles where a line crosses the body's edge)."""
    over = np.zeros(windows.shape[0], dtype=np.bool_)
    for c in range(crossings.shape[0]):
        rel = wrap_angle(crossings[c] - heading)
        for w in range(windows.shape[0]):
            if windows[w, 0] <= rel <= windows[w, 1]:
                over[w] = True
    return over
