"""Joint motion of a position-controlled arm: trajectories and point targets (no rclpy).

Every command becomes a time-parametrised cubic Hermite spline starting at the current state:

- :meth:`JointMotion.follow` takes waypoints (times from now, positions, optional velocities;
  missing velocities are estimated, zero at the last point);
- :meth:`JointMotion.move_to` makes a one-segment spline from rest-or-current-velocity to a
  target, long enough that no joint exceeds its velocity limit (all joints arrive together).

:meth:`JointMotion.step` advances time and tracks the spline. A spline that would move a joint
faster than its velocity limit is followed at the limit (the arm lags behind and catches up),
so velocity limits always hold. A new command replaces the old one.
"""

from __future__ import annotations

import numpy as np

from sim_runtime.errors import InputError

_CUBIC_PEAK = 1.5  # peak speed of a rest-to-rest cubic is 1.5 x its mean speed


class JointMotion:
    """Position, velocity and acceleration of n joints following the latest command."""

    def __init__(self, q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, vmax: np.ndarray) -> None:
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        self.vmax = np.asarray(vmax, dtype=float)
        self.q: np.ndarray = np.clip(np.asarray(q0, dtype=float), self.lower, self.upper)
        self.qd = np.zeros_like(self.q)
        self.qdd = np.zeros_like(self.q)
        self.time = 0.0
        # spline knots: absolute times (k,), positions and velocities (k, n)
        self._t = np.array([0.0])
        self._p: np.ndarray = self.q[None, :].copy()
        self._v = np.zeros((1, self.q.size))

    @property
    def n(self) -> int:
        return self.q.size

    @property
    def goal(self) -> np.ndarray:
        """The position the current command ends at."""
        goal: np.ndarray = self._p[-1].copy()
        return goal

    @property
    def end_time(self) -> float:
        """Time at which the current command's reference reaches its goal."""
        return float(self._t[-1])

    @property
    def moving(self) -> bool:
        return self.time < self._t[-1] or bool(np.any(np.abs(self.q - self._p[-1]) > 1e-12))

    def clamp(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions clipped to the joint limits, and the indices of joints that were clipped."""
        q = np.asarray(q, dtype=float)
        clipped = np.clip(q, self.lower, self.upper)
        return clipped, np.flatnonzero(clipped != q)

    def follow(self, times: np.ndarray, positions: np.ndarray, velocities: np.ndarray | None = None) -> None:
        """Follow waypoints ``positions`` (k, n) at ``times`` (k,) seconds from now.

        Times must be strictly increasing and >= 0 (a first point at 0 replaces the current
        position as start). Positions must be within the joint limits (clamp them first).
        """
        times = np.asarray(times, dtype=float)
        positions = np.atleast_2d(np.asarray(positions, dtype=float))
        if times.ndim != 1 or len(times) != len(positions) or positions.shape[1] != self.n:
            raise InputError(
                f"trajectory needs times (k,) and positions (k, {self.n}), got {times.shape} and {positions.shape}"
            )
        if len(times) == 0 or times[0] < 0 or np.any(np.diff(times) <= 0):
            raise InputError(f"trajectory times must be >= 0 and strictly increasing, got {times.tolist()}")
        if velocities is not None:
            velocities = np.atleast_2d(np.asarray(velocities, dtype=float))
            if velocities.shape != positions.shape:
                raise InputError(f"trajectory velocities shape {velocities.shape} != positions {positions.shape}")
        if times[0] > 0:
            times = np.concatenate([[0.0], times])
            positions = np.vstack([self.q, positions])
            if velocities is not None:
                velocities = np.vstack([self.qd, velocities])
        if velocities is None:
            velocities = _estimate_velocities(times, positions)
            velocities[0] = self.qd if times[0] == 0 and np.allclose(positions[0], self.q) else 0.0
        self._t = self.time + times
        self._p = positions
        self._v = velocities

    def move_to(self, target: np.ndarray, min_duration: float = 0.0) -> float:
        """Move to ``target`` (within limits) as fast as the velocity limits allow; returns
        the planned duration (s)."""
        target = np.asarray(target, dtype=float)
        span = np.abs(target - self.q) / self.vmax
        duration = max(_CUBIC_PEAK * float(span.max(initial=0.0)), min_duration)
        if duration <= 0.0:
            self.follow(np.array([0.0]), self.q[None, :], np.zeros((1, self.n)))
            return 0.0
        self.follow(np.array([duration]), target[None, :], np.zeros((1, self.n)))
        return duration

    def stop(self) -> None:
        """Hold the current position."""
        self.qd[:] = 0.0
        self.follow(np.array([0.0]), self.q[None, :], np.zeros((1, self.n)))

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Spline position, velocity and acceleration at absolute time t (held after the end)."""
        if t >= self._t[-1]:
            return self._p[-1].copy(), np.zeros(self.n), np.zeros(self.n)
        if t <= self._t[0]:
            return self._p[0].copy(), self._v[0].copy(), np.zeros(self.n)
        k = int(np.searchsorted(self._t, t, side="right")) - 1
        h = self._t[k + 1] - self._t[k]
        s = (t - self._t[k]) / h
        p0, p1, v0, v1 = self._p[k], self._p[k + 1], self._v[k] * h, self._v[k + 1] * h
        s2, s3 = s * s, s * s * s
        pos = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * v1
        vel = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * v0 + (-6 * s2 + 6 * s) * p1 + (3 * s2 - 2 * s) * v1) / h
        acc = ((12 * s - 6) * p0 + (6 * s - 4) * v0 + (-12 * s + 6) * p1 + (6 * s - 2) * v1) / (h * h)
        return pos, vel, acc

    def step(self, dt: float) -> None:
        """Advance ``dt`` seconds along the reference, never faster than the velocity limits."""
        self.time += dt
        pos, vel, acc = self.reference(self.time)
        limit = self.vmax * dt
        delta = pos - self.q
        if np.all(np.abs(delta) <= limit + 1e-12) and np.all(np.abs(vel) <= self.vmax + 1e-9):
            self.qdd = acc
            self.qd = vel
            self.q = np.clip(pos, self.lower, self.upper)
            return
        delta = np.clip(delta, -limit, limit)
        qd = delta / dt
        self.qdd = (qd - self.qd) / dt
        self.qd = qd
        self.q = np.clip(self.q + delta, self.lower, self.upper)


def _estimate_velocities(times: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Waypoint velocities: mean of neighbouring slopes, zero where the path turns and at the end."""
    v = np.zeros_like(positions)
    if len(times) < 3:
        return v
    slopes = np.diff(positions, axis=0) / np.diff(times)[:, None]
    before, after = slopes[:-1], slopes[1:]
    v[1:-1] = np.where(before * after > 0, 0.5 * (before + after), 0.0)
    return v
