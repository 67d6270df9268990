"""The Create's observation for learning, from raw sensor readings: one definition for the
environments (readings from the model) and ``policy_controller`` (readings from the ROS world's
messages). Imports neither Gymnasium nor ROS.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numba
import numpy as np

from create_sim.model import CreateModel, odometry_origin
from sim_runtime.angles import wrap_angle_jit
from sim_runtime.errors import InputError
from sim_tools.rl.kernels import clip_into

SENSORS = ("lidar", "sonar", "bump", "cliff", "goal")
DEFAULT_SENSORS = ("lidar", "bump", "goal")
#: The goal distance an observation reports at most (m).
MAX_GOAL_DISTANCE_M = 20.0
#: The goal region's radius (m) unless a CreateNav env (or its policy file) says otherwise.
DEFAULT_GOAL_RADIUS_M = 0.3


def observation(raw: dict[str, Any], goal_odom: tuple[float, float]) -> np.ndarray:
    """The observation vector from raw readings, as the env and ``policy_controller`` (from the ROS
    world's messages) both build it. ``raw``: sensor name → reading, in :data:`SENSORS` order:
    ``lidar`` the chosen beams' ranges (m, +inf no return), ``sonar`` [front, left, back, right]
    (m, ±inf), ``bump`` [left, right] (0/1), ``cliff`` 4 signals (%), ``goal`` the odometry pose
    (x, y, θ); ``goal_odom`` the goal in the odometry frame."""
    values = {name: np.asarray(value, dtype=float) for name, value in raw.items()}
    out = np.empty(sum(PART_SIZES.get(name) or len(value) for name, value in values.items()), np.float32)
    at = 0
    for name, value in values.items():
        at = WRITE[name](out, at, value, goal_odom)
    return out


def _ranges(lo: float, hi: float) -> Callable[[np.ndarray, int, np.ndarray, Any], int]:
    """A part of ranges kept within [lo, hi] (+inf, no return → hi; -inf, too close → lo)."""

    def write(out: np.ndarray, at: int, value: np.ndarray, _goal: tuple[float, float]) -> int:
        return clip_into(out, at, value, lo, hi)

    return write


def _as_is(out: np.ndarray, at: int, value: np.ndarray, _goal: tuple[float, float]) -> int:
    end = at + value.shape[0]
    out[at:end] = value
    return end


def _bump(out: np.ndarray, at: int, value: Sequence[bool], _goal: tuple[float, float]) -> int:
    out[at], out[at + 1] = value  # (left, right): a tuple of bools, as the model gives them, or an array
    return at + 2


@numba.njit(cache=True)
def _goal(out: np.ndarray, at: int, odom: np.ndarray, goal_odom: tuple[float, float]) -> int:
    """The goal's distance (at most :data:`MAX_GOAL_DISTANCE_M`) and bearing from the odometry pose
    (x, y, θ) into ``out[at:at + 2]``; the index after. A kernel: in Python this was the dearest
    part of a step's observation."""
    dx, dy = goal_odom[0] - odom[0], goal_odom[1] - odom[1]
    out[at] = min(math.hypot(dx, dy), MAX_GOAL_DISTANCE_M)
    out[at + 1] = wrap_angle_jit(math.atan2(dy, dx) - odom[2])
    return at + 2


#: How each part is written into the observation vector: ``write(out, at, reading, goal_odom)`` → the
#: index after the part. Each part goes straight into the float32 vector: this runs on every env
#: step, where a concatenation of per-part arrays cost more than the env's own reads.
WRITE: dict[str, Callable[[np.ndarray, int, Any, tuple[float, float]], int]] = {
    "lidar": _ranges(*CreateModel.LIDAR_RANGE),
    "sonar": _ranges(0.0, CreateModel.SONAR_RANGE[1]),
    "bump": _bump,
    "cliff": _as_is,
    "goal": _goal,
}
#: Each part's length (the LIDAR's: the beams chosen).
PART_SIZES = {"sonar": 4, "bump": 2, "cliff": 4, "goal": 2}


def blank_readings(sensors: Sequence[str], beams: int) -> dict[str, np.ndarray]:
    """Zero readings of each sensor's shape (``beams`` LIDAR ranges; the goal's is the odometry
    pose, x y θ): what :func:`observation` takes, to compile its kernels before the first reading."""
    sizes = {"lidar": beams, "goal": 3}
    return {name: np.zeros(sizes.get(name) or PART_SIZES[name]) for name in sensors}


def goal_in_odom(
    goal_map: tuple[float, float], truth: tuple[float, float, float], odom: np.ndarray
) -> tuple[float, float]:
    """The map-frame goal in the odometry frame, given the true pose and the odometry of one instant
    (the env's at reset: the start pose and (0, 0, 0); ``policy_controller``'s: the world's first
    overhead pose and odometry)."""
    ox, oy, yaw = odometry_origin(truth, (float(odom[0]), float(odom[1]), float(odom[2])))
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = goal_map[0] - ox, goal_map[1] - oy
    return (c * dx + s * dy, -s * dx + c * dy)


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
