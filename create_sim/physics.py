"""Rigid-body motion of the circular Create among wall segments (numba kernel).

Follows the original's physics engine (driveNormal / drive1Wall / drive2Wall / driveCorner) with its
known errors fixed:

* Free motion is the exact arc of constant (v, ω), with the lateral offset on the correct side
  (the original mirrored counter-clockwise arcs).
* Every wall within reach is a contact (the original kept the two closest). A contact's normal
  points from its closest point (a wall's side or a corner) to the centre. Contacts that the
  intended velocity pushes into are "active".
* One active contact on a wall's side: the robot slides along the wall; Coulomb-like friction from
  the original's "force ∝ intended velocity" assumption removes μ·|v_n| from the sliding speed and
  μ·|v_n|/r from the turn rate, never reversing either (the original could *add* speed).
* A contact at a wall's end (a corner) is rolled round: the robot keeps its whole tangential
  speed (the original's driveCorner, where friction acts on the turn rate only), so a robot meeting a
  free wall end close to head-on (within atan μ) is deflected round it instead of stopping dead.
* Several active contacts (two walls, a wall and a corner, corners): slide along the first
  contact, from the most opposed, whose slide presses into no other contact; if there is none,
  stay put (stuck in the corner); the turn rate loses μ·Σ|v_n|/r. A corner's normal points from
  the wall's end to the centre (the original's extra "glancing" turn of the heading at a corner is
  not reproduced: the heading changes only with ω).
* Whatever the commands, a step never ends overlapping a wall: motion is cut into sub-steps of at
  most r/4 (so the centre cannot cross a wall), any penetration is pushed out along the contact
  normals, and if that fails the move is shortened by bisection towards the previous, valid pose.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from create_sim.geometry import Contacts, SegmentGrid, grid_contacts, new_contacts, point_segment_closest
from sim_runtime.angles import wrap_angle_jit as wrap_angle

CONTACT_SKIN = 1e-3  # a wall this close to the body presses a bumper
OVERLAP_TOL = 1e-9  # numerical slack of the "never inside a wall" invariant
_PUSH_MARGIN = 1e-8  # push-out leaves the body this far from the wall...
_TOUCH = 1e-6  # ...which the next step sees as touching (friction, sliding)
_SOLVER_TOL = 0.1 * OVERLAP_TOL  # the solver's own acceptance, well inside the promise
MAX_SUBSTEPS = 1_000_000  # bounds one step's work whatever dt: 40 km of travel in r/4 sub-steps


@numba.njit(cache=True)
def arc_motion(x: float, y: float, th: float, v: float, w: float, dt: float) -> tuple[float, float, float]:
    """Exact pose after driving at constant (v, ω) for dt (the original's driveNormal, sign fixed)."""
    dth = w * dt
    if abs(dth) < 1e-12:
        # Straight line (the arc formula's limit); keeps tiny ω numerically exact.
        mid = th + 0.5 * dth
        return x + v * dt * math.cos(mid), y + v * dt * math.sin(mid), th + dth
    radius = v / w
    # Chord of the arc, at half the turned angle from the initial heading.
    chord = 2.0 * radius * math.sin(0.5 * dth)
    mid = th + 0.5 * dth
    return x + chord * math.cos(mid), y + chord * math.sin(mid), th + dth


@numba.njit(cache=True)
def min_clearance(grid: SegmentGrid, px: float, py: float, radius: float, contacts: Contacts) -> float:
    """Smallest centre-to-wall distance among walls within 2r (inf if none)."""
    n = grid_contacts(grid, px, py, 2.0 * radius, contacts)
    best = np.inf
    for i in range(n):
        if contacts.distance[i] < best:
            best = contacts.distance[i]
    return best


@numba.njit(cache=True)
def _push_out(grid: SegmentGrid, px: float, py: float, radius: float, contacts: Contacts) -> tuple[float, float, bool]:
    """Move the centre out of penetrating walls along their normals; returns (x, y, ok)."""
    segs = grid.segments
    for _ in range(16):
        n = grid_contacts(grid, px, py, radius, contacts)
        inside = False
        for i in range(n):
            if contacts.distance[i] >= radius:
                continue
            inside = True
            # Recompute against the already-moved centre (Gauss–Seidel over contacts).
            s = contacts.segment[i]
            cx, cy, d = point_segment_closest(px, py, segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3])
            if d >= radius or d == 0.0:
                continue
            k = (radius + _PUSH_MARGIN - d) / d
            px += (px - cx) * k
            py += (py - cy) * k
        if not inside:
            return px, py, True
    return px, py, min_clearance(grid, px, py, radius, contacts) >= radius - _SOLVER_TOL


@numba.njit(cache=True)
def _substep(
    grid: SegmentGrid,
    x: float,
    y: float,
    th: float,
    v: float,
    w: float,
    h: float,
    radius: float,
    mu: float,
    contacts: Contacts,
) -> tuple[float, float, float]:
    n = grid_contacts(grid, x, y, radius + _TOUCH, contacts)
    hx = math.cos(th)
    hy = math.sin(th)
    vx = v * hx
    vy = v * hy
    # Contact normals (closest point → centre) and the intended velocity's normal components.
    normals = np.empty((n, 2))
    vn = np.empty(n)
    n_active = 0
    sum_press = 0.0
    for i in range(n):
        d = contacts.distance[i]
        if d > 0.0:
            normals[i, 0] = (x - contacts.point_x[i]) / d
            normals[i, 1] = (y - contacts.point_y[i]) / d
        else:
            normals[i, 0] = hx
            normals[i, 1] = hy
        vn[i] = vx * normals[i, 0] + vy * normals[i, 1]
        if vn[i] < 0.0:
            n_active += 1
            sum_press -= vn[i]
    if n_active == 0:
        nx_, ny_, nth = arc_motion(x, y, th, v, w, h)
    else:
        # Try sliding along contacts from the most opposed one; take the first feasible slide.
        ux = 0.0
        uy = 0.0
        order = np.argsort(vn)
        for oi in range(n_active):
            i = order[oi]
            tx = -normals[i, 1]
            ty = normals[i, 0]
            vt = vx * tx + vy * ty
            # Rolling round a wall's end loses no speed; sliding along a side loses μ·|v_n|.
            drag = 0.0 if contacts.at_end[i] else mu * (-vn[i])
            slide = max(abs(vt) - drag, 0.0)
            cand_x = math.copysign(slide, vt) * tx
            cand_y = math.copysign(slide, vt) * ty
            feasible = True
            for j in range(n):
                if cand_x * normals[j, 0] + cand_y * normals[j, 1] < -1e-12:
                    feasible = False
                    break
            if feasible:
                ux = cand_x
                uy = cand_y
                break
        w_eff = math.copysign(max(abs(w) - mu * sum_press / radius, 0.0), w)
        nx_ = x + ux * h
        ny_ = y + uy * h
        nth = th + w_eff * h
    px, py, ok = _push_out(grid, nx_, ny_, radius, contacts)
    if not ok:
        px, py = _last_free(grid, x, y, nx_, ny_, radius, contacts)
    return px, py, wrap_angle(nth)


@numba.njit(cache=True, inline="always")
def _last_free(
    grid: SegmentGrid, x: float, y: float, nx_: float, ny_: float, radius: float, contacts: Contacts
) -> tuple[float, float]:
    """The last free point from the valid start (x, y) towards the target, by bisection: the robot
    is a circle, so heading never matters for overlap."""
    lo = 0.0
    hi = 1.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        mx = x + (nx_ - x) * mid
        my = y + (ny_ - y) * mid
        if min_clearance(grid, mx, my, radius, contacts) >= radius - _SOLVER_TOL:
            lo = mid
        else:
            hi = mid
    return x + (nx_ - x) * lo, y + (ny_ - y) * lo


@numba.njit(cache=True)
def advance(
    grid: SegmentGrid, x: float, y: float, th: float, v: float, w: float, dt: float, radius: float, mu: float
) -> tuple[float, float, float]:
    """Pose (x, y, θ) after one physics step of dt at the intended (v, ω).

    Motion is cut into sub-steps of at most r/4 of travel, at most :data:`MAX_SUBSTEPS` of them
    (the model refuses time steps long enough to need more).
    """
    contacts = new_contacts(grid.segments.shape[0])
    n_sub = max(1, int(math.ceil(min(abs(v) * dt / (0.25 * radius), MAX_SUBSTEPS))))
    h = dt / n_sub
    for _ in range(n_sub):
        x, y, th = _substep(grid, x, y, th, v, w, h, radius, mu, contacts)
    return x, y, th


@numba.njit(cache=True)
def advance_unpacked(
    segments: np.ndarray,
    origin_x_m: float,
    origin_y_m: float,
    cell_m: float,
    nx: int,
    ny: int,
    cell_start: np.ndarray,
    cell_items: np.ndarray,
    x: float,
    y: float,
    th: float,
    v: float,
    w: float,
    dt: float,
    radius: float,
    mu: float,
) -> tuple[float, float, float]:
    """:func:`advance` with the grid's fields as arguments, ``advance_unpacked(*grid, …)``: the
    model's hot path. Numba works out a NamedTuple argument's type in Python on every call (about
    1 µs, more than a physics step's arithmetic); arrays and numbers it types in C."""
    grid = SegmentGrid(segments, origin_x_m, origin_y_m, cell_m, nx, ny, cell_start, cell_items)
    return advance(grid, x, y, th, v, w, dt, radius, mu)
