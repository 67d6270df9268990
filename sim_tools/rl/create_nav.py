"""``robot_sims/CreateNav-v0``: drive a Create to a goal region on a map file without collisions.

A Gymnasium environment over the pure :class:`~create_sim.model.CreateModel` (no ROS): the same
physics and sensor models as the ROS world, stepped at the world's physics rate.

- **Action**: ``[v, ω]`` (m/s, rad/s) within the robot's limits (each wheel ±``MAX_WHEEL_SPEED``);
  a pair beyond one wheel's limit is clamped per wheel, as the world does. ``normalize_actions=True``:
  ``[-1, 1]`` in both, mapped linearly onto those bounds (0 = stopped).
- **Observation**: one float32 vector, the parts chosen by ``sensors`` in this order (each read
  from the model in this order after every step, so noise draws are reproducible):
  ``lidar`` (``lidar_beams`` ranges, m, evenly picked from the 681 beams, no return = max range),
  ``sonar`` (4 ranges, m, [front, left, back, right], none = max range, too close = 0),
  ``bump`` (left, right: 0/1), ``cliff`` (4 signals, %, as read: noise is unbounded), ``goal``
  (distance m and bearing rad of the goal from the robot, as its noisy odometry believes it is:
  the goal is given once, relative to the start, like a real robot's).
- **Reward** per step: ``10 × (metres closer to the goal)`` (true pose) ``- 0.01``; reaching the
  goal (centre within ``goal_radius_m``) adds ``+10`` and terminates; a collision adds ``-10`` and
  terminates; ``max_steps`` steps truncate (``None``: never; ``gymnasium.make`` then truncates by
  its ``max_episode_steps``, registered as 600).
- **Collision**: a wall touched the body at the end of any physics step of the env step, from any
  side (:meth:`~create_sim.model.CreateModel.touching`): the bumpers cover only the front half, so
  reversing or sliding into a wall is a collision without a bump. ``info["collided"]`` says it,
  ``info["bumped"]`` whether a bumper is pressed at the step's end.
- **Randomised per reset(seed=…)**: the start pose and the goal (poses clear of every wall in the
  walls' bounding box, as ``robot_sims batch``'s ``poses: {random: n}``, the goal reachable from
  the start (:mod:`~sim_tools.rl.create_regions`) and outside the goal region), and the noise stream;
  ``start``/``goal`` (constructor or ``reset(options=…)``) fix them.
- ``render_mode="rgb_array"``: :meth:`~CreateNavEnv.render` draws the walls, the track so far, the
  goal region, the sensors' rays and the robot (body, heading, bumpers, collisions) in a few ms;
  ``"human"`` shows those frames in a window (where a display exists).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from create_sim import spec
from create_sim.configfile import NoiseConfig, load_config
from create_sim.mapfile import load_map
from create_sim.model import CreateModel
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_tools.adapters.create.world import random_create_poses
from sim_tools.rl.create_regions import map_regions
from sim_tools.rl.create_sensors import (
    DEFAULT_GOAL_RADIUS_M,
    DEFAULT_SENSORS,
    MAX_GOAL_DISTANCE_M,
    WRITE,
    checked_sensors,
    goal_in_odom,
    lidar_index,
)
from sim_tools.rl.frames import FrameWindow, Robot, TopView, check_render_mode
from sim_tools.rl.kernels import normalized_box, physical_action

PROGRESS_REWARD = 10.0  # per metre closer to the goal
STEP_COST = 0.01
GOAL_REWARD = 10.0
COLLISION_PENALTY = 10.0
#: A random start or goal is at least this clear of every wall (m).
START_MARGIN_M = 0.1
#: Random draws of a start and goal before giving up (a map with no room for a fair pair).
MAX_DRAWS = 100
GOAL_COLOR = (0.1, 0.8, 0.2)  # the goal region on the recorded bags' /map_markers
MAX_W = spec.MAX_TURN_RATE_RADPS  # spinning in place
#: A wall within a control period's travel plus this (m: the contact reach and the physics' push-out
#: slack) is checked for contact after every physics step.
_CHECK_MARGIN_M = CreateModel.CONTACT_M + 1e-6


class CreateNavEnv(gym.Env[np.ndarray, np.ndarray]):
    """Navigate to a goal region without touching a wall (see the module's docstring)."""

    # render_fps: one frame per step at the default control period (0.1 s)
    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}  # noqa: RUF012 (Gymnasium's own attribute)

    def __init__(
        self,
        map_file: str | Path | None = None,
        config_file: str | Path | None = None,
        *,
        sensors: Sequence[str] = DEFAULT_SENSORS,
        lidar_beams: int = 24,
        start: Sequence[float] | None = None,
        goal: Sequence[float] | None = None,
        goal_radius_m: float = DEFAULT_GOAL_RADIUS_M,
        control_period_s: float = 0.1,
        max_steps: int | None = 600,
        normalize_actions: bool = False,
        render_mode: str | None = None,
    ) -> None:
        self.sensors = checked_sensors(sensors)
        self.render_mode = check_render_mode(render_mode, self.metadata["render_modes"])
        self.map_file = str(map_file if map_file is not None else config_path("create/example.map"))
        self.map = load_map(self.map_file)
        self.noise = load_config(config_file) if config_file is not None else NoiseConfig()
        self.start, self.goal = start, goal
        self.goal_radius_m = float(goal_radius_m)
        self.substeps = max(1, round(control_period_s * spec.PHYSICS_RATE))
        self.max_steps = int(max_steps) if max_steps is not None else math.inf
        self.lidar_index = lidar_index(lidar_beams)
        #: The action's bounds in the robot's units (m/s, rad/s), whatever ``normalize_actions``.
        self.physical_action_space = spaces.Box(
            np.array([-CreateModel.MAX_WHEEL_SPEED, -MAX_W], dtype=np.float32),
            np.array([CreateModel.MAX_WHEEL_SPEED, MAX_W], dtype=np.float32),
        )
        self.normalize_actions = bool(normalize_actions)
        box = self.physical_action_space
        self.action_space = normalized_box(box) if normalize_actions else box
        self._act_bounds = (box.low.astype(float), box.high.astype(float))
        low, high = self._bounds()
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self._obs_size = low.shape[0]
        self._parts = self._reading_parts()
        self.model: CreateModel | None = None
        #: Whether a wall touched the body during the last step (see :meth:`_advance`).
        self.collided = False
        self._clear_m = -math.inf
        self.track: list[tuple[float, float]] = []
        self._pose = np.zeros(3)  # the true pose after the last step or reset
        self._view: TopView | None = None  # made at the first frame
        self._window: FrameWindow | None = None
        self._last_obs: np.ndarray | None = None  # what a frame draws the rays of
        half_fov = 0.5 * CreateModel.LIDAR_FOV
        self._lidar_angles = np.linspace(-half_fov, half_fov, CreateModel.LIDAR_BEAMS)[self.lidar_index]
        #: Called after each physics step (the episode recorder, ``sim_tools.rl.record``, hooks in here).
        self.on_physics_step: Callable[[CreateModel], None] | None = None

    def _reading_parts(self) -> list[tuple[Any, Any]]:
        """Per chosen sensor, how to read it (None: the bumps, read by the step) and write it."""
        return [(_RAW.get(name), WRITE[name]) for name in self.sensors]

    def __getstate__(self) -> dict[str, Any]:
        """A copy to pickle (the vector env moves sub-envs between processes): the readers are
        functions made here, made again on the other side; a window stays behind."""
        state = self.__dict__.copy()
        state["_parts"], state["_window"] = None, None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._parts = self._reading_parts()

    # ----------------------------------------------------------------------------- spaces
    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        parts = {
            "lidar": (CreateModel.LIDAR_RANGE[0], CreateModel.LIDAR_RANGE[1], len(self.lidar_index)),
            "sonar": (0.0, CreateModel.SONAR_RANGE[1], 4),
            "bump": (0.0, 1.0, 2),
            "cliff": (-np.inf, np.inf, 4),  # noise is unbounded
        }
        low: list[float] = []
        high: list[float] = []
        for name in self.sensors:
            if name == "goal":
                low += [0.0, -math.pi]
                high += [MAX_GOAL_DISTANCE_M, math.pi]
            else:
                lo, hi, n = parts[name]
                low += [lo] * n
                high += [hi] * n
        return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)

    # ----------------------------------------------------------------------------- episode
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        start, goal = self._start_and_goal(options.get("start", self.start), options.get("goal", self.goal))
        #: The model's noise seed this episode (drawn from the env's seeded stream).
        self.model_seed = int(self.np_random.integers(2**63 - 1))
        self.model = CreateModel(self.map, self.noise, np.random.default_rng(self.model_seed), pose=start)
        self.start_pose = tuple(float(v) for v in start)
        self.goal_xy = (float(goal[0]), float(goal[1]))
        # The goal in the odometry frame (odometry starts at (0, 0, 0) on the start pose).
        x, y, theta = self.start_pose
        self.goal_odom = goal_in_odom(self.goal_xy, (x, y, theta), np.zeros(3))
        self.steps = 0
        self._clear_m = -math.inf  # the clearance's lower bound: none yet (see _advance)
        self.track = [(float(start[0]), float(start[1]))]
        self._pose = self.model.pose
        self.distance_m = self._true_distance()
        obs = self._observe(self.model.bumps())
        self._show()
        return obs, self._info()

    def _start_and_goal(self, start: Sequence[float] | None, goal: Sequence[float] | None):
        """The fixed ones, the rest drawn from the env's seeded stream: clear of the walls, the goal
        reachable from the start and outside the goal region."""
        for _ in range(MAX_DRAWS):
            drawn = random_create_poses(self.map_file, 2, int(self.np_random.integers(2**31)), START_MARGIN_M)
            pose = tuple(float(v) for v in start) if start is not None else drawn[0]
            if len(pose) != 3:
                raise InputError(f"start {pose}: x, y, theta")
            xy = tuple(float(v) for v in goal) if goal is not None else drawn[1][:2]
            if len(xy) != 2:
                raise InputError(f"goal {xy}: x, y")
            if (start is not None and goal is not None) or self._fair(pose, xy):
                return pose, xy
        raise InputError(f"{self.map_file}: no reachable goal found for start {start} / goal {goal}")

    def _fair(self, start: tuple[float, ...], goal: tuple[float, ...]) -> bool:
        far = math.hypot(goal[0] - start[0], goal[1] - start[1]) > 2.0 * self.goal_radius_m
        regions = map_regions(self.map_file, CreateModel.RADIUS)
        # a start given on no free square (hard by a wall, or in one: the model says) is not judged
        return far and (regions.region(start[0], start[1]) < 0 or regions.connected(start, goal))

    def step(self, action: np.ndarray):
        model = self._advance(action)
        bumps = model.bumps()
        obs = self._observe(bumps)
        before, self.distance_m = self.distance_m, self._true_distance()
        reward = PROGRESS_REWARD * (before - self.distance_m) - STEP_COST
        collided = self.collided
        reached = self.distance_m <= self.goal_radius_m
        if reached:
            reward += GOAL_REWARD
        if collided:
            reward -= COLLISION_PENALTY
        truncated = self.steps >= self.max_steps and not (reached or collided)
        info = self._info(bumped=bumps[0] or bumps[1], collided=collided)
        self._show()
        return obs, float(reward), bool(reached or collided), truncated, info

    def _advance(self, action: np.ndarray) -> CreateModel:
        """One control period at the action's (v, ω), the track extended; :attr:`collided` says
        whether a wall touched the body after any of its physics steps (a touch in mid-period that
        the body slid off by the period's end is a collision too, as ``robot_sims batch``'s
        ``collisions`` counts it from every physics step)."""
        model = self._model()
        if self.normalize_actions:
            action = physical_action(action, *self._act_bounds)
        v, w = np.asarray(action).tolist()  # plain floats (a float32 pair's values exactly)
        model.set_velocity(v, w)
        dt, hook = 1.0 / spec.PHYSICS_RATE, self.on_physics_step
        # The body never moves faster than commanded (walls only slow it, turning does not move
        # a circle), so a wall further than this period's travel cannot be touched in it: no
        # contact check per physics step then. _clear_m is a lower bound of the clearance, the
        # exact one taken again only when the bound comes within a period's travel.
        travel = abs(model.command[0]) * dt * self.substeps
        if self._clear_m - travel <= _CHECK_MARGIN_M:
            self._clear_m = model.clearance()
        near = self._clear_m - travel <= _CHECK_MARGIN_M
        touched = False
        for _ in range(self.substeps):
            model.step(dt)
            if hook is not None:
                hook(model)
            if near and not touched:
                touched = model.touching()
        self._clear_m -= travel
        self.collided = touched
        self.steps += 1
        self._pose = model.pose  # the info's (a fresh array each step)
        x, y, _ = self._pose.tolist()
        self.track.append((x, y))
        return model

    def _model(self) -> CreateModel:
        if self.model is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        return self.model

    def render(self) -> np.ndarray | None:
        """The frame of now (:mod:`~sim_tools.rl.frames`): walls, painted lines, the track since
        reset, the goal region, the observed LIDAR beams and sonar rays, and the robot's body with
        its heading, its bumpers red while pressed, the body red on a collision. ``rgb_array``:
        returned, (height, width, 3) uint8; ``human``: shown in a window (also after every reset and
        step), None returned; no ``render_mode``: None."""
        if self.render_mode is None:
            return None
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            self._window = FrameWindow(f"robot_sims {type(self).__name__}", self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def _show(self) -> None:
        """In ``human`` mode, the frame of now in the window (after every reset and step)."""
        if self.render_mode == "human":
            self.render()

    def _frame(self) -> np.ndarray:
        model = self._model()  # ResetNeeded before the first reset
        if self._view is None:
            self._view = TopView(self.map.walls, self.map.lines)
        x, y, theta = self._pose.tolist()
        robot = Robot(x, y, theta, CreateModel.RADIUS, model.bumps(), self.collided, self._rays(x, y, theta))
        return self._view.frame([robot], [self.track], self._frame_goal(), f"step {self.steps}")

    def _frame_goal(self) -> tuple[float, float, float] | None:
        """The goal region a frame draws: (x, y, radius) m."""
        return (*self.goal_xy, self.goal_radius_m)

    def _rays(self, x: float, y: float, theta: float) -> list[tuple[float, float, float, float, bool]]:
        """The last observation's LIDAR beams (from the LIDAR, at the front) and sonar rays (from
        the body's edge): origin, end and whether it returned."""
        rays: list[tuple[float, float, float, float, bool]] = []
        obs, at = self._last_obs, 0
        if obs is None:
            return rays
        r = CreateModel.RADIUS
        if "lidar" in self.sensors:
            n, hi = len(self.lidar_index), CreateModel.LIDAR_RANGE[1]
            ox, oy = x + r * math.cos(theta), y + r * math.sin(theta)
            for angle, d in zip(self._lidar_angles.tolist(), obs[:n].tolist(), strict=True):
                rays.append((ox, oy, ox + d * math.cos(theta + angle), oy + d * math.sin(theta + angle), d < hi))
            at = n
        if "sonar" in self.sensors:
            hi = CreateModel.SONAR_RANGE[1]
            for bearing, d in zip(spec.SONAR_BEARINGS_RAD, obs[at : at + 4].tolist(), strict=True):
                a = theta + bearing
                ox, oy = x + r * math.cos(a), y + r * math.sin(a)
                rays.append((ox, oy, ox + d * math.cos(a), oy + d * math.sin(a), d < hi))
        return rays

    def close(self) -> None:
        """The window of ``render_mode="human"`` closed."""
        if self._window is not None:
            self._window.close()
            self._window = None

    # ----------------------------------------------------------------------------- readings
    def _observe(self, bumps: tuple[bool, bool]) -> np.ndarray:
        """The chosen sensors, read in the order of :data:`SENSORS` (their noise draws in that order)
        and written as :func:`~sim_tools.rl.create_sensors.observation` writes them; ``bumps``: the
        bumpers, already read for the step's end (they draw no noise)."""
        model, index, goal = self.model, self.lidar_index, self.goal_odom
        out = np.empty(self._obs_size, np.float32)
        at = 0
        for read, write in self._parts:
            at = write(out, at, bumps if read is None else read(model, index), goal)
        self._last_obs = out
        return out

    def _true_distance(self) -> float:
        x, y = self.track[-1]  # where the body is now
        return math.hypot(self.goal_xy[0] - x, self.goal_xy[1] - y)

    def _info(self, bumped: bool = False, collided: bool = False) -> dict[str, Any]:
        return {
            "pose": self._pose,
            "goal": np.array(self.goal_xy),
            "distance_m": self.distance_m,
            "bumped": bumped,
            "collided": collided,
            "is_success": self.distance_m <= self.goal_radius_m,
        }


#: How the env reads each sensor's raw reading from the model (``index``: the chosen LIDAR beams;
#: the bumpers are read once per step, by the step).
_RAW = {
    "lidar": lambda model, index: model.lidar(index),
    "sonar": lambda model, _index: model.sonar(),
    "cliff": lambda model, _index: model.cliff_signals(),
    "goal": lambda model, _index: model.odometry_pose,
}
