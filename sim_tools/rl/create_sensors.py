"""The Create's observation for learning, from raw sensor readings: one definition for the
environments (readings from the model) and ``policy_controller`` (readings from the ROS world's
messages). Imports neither Gymnasium nor ROS.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from create_sim.model import CreateModel
from sim_runtime.angles import wrap_angle
from sim_runtime.errors import InputError

SENSORS = ("lidar", "sonar", "bump", "cliff", "goal")
DEFAULT_SENSORS = ("lidar", "bump", "goal")
#: The goal distance an observation reports at most (m).
MAX_GOAL_DISTANCE_M = 20.0


def observation(raw: dict[str, np.ndarray], goal_odom: tuple[float, float]) -> np.ndarray:
    """The observation vector from raw readings, as the env and ``policy_controller`` (from the ROS
    world's messages) both build it. ``raw``: sensor name → reading, in :data:`SENSORS` order:
    ``lidar`` the chosen beams' ranges (m, +inf no return), ``sonar`` [front, left, back, right]
    (m, ±inf), ``bump`` [left, right] (0/1), ``cliff`` 4 signals (%), ``goal`` the odometry pose
    (x, y, θ); ``goal_odom`` the goal in the odometry frame."""
    parts = [_SHAPE[name](np.asarray(value, dtype=float), goal_odom) for name, value in raw.items()]
    return np.concatenate(parts).astype(np.float32)


def _goal(odom: np.ndarray, goal_odom: tuple[float, float]) -> np.ndarray:
    x, y, th = odom.tolist()
    dx, dy = goal_odom[0] - x, goal_odom[1] - y
    return np.array([min(math.hypot(dx, dy), MAX_GOAL_DISTANCE_M), wrap_angle(math.atan2(dy, dx) - th)])


_SHAPE = {
    "lidar": lambda r, _g: np.clip(r, *CreateModel.LIDAR_RANGE),  # +inf (no return) → max range
    "sonar": lambda r, _g: np.clip(r, 0.0, CreateModel.SONAR_RANGE[1]),  # -inf (too close) → 0, +inf → max
    "bump": lambda r, _g: r,
    "cliff": lambda r, _g: r,
    "goal": _goal,
}


def checked_sensors(sensors: Sequence[str]) -> tuple[str, ...]:
    chosen = tuple(sensors)
    unknown = [s for s in chosen if s not in SENSORS]
    if unknown or not chosen:
        raise InputError(f"sensors {list(chosen)}: choose one or more of {list(SENSORS)}")
    return tuple(s for s in SENSORS if s in chosen)


def lidar_index(beams: int) -> np.ndarray:
    """The ``beams`` LIDAR beams an observation holds, evenly picked from all of them."""
    if not 1 <= beams <= CreateModel.LIDAR_BEAMS:
        raise InputError(f"lidar_beams {beams}: 1 to {CreateModel.LIDAR_BEAMS}")
    return np.linspace(0, CreateModel.LIDAR_BEAMS - 1, beams).round().astype(int)
