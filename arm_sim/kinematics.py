"""Numba kernels for serial-arm kinematics and dynamics from Denavit–Hartenberg parameters.

Pure numpy/numba (no rclpy). The public, friendlier API is :class:`arm_sim.arm.Arm`; these kernels
take the named tables it builds (NamedTuples of arrays and numbers, as the SIMROBOT kernels'):

- :class:`Chain`, the geometry: ``dh``, a float64 array (n, 7), one row per joint: ``theta``
  offset, ``d``, ``a``, ``alpha``, ``prismatic`` (0.0 revolute, 1.0 prismatic), cos(alpha),
  sin(alpha) (precomputed: trigonometry is most of an FK's cost); a revolute joint adds q to
  ``theta``, a prismatic joint adds q to ``d`` (build it with :func:`pack_dh`). ``base``, the 4x4
  world-from-frame-0 transform. ``modified``: False for standard DH (link transform Rz(theta)
  Tz(d) Tx(a) Rx(alpha)), True for modified/Craig DH (Rx(alpha) Tx(a) Rz(theta) Tz(d), with alpha
  and a of the previous link).
- :class:`Limits`, the joint position limits; :class:`IKSearch`, the inverse kinematics' settings.
- :class:`Dynamics`, every link's mass, centre of gravity and inertia, and the gravity vector.

Frame k (k = 0..n) is the frame of link k: frame 0 is the base (after ``base``), frame n the flange.
Standard DH moves joint i (1-based) about/along z of frame i-1, modified DH about/along z of frame i.

Note: the RoboClass notes print the DH matrix with ``c_alpha * s_theta`` in row 1, column 3; the
correct entry (used here) is ``s_alpha * s_theta``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
import numpy.typing as npt

PRISMATIC = 4  # column of ``dh`` flagging a prismatic joint


class Chain(NamedTuple):
    """An arm's geometry: the (n, 7) ``dh`` table (:func:`pack_dh`), the 4x4 ``base`` transform
    (world from frame 0) and the DH convention (``modified``: Craig's, else standard)."""

    dh: np.ndarray
    base: np.ndarray
    modified: bool


class Limits(NamedTuple):
    """Joint position limits (n,) each: metres for a prismatic joint, radians for a revolute one."""

    lower: np.ndarray
    upper: np.ndarray


class IKSearch(NamedTuple):
    """Inverse kinematics settings: success when the pose error norm is below ``tol``; each
    search runs ``ilimit`` iterations (up to 4 * ``ilimit`` while it keeps converging), at most
    ``slimit`` searches; ``seed`` seeds the random restarts."""

    tol: float
    ilimit: int
    slimit: int
    seed: int


class Dynamics(NamedTuple):
    """Link i (1-based) has ``mass[i-1]`` (kg), centre of gravity ``cog[i-1]`` (m) and inertia
    ``inertia[i-1]`` (kg m^2, about the centre of gravity), both in frame i; ``gravity`` is the
    world gravity vector (m/s^2)."""

    mass: np.ndarray
    cog: np.ndarray
    inertia: np.ndarray
    gravity: np.ndarray


def pack_dh(
    theta: npt.ArrayLike, d: npt.ArrayLike, a: npt.ArrayLike, alpha: npt.ArrayLike, prismatic: npt.ArrayLike
) -> np.ndarray:
    """The (n, 7) ``dh`` array of the kernels from per-joint parameters."""
    alphas = np.asarray(alpha, dtype=float)
    return np.ascontiguousarray(
        np.column_stack([theta, d, a, alphas, np.asarray(prismatic, dtype=float), np.cos(alphas), np.sin(alphas)]),
        dtype=float,
    )


@numba.njit(cache=True, inline="always")
def _link_matrix(out, theta, d, a, ca, sa, modified):
    ct = math.cos(theta)
    st = math.sin(theta)
    if modified:
        out[0, 0] = ct
        out[0, 1] = -st
        out[0, 2] = 0.0
        out[0, 3] = a
        out[1, 0] = st * ca
        out[1, 1] = ct * ca
        out[1, 2] = -sa
        out[1, 3] = -sa * d
        out[2, 0] = st * sa
        out[2, 1] = ct * sa
        out[2, 2] = ca
        out[2, 3] = ca * d
    else:
        out[0, 0] = ct
        out[0, 1] = -st * ca
        out[0, 2] = st * sa
        out[0, 3] = a * ct
        out[1, 0] = st
        out[1, 1] = ct * ca
        out[1, 2] = -ct * sa
        out[1, 3] = a * st
        out[2, 0] = 0.0
        out[2, 1] = sa
        out[2, 2] = ca
        out[2, 3] = d
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@numba.njit(cache=True, inline="always")
def _joint_matrix(out, q_i, row, modified):
    if row[PRISMATIC] != 0.0:
        _link_matrix(out, row[0], row[1] + q_i, row[2], row[5], row[6], modified)
    else:
        _link_matrix(out, row[0] + q_i, row[1], row[2], row[5], row[6], modified)


@numba.njit(cache=True, inline="always")
def _mul_affine(out, A, B):
    """out = A @ B for homogeneous 4x4 matrices (bottom row [0 0 0 1]); out may not alias A or B."""
    for r in range(3):
        a0 = A[r, 0]
        a1 = A[r, 1]
        a2 = A[r, 2]
        for c in range(4):
            out[r, c] = a0 * B[0, c] + a1 * B[1, c] + a2 * B[2, c]
        out[r, 3] += A[r, 3]
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@numba.njit(cache=True, inline="always")
def _fk_frames(frames, q, chain, A):
    # fields are read once, outside the loops: each read of an array field is a reference count
    dh = chain.dh
    modified = chain.modified
    frames[0, :, :] = chain.base
    for i in range(dh.shape[0]):
        _joint_matrix(A, q[i], dh[i], modified)
        _mul_affine(frames[i + 1], frames[i], A)


@numba.njit(cache=True)
def fk_all_into(frames: np.ndarray, q: np.ndarray, chain: Chain) -> None:
    """Write the world pose of every link frame 0..n into ``frames`` (n+1, 4, 4)."""
    _fk_frames(frames, q, chain, np.empty((4, 4)))


@numba.njit(cache=True)
def fk_all(q: np.ndarray, chain: Chain) -> np.ndarray:
    """World poses of every link frame 0..n, shape (n+1, 4, 4)."""
    frames = np.empty((chain.dh.shape[0] + 1, 4, 4))
    fk_all_into(frames, q, chain)
    return frames


@numba.njit(cache=True)
def fk(q: np.ndarray, chain: Chain) -> np.ndarray:
    """World pose (4x4) of the last frame (the flange)."""
    dh = chain.dh
    modified = chain.modified
    A = np.empty((4, 4))
    T = chain.base.copy()
    tmp = np.empty((4, 4))
    for i in range(dh.shape[0]):
        _joint_matrix(A, q[i], dh[i], modified)
        _mul_affine(tmp, T, A)
        T, tmp = tmp, T
    return T


@numba.njit(cache=True)
def fk_batch(Q: np.ndarray, chain: Chain) -> np.ndarray:
    """Flange poses for many configurations: Q (m, n) -> (m, 4, 4)."""
    m = Q.shape[0]
    out = np.empty((m, 4, 4))
    for k in range(m):
        out[k] = fk(Q[k], chain)
    return out


@numba.njit(cache=True, inline="always")
def _jacobian_from_frames(J, frames, chain):
    dh = chain.dh
    modified = chain.modified
    n = dh.shape[0]
    pe = frames[n, :3, 3]
    for i in range(n):
        axis_frame = i + 1 if modified else i
        z0 = frames[axis_frame, 0, 2]
        z1 = frames[axis_frame, 1, 2]
        z2 = frames[axis_frame, 2, 2]
        if dh[i, PRISMATIC] != 0.0:
            J[0, i] = z0
            J[1, i] = z1
            J[2, i] = z2
            J[3, i] = 0.0
            J[4, i] = 0.0
            J[5, i] = 0.0
        else:
            rx = pe[0] - frames[axis_frame, 0, 3]
            ry = pe[1] - frames[axis_frame, 1, 3]
            rz = pe[2] - frames[axis_frame, 2, 3]
            J[0, i] = z1 * rz - z2 * ry
            J[1, i] = z2 * rx - z0 * rz
            J[2, i] = z0 * ry - z1 * rx
            J[3, i] = z0
            J[4, i] = z1
            J[5, i] = z2


@numba.njit(cache=True)
def jacob0(q: np.ndarray, chain: Chain) -> np.ndarray:
    """Geometric Jacobian (6, n) of the flange in the world frame: rows vx vy vz wx wy wz."""
    frames = fk_all(q, chain)
    J = np.empty((6, chain.dh.shape[0]))
    _jacobian_from_frames(J, frames, chain)
    return J


@numba.njit(cache=True)
def jacob0_batch(Q: np.ndarray, chain: Chain) -> np.ndarray:
    """Jacobians for many configurations: Q (m, n) -> (m, 6, n)."""
    m = Q.shape[0]
    n = chain.dh.shape[0]
    out = np.empty((m, 6, n))
    frames = np.empty((n + 1, 4, 4))
    for k in range(m):
        fk_all_into(frames, Q[k], chain)
        _jacobian_from_frames(out[k], frames, chain)
    return out


@numba.njit(cache=True)
def _pose_error(e, Tgoal, T):
    """6-vector from T to Tgoal: position difference and rotation vector of Rgoal R^T (world)."""
    for r in range(3):
        e[r] = Tgoal[r, 3] - T[r, 3]
    # R_err = Rgoal @ R^T; only its trace and skew part are needed
    r00 = Tgoal[0, 0] * T[0, 0] + Tgoal[0, 1] * T[0, 1] + Tgoal[0, 2] * T[0, 2]
    r11 = Tgoal[1, 0] * T[1, 0] + Tgoal[1, 1] * T[1, 1] + Tgoal[1, 2] * T[1, 2]
    r22 = Tgoal[2, 0] * T[2, 0] + Tgoal[2, 1] * T[2, 1] + Tgoal[2, 2] * T[2, 2]
    r21 = Tgoal[2, 0] * T[1, 0] + Tgoal[2, 1] * T[1, 1] + Tgoal[2, 2] * T[1, 2]
    r12 = Tgoal[1, 0] * T[2, 0] + Tgoal[1, 1] * T[2, 1] + Tgoal[1, 2] * T[2, 2]
    r02 = Tgoal[0, 0] * T[2, 0] + Tgoal[0, 1] * T[2, 1] + Tgoal[0, 2] * T[2, 2]
    r20 = Tgoal[2, 0] * T[0, 0] + Tgoal[2, 1] * T[0, 1] + Tgoal[2, 2] * T[0, 2]
    r10 = Tgoal[1, 0] * T[0, 0] + Tgoal[1, 1] * T[0, 1] + Tgoal[1, 2] * T[0, 2]
    r01 = Tgoal[0, 0] * T[1, 0] + Tgoal[0, 1] * T[1, 1] + Tgoal[0, 2] * T[1, 2]
    lx = r21 - r12
    ly = r02 - r20
    lz = r10 - r01
    ln = math.sqrt(lx * lx + ly * ly + lz * lz)
    tr = r00 + r11 + r22
    if ln < 1e-9:
        if tr > 0.0:
            e[3] = 0.5 * lx
            e[4] = 0.5 * ly
            e[5] = 0.5 * lz
        else:
            # rotation by pi: the axis comes from the diagonal
            e[3] = 0.5 * math.pi * (r00 + 1.0)
            e[4] = 0.5 * math.pi * (r11 + 1.0)
            e[5] = 0.5 * math.pi * (r22 + 1.0)
    else:
        s = math.atan2(ln, tr - 1.0) / ln
        e[3] = s * lx
        e[4] = s * ly
        e[5] = s * lz


@numba.njit(cache=True)
def _norm(e):
    s = 0.0
    for i in range(e.shape[0]):
        s += e[i] * e[i]
    return math.sqrt(s)


@numba.njit(cache=True)
def _solve_spd(A, b, L, x):
    """Solve A x = b for a small symmetric positive definite A (Cholesky into the buffer L)."""
    n = A.shape[0]
    for i in range(n):
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = math.sqrt(s) if s > 0.0 else 1e-12
            else:
                L[i, j] = s / L[j, j]
    for i in range(n):  # forward substitution, y kept in x
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


class _IKScratch(NamedTuple):
    """Working memory of one inverse kinematics call: frames, Jacobian, pose error, the damped
    normal equations (matrix, right-hand side, Cholesky factor, step) and a 4x4 buffer."""

    frames: np.ndarray
    J: np.ndarray
    e: np.ndarray
    A: np.ndarray
    g: np.ndarray
    L: np.ndarray
    dq: np.ndarray
    work: np.ndarray


@numba.njit(cache=True, inline="always")
def _ik_scratch(n):
    return _IKScratch(
        np.empty((n + 1, 4, 4)),
        np.empty((6, n)),
        np.empty(6),
        np.empty((n, n)),
        np.empty(n),
        np.zeros((n, n)),
        np.empty(n),
        np.empty((4, 4)),
    )


@numba.njit(cache=True, inline="always")
def _normal_equations(A, g, J, e, damping):
    """A = J^T J + damping * identity and g = J^T e (Levenberg–Marquardt's damped step)."""
    n = A.shape[0]
    for r in range(n):
        s = 0.0
        for k in range(6):
            s += J[k, r] * e[k]
        g[r] = s
        for c in range(r, n):
            s = 0.0
            for k in range(6):
                s += J[k, r] * J[k, c]
            A[r, c] = s
            A[c, r] = s
        A[r, r] += damping


@numba.njit(cache=True, inline="always")
def _lm_search(q, Tgoal, chain, limits, search, best_q, best_res, ws):
    """One Levenberg–Marquardt search from ``q`` (updated in place), keeping the best
    configuration in ``best_q``. Returns (best residual so far, converged)."""
    n = q.shape[0]
    ilimit = search.ilimit
    tol = search.tol
    lower, upper = limits
    frames, J, e, A, g, L, dq, work = ws
    prev_res = np.inf
    # a search that is still converging (near a singularity convergence turns linear) may run
    # up to 4 * ilimit iterations; one that stalls or is still far ends after ilimit. The
    # extra pass checks the last step's result.
    for it in range(4 * ilimit + 1):
        _fk_frames(frames, q, chain, work)
        _pose_error(e, Tgoal, frames[n])
        res = _norm(e)
        if res < best_res:
            best_res = res
            best_q[:] = q
        if res < tol:
            return best_res, True
        if it == 4 * ilimit or (it >= ilimit and (res > 1e-2 or res > 0.95 * prev_res)):
            break
        prev_res = res
        _jacobian_from_frames(J, frames, chain)
        _normal_equations(A, g, J, e, 0.5 * res * res + 1e-12)
        _solve_spd(A, g, L, dq)
        for i in range(n):
            q[i] = min(max(q[i] + dq[i], lower[i]), upper[i])
    return best_res, False


@numba.njit(cache=True)
def ikine_lm(
    Tgoal: np.ndarray, q0: np.ndarray, chain: Chain, limits: Limits, search: IKSearch
) -> tuple[np.ndarray, bool, float, int]:
    """Levenberg–Marquardt IK (Sugihara's damping) within joint :class:`Limits`, with random restarts.

    Starts from ``q0`` (clipped to the limits), then from uniform random configurations within
    the limits (:class:`IKSearch` says how long and how often).
    Returns (q, success, residual, searches): ``residual`` is the norm of the 6-vector pose error
    (metres and radians mixed, as the tolerance); on failure ``q`` is the best found, never
    presented as a solution.
    """
    n = chain.dh.shape[0]
    lower = limits.lower
    upper = limits.upper
    np.random.seed(search.seed)
    q = np.empty(n)
    for i in range(n):
        q[i] = min(max(q0[i], lower[i]), upper[i])
    best_q = q.copy()
    best_res = np.inf
    ws = _ik_scratch(n)
    for attempt in range(search.slimit):
        if attempt > 0:
            for i in range(n):
                q[i] = lower[i] + np.random.random() * (upper[i] - lower[i])
        best_res, converged = _lm_search(q, Tgoal, chain, limits, search, best_q, best_res, ws)
        if converged:
            return best_q, True, best_res, attempt + 1
    return best_q, False, best_res, search.slimit


@numba.njit(cache=True)
def ikine_lm_batch(
    Tgoals: np.ndarray, Q0: np.ndarray, chain: Chain, limits: Limits, search: IKSearch
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """IK for many targets: Tgoals (m, 4, 4), Q0 (m, n) -> (Q, success, residual); target k's
    restarts are seeded with ``search.seed + k``."""
    m = Tgoals.shape[0]
    n = chain.dh.shape[0]
    Q = np.empty((m, n))
    ok = np.empty(m, dtype=np.bool_)
    res = np.empty(m)
    for k in range(m):
        one = IKSearch(search.tol, search.ilimit, search.slimit, search.seed + k)
        q, s, r, _ = ikine_lm(Tgoals[k], Q0[k], chain, limits, one)
        Q[k] = q
        ok[k] = s
        res[k] = r
    return Q, ok, res


@numba.njit(cache=True, inline="always")
def _cross(out, a, b):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@numba.njit(cache=True, inline="always")
def _carried(tmp, tmp2, w, wd, d):
    """A rigid body's acceleration terms from a point to another ``d`` away: tmp = wd x d
    (tangential) and tmp2 = w x (w x d) (centripetal)."""
    _cross(tmp, w, d)
    _cross(tmp2, w, tmp)
    _cross(tmp, wd, d)


class _LinkWrenches(NamedTuple):
    """The outward pass's results, per link, world coordinates: joint axis ``z``, the axis point
    ``p`` the joint acts about, centre of gravity ``c``, and the force ``F`` and moment ``N``
    (about ``c``) its motion needs."""

    z: np.ndarray
    p: np.ndarray
    c: np.ndarray
    F: np.ndarray
    N: np.ndarray


@numba.njit(cache=True, inline="always")
def _inertial_moment(N_i, Rf, inertia_i, w, wd, Iw, tmp, tmp2):
    """N = Iw wd + w x (Iw w), with the world inertia Iw = R I R^T of a link at rotation Rf."""
    for r in range(3):
        for k in range(3):
            tmp[k] = Rf[r, 0] * inertia_i[0, k] + Rf[r, 1] * inertia_i[1, k] + Rf[r, 2] * inertia_i[2, k]
        for cc in range(3):
            Iw[r, cc] = tmp[0] * Rf[cc, 0] + tmp[1] * Rf[cc, 1] + tmp[2] * Rf[cc, 2]
    for r in range(3):
        tmp2[r] = Iw[r, 0] * w[0] + Iw[r, 1] * w[1] + Iw[r, 2] * w[2]
    _cross(tmp, w, tmp2)
    for r in range(3):
        N_i[r] = Iw[r, 0] * wd[0] + Iw[r, 1] * wd[1] + Iw[r, 2] * wd[2] + tmp[r]


@numba.njit(cache=True, inline="always")
def _rne_outward(links, frames, qd, qdd, chain, dyn):
    """Newton–Euler's outward pass, base to flange: fills ``links`` (:class:`_LinkWrenches`)."""
    z, p, c, F, N = links
    mass, cog, inertia, gravity = dyn
    dh = chain.dh
    modified = chain.modified
    w = np.zeros(3)  # angular velocity of the current link
    wd = np.zeros(3)
    # linear acceleration of the previous axis point (base: -gravity stands in for gravity)
    ap = -gravity.copy()
    prev_p = frames[0, :3, 3].copy()
    tmp = np.empty(3)
    tmp2 = np.empty(3)
    d = np.empty(3)
    Iw = np.empty((3, 3))
    for i in range(dh.shape[0]):
        af = i + 1 if modified else i
        for r in range(3):
            z[i, r] = frames[af, r, 2]
            p[i, r] = frames[af, r, 3]
        # acceleration of the new axis point, carried by the parent link
        for r in range(3):
            d[r] = p[i, r] - prev_p[r]
        _carried(tmp, tmp2, w, wd, d)
        for r in range(3):
            ap[r] += tmp[r] + tmp2[r]
        zi = z[i]
        if dh[i, PRISMATIC] == 0.0:
            _cross(tmp, w, zi)
            for r in range(3):
                wd[r] += zi[r] * qdd[i] + tmp[r] * qd[i]
                w[r] += zi[r] * qd[i]
        else:
            # the slide adds Coriolis and its own acceleration to every point of the link
            _cross(tmp, w, zi)
            for r in range(3):
                ap[r] += 2.0 * tmp[r] * qd[i] + zi[r] * qdd[i]
        # centre of gravity in world coordinates
        Rf = frames[i + 1, :3, :3]
        for r in range(3):
            c[i, r] = frames[i + 1, r, 3] + Rf[r, 0] * cog[i, 0] + Rf[r, 1] * cog[i, 1] + Rf[r, 2] * cog[i, 2]
            d[r] = c[i, r] - p[i, r]
        _carried(tmp, tmp2, w, wd, d)
        for r in range(3):
            F[i, r] = mass[i] * (ap[r] + tmp[r] + tmp2[r])
        _inertial_moment(N[i], Rf, inertia[i], w, wd, Iw, tmp, tmp2)
        prev_p[:] = p[i]


@numba.njit(cache=True, inline="always")
def _rne_inward(tau, links, dh):
    """Newton–Euler's inward pass, flange to base: each joint's torque (force) from the wrenches."""
    z, p, c, F, N = links
    f = np.zeros(3)
    nn = np.zeros(3)  # moment about the next axis point
    next_p = np.zeros(3)
    tmp = np.empty(3)
    d = np.empty(3)
    for i in range(dh.shape[0] - 1, -1, -1):
        # moment about p[i]: own wrench + child's wrench moved from next_p
        for r in range(3):
            d[r] = next_p[r] - p[i, r]
        _cross(tmp, d, f)
        for r in range(3):
            nn[r] += tmp[r]
        for r in range(3):
            d[r] = c[i, r] - p[i, r]
        _cross(tmp, d, F[i])
        for r in range(3):
            nn[r] += tmp[r] + N[i, r]
            f[r] += F[i, r]
            next_p[r] = p[i, r]
        if dh[i, PRISMATIC] == 0.0:
            tau[i] = nn[0] * z[i, 0] + nn[1] * z[i, 1] + nn[2] * z[i, 2]
        else:
            tau[i] = f[0] * z[i, 0] + f[1] * z[i, 1] + f[2] * z[i, 2]


@numba.njit(cache=True, inline="always")
def rne_into(tau: np.ndarray, frames: np.ndarray, qd: np.ndarray, qdd: np.ndarray, chain: Chain, dyn: Dynamics) -> None:
    """Recursive Newton–Euler inverse dynamics, written in world coordinates.

    ``frames`` from :func:`fk_all` at the joint positions; ``qd``, ``qdd`` the joint velocities
    and accelerations; ``dyn`` the links' :class:`Dynamics` and gravity. Writes the joint
    torques/forces into ``tau``.
    One code path serves both DH conventions: every joint acts about a point on its axis that is
    fixed in the parent link (frame i-1's origin for standard DH, frame i's for modified DH).
    """
    n = chain.dh.shape[0]
    links = _LinkWrenches(np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)))
    _rne_outward(links, frames, qd, qdd, chain, dyn)
    _rne_inward(tau, links, chain.dh)


@numba.njit(cache=True)
def rne(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, chain: Chain, dyn: Dynamics) -> np.ndarray:
    """Joint torques/forces (n,) for motion (q, qd, qdd) of the arm ``chain`` with :class:`Dynamics` ``dyn``."""
    frames = fk_all(q, chain)
    tau = np.empty(chain.dh.shape[0])
    rne_into(tau, frames, qd, qdd, chain, dyn)
    return tau


@numba.njit(cache=True)
def rne_batch(Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray, chain: Chain, dyn: Dynamics) -> np.ndarray:
    """Inverse dynamics for many states: Q, QD, QDD (m, n) -> (m, n)."""
    m = Q.shape[0]
    n = chain.dh.shape[0]
    out = np.empty((m, n))
    frames = np.empty((n + 1, 4, 4))
    for k in range(m):
        fk_all_into(frames, Q[k], chain)
        rne_into(out[k], frames, QD[k], QDD[k], chain, dyn)
    return out
