"""``robot_sims/ArmReach-v0``: bring a serial arm's flange to a target pose with joint velocities.

A Gymnasium environment over the pure :class:`~arm_sim.arm.Arm` kinematics (no ROS), for any arm
config (``robot="irb120"``, ``"csa7"`` (7 joints) or a config file's path).

- **Action**: joint velocities (rad/s, m/s for a prismatic joint) within the config's velocity
  limits; each step integrates them over ``control_period_s`` and holds the joints in their limits.
- **Observation** (float32): the joint positions, then the flange's pose error to the target in the
  world frame: position (3, m) and rotation vector (3, rad) of ``R_target R_flangeᵀ``.
- **Reward** per step: ``-(position error m + 0.1 × rotation error rad)``; reaching the target
  (within ``tolerance_m`` and ``tolerance_rad``) adds ``+10`` and terminates; ``max_steps`` truncate.
- **Randomised per reset(seed=…)**: the start joints and the target (the flange pose of random
  joints within the limits, so it is reachable); ``start`` / ``target_q`` fix them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, overload

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from arm_sim.arm import Arm
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path

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
        max_steps: int = 200,
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
        self.max_steps = int(max_steps)
        limit = self.arm.velocity_limits.astype(np.float32)
        self.action_space = spaces.Box(-limit, limit, dtype=np.float32)
        err = [MAX_POSITION_ERROR_M] * 3 + [math.pi] * 3
        low = np.concatenate([self.arm.lower, -np.array(err)]).astype(np.float32)
        high = np.concatenate([self.arm.upper, err]).astype(np.float32)
        self.observation_space = spaces.Box(low, high, shape=(n + 6,), dtype=np.float32)
        self.q = self.arm.mid_range()
        self.target = self.arm.fkine(self.q)

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
        limit = self.arm.velocity_limits
        qd = np.minimum(np.maximum(np.asarray(action, dtype=float), -limit), limit)
        self.q = np.minimum(np.maximum(self.q + qd * self.dt, self.arm.lower), self.arm.upper)
        self.steps += 1
        obs, info = self._observe()
        reached = info["position_error_m"] <= self.tolerance_m and info["rotation_error_rad"] <= self.tolerance_rad
        reward = -(info["position_error_m"] + ROTATION_WEIGHT * info["rotation_error_rad"])
        if reached:
            reward += REACH_REWARD
        info["is_success"] = reached
        truncated = self.steps >= self.max_steps and not reached
        return obs, float(reward), bool(reached), truncated, info

    def _observe(self) -> tuple[np.ndarray, dict[str, Any]]:
        error = pose_error(self.target, self.arm.fkine(self.q)).tolist()
        cap = MAX_POSITION_ERROR_M
        position = [min(max(e, -cap), cap) for e in error[:3]]
        obs = np.array(self.q.tolist() + position + error[3:], dtype=np.float32)
        info = {"position_error_m": math.hypot(*error[:3]), "rotation_error_rad": math.hypot(*error[3:])}
        return obs, info


def pose_error(target: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """6-vector from ``pose`` to ``target`` (4x4 each): position difference and the rotation vector
    of ``R_target Rᵀ`` (world frame, angle in [0, π])."""
    R = target[:3, :3] @ pose[:3, :3].T
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R.tolist()
    skew = (r21 - r12, r02 - r20, r10 - r01)
    sine2 = math.hypot(*skew)  # 2 sin(angle)
    angle = math.atan2(sine2, r00 + r11 + r22 - 1.0)
    if sine2 > 1e-9:
        rotvec = [c * (angle / sine2) for c in skew]
    elif angle < 1.0:
        rotvec = [0.5 * c for c in skew]  # tiny rotation
    else:
        # a half turn: the axis is the column of R + I with the largest norm
        axes = R + np.eye(3)
        axis = axes[:, int(np.argmax(np.linalg.norm(axes, axis=0)))]
        rotvec = (math.pi * axis / np.linalg.norm(axis)).tolist()
    (dx, dy, dz) = (target[:3, 3] - pose[:3, 3]).tolist()
    return np.array([dx, dy, dz, *rotvec])
