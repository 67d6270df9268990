"""The toy simulator's model: a point robot on an empty plane (metres, radians, seconds)."""

from __future__ import annotations

import numpy as np

from sim_runtime.angles import wrap_angle


class PointRobot:
    """A point at ``pose`` = (x, y, theta) driven by a velocity command (v m/s forward, w rad/s).

    :meth:`step` integrates the command exactly over ``dt`` (an arc, a straight line when w = 0),
    so the same commands give the same poses whatever the step."""

    def __init__(self, pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.pose = np.array(pose, dtype=float)
        self.v = 0.0
        self.w = 0.0
        self.distance = 0.0  # metres travelled, for the tools' metrics

    def command(self, v: float, w: float) -> None:
        """Drive at ``v`` m/s and ``w`` rad/s from the next step on."""
        self.v, self.w = float(v), float(w)

    def step(self, dt: float) -> None:
        """Advance ``dt`` seconds along the commanded arc."""
        x, y, theta = self.pose
        if abs(self.w) < 1e-12:
            x += self.v * dt * np.cos(theta)
            y += self.v * dt * np.sin(theta)
        else:
            radius = self.v / self.w
            x += radius * (np.sin(theta + self.w * dt) - np.sin(theta))
            y -= radius * (np.cos(theta + self.w * dt) - np.cos(theta))
        self.pose = np.array([x, y, wrap_angle(theta + self.w * dt)])
        self.distance += abs(self.v) * dt
