"""``robot_sims/ArmReach-v0``: bring a serial arm's flange to a target pose with joint velocities.

A Gymnasium environment over the pure :class:`~arm_sim.arm.Arm` kinematics (no ROS), for any arm
config (``robot="irb120"``, ``"csa7"`` (7 joints) or a config file's path).

- **Action**: joint velocities (rad/s, m/s for a prismatic joint) within the config's velocity
  limits; each step integrates them over ``control_period_s`` and holds the joints in their limits.
  ``normalize_actions=True``: ``[-1, 1]`` per joint, mapped linearly onto those limits.
- **Observation** (float32): the joint positions, then the flange's pose error to the target in the
  world frame: position (3, m) and rotation vector (3, rad) of ``R_target R_flangeᵀ``.
- **Reward** per step: ``-(position error m + 0.1 × rotation error rad)``; reaching the target
  (within ``tolerance_m`` and ``tolerance_rad``) adds ``+10`` and terminates; ``max_steps`` truncate
  (``None``: never; ``gymnasium.make`` then truncates by its ``max_episode_steps``, registered 200).
- **Randomised per reset(seed=…)**: the start joints and the target (the flange pose of random
  joints within the limits, so it is reachable); ``start`` / ``target_q`` fix them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, overload

import gymnasium as gym
import numba
import numpy as np
from gymnasium import spaces

from arm_sim.arm import Arm
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_tools.rl.kernels import normalized_box, physical_action

ROTATION_WEIGHT = 0.1  # metres of position error one radian of rotation error costs
REACH_REWARD = 10.0
#: An observed position error is at most this (m): beyond any arm's reach here.
MAX_POSITION_ERROR_M = 10.0


def arm_config(robot: str | Path) -> Path:
    """A shipped arm's config (``"irb120"``, ``"csa7"``) or a config file's path."""
    shipped = config_path(f"arm/{robot}.yaml")
    return shipped if shipped.is_file() else Path(robot)


class ArmReachEnv(gym.Env[np.ndarray, np.ndarray]):
    """Reach a target flange pose (see the module's docstring)."""

    metadata = {"render_modes": []}  # noqa: RUF012 (Gymnasium's own attribute)

    def __init__(
        self,
        robot: str | Path = "irb120",
        *,
        start: Sequence[float] | None = None,
        target_q: Sequence[float] | None = None,
        tolerance_m: float = 0.01,
        tolerance_rad: float = 0.05,
        control_period_s: float = 0.05,
        max_steps: int | None = 200,
        normalize_actions: bool = False,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise InputError(f"render_mode {render_mode!r}: ArmReach has no rendering yet (None only)")
        self.arm = Arm.from_file(arm_config(robot), load_meshes=False)
        n = self.arm.n
        self.start = self._joints(start, "start")
        self.target_q = self._joints(target_q, "target_q")
        self.tolerance_m, self.tolerance_rad = float(tolerance_m), float(tolerance_rad)
        self.dt = float(control_period_s)
        self.max_steps = int(max_steps) if max_steps is not None else math.inf
        limit = self.arm.velocity_limits.astype(np.float32)
        #: The action's bounds in the joints' units (rad/s), whatever ``normalize_actions``.
        self.physical_action_space = spaces.Box(-limit, limit, dtype=np.float32)
        self.normalize_actions = bool(normalize_actions)
        box = self.physical_action_space
        self.action_space = normalized_box(box) if normalize_actions else box
        self._act_bounds = (box.low.astype(float), box.high.astype(float))
        err = [MAX_POSITION_ERROR_M] * 3 + [math.pi] * 3
        low = np.concatenate([self.arm.lower, -np.array(err)]).astype(np.float32)
        high = np.concatenate([self.arm.upper, err]).astype(np.float32)
        self.observation_space = spaces.Box(low, high, shape=(n + 6,), dtype=np.float32)
        self.q = self.arm.mid_range()
        self.target = self.arm.fkine(self.q)
        # the limits as the step's kernel takes them, gathered once
        self._limits = (self.arm.velocity_limits, self.arm.lower, self.arm.upper)

    @overload
    def _joints(self, q: None, what: str) -> None: ...
    @overload
    def _joints(self, q: Sequence[float] | np.ndarray, what: str) -> np.ndarray: ...
    def _joints(self, q: Sequence[float] | np.ndarray | None, what: str) -> np.ndarray | None:
        if q is None:
            return None
        joints = np.asarray(q, dtype=float)
        if joints.shape != (self.arm.n,) or not self.arm.within_limits(joints):
            raise InputError(f"{what} {joints.tolist()}: {self.arm.n} joint positions within the limits")
        return joints

    def _random_joints(self) -> np.ndarray:
        return self.np_random.uniform(self.arm.lower, self.arm.upper)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        start = options.get("start", self.start)
        target_q = options.get("target_q", self.target_q)
        self.q = self._joints(start, "start") if start is not None else self._random_joints()
        goal_q = self._joints(target_q, "target_q") if target_q is not None else self._random_joints()
        #: The target flange pose (4x4, world).
        self.target = self.arm.fkine(goal_q)
        self.steps = 0
        return self._observe()

    def step(self, action: np.ndarray):
        # kernels: the joints moved within their limits, then the flange's error and the observation
        if self.normalize_actions:
            action = physical_action(action, *self._act_bounds)
        self.q = _moved(self.q, np.asarray(action, dtype=float), self.dt, *self._limits)
        obs, position, rotation = _observation(self.q, self.target, self.arm.fkine(self.q))
        self.steps += 1
        reached = position <= self.tolerance_m and rotation <= self.tolerance_rad
        reward = -(position + ROTATION_WEIGHT * rotation)
        if reached:
            reward += REACH_REWARD
        info = {"position_error_m": position, "rotation_error_rad": rotation, "is_success": reached}
        truncated = self.steps >= self.max_steps and not reached
        return obs, reward, reached, truncated, info

    def _observe(self) -> tuple[np.ndarray, dict[str, Any]]:
        obs, position, rotation = _observation(self.q, self.target, self.arm.fkine(self.q))
        return obs, {"position_error_m": position, "rotation_error_rad": rotation}


def pose_error(target: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """6-vector from ``pose`` to ``target`` (4x4 each): position difference and the rotation vector
    of ``R_target Rᵀ`` (world frame, angle in [0, π])."""
    error = np.empty(6)
    _pose_error_into(error, np.ascontiguousarray(target, dtype=float), np.ascontiguousarray(pose, dtype=float))
    return error


# The kernels here call no other package's kernels (the flange pose comes from Arm.fkine): numba's
# cache of a sim_tools kernel is checked against sim_tools' and sim_runtime's sources only
# (sim_runtime.numba_cache), so one calling into arm_sim could run stale code after arm_sim changed.
@numba.njit(cache=True)
def _pose_error_into(out, target, pose):
    R = np.empty((3, 3))  # R_target R_poseᵀ
    for i in range(3):
        for j in range(3):
            R[i, j] = target[i, 0] * pose[j, 0] + target[i, 1] * pose[j, 1] + target[i, 2] * pose[j, 2]
    sx, sy, sz = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    sine2 = math.hypot(math.hypot(sx, sy), sz)  # 2 sin(angle)
    angle = math.atan2(sine2, R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    if sine2 > 1e-9:
        k = angle / sine2
        out[3], out[4], out[5] = sx * k, sy * k, sz * k
    elif angle < 1.0:
        out[3], out[4], out[5] = 0.5 * sx, 0.5 * sy, 0.5 * sz  # tiny rotation
    else:
        # a half turn: the axis is the column of R + I with the largest norm
        best, norm = 0, -1.0
        for j in range(3):
            c = math.hypot(math.hypot(R[0, j] + (j == 0), R[1, j] + (j == 1)), R[2, j] + (j == 2))
            if c > norm:
                best, norm = j, c
        for i in range(3):
            out[3 + i] = math.pi * (R[i, best] + (i == best)) / norm
    for i in range(3):
        out[i] = target[i, 3] - pose[i, 3]


@numba.njit(cache=True)
def _observation(q, target, flange):
    """(observation float32, position error m, rotation error rad) at joints ``q``, the flange at
    ``flange`` (4x4)."""
    n = q.shape[0]
    error = np.empty(6)
    _pose_error_into(error, target, flange)
    obs = np.empty(n + 6, dtype=np.float32)
    obs[:n] = q
    for i in range(3):
        obs[n + i] = min(max(error[i], -MAX_POSITION_ERROR_M), MAX_POSITION_ERROR_M)
        obs[n + 3 + i] = error[3 + i]
    position = math.hypot(math.hypot(error[0], error[1]), error[2])
    return obs, position, math.hypot(math.hypot(error[3], error[4]), error[5])


@numba.njit(cache=True)
def _moved(q, action, dt, velocity_limits, lower, upper):
    """The joints after velocities ``action`` (clipped to their limits) for ``dt``, held in their
    limits (NaN stays NaN, as numpy's clip keeps it)."""
    moved = np.empty(q.shape[0])
    for i in range(q.shape[0]):
        limit = velocity_limits[i]
        qd = action[i]
        if qd > limit:
            qd = limit
        elif qd < -limit:
            qd = -limit
        x = q[i] + qd * dt
        if x < lower[i]:
            x = lower[i]
        elif x > upper[i]:
            x = upper[i]
        moved[i] = x
    return moved
