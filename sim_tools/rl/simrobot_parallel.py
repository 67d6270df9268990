"""SIMROBOT as a PettingZoo ``ParallelEnv``: one agent per robot of a bitmap world file.

Each agent observes its own robot's sensors and sets its own wheel speeds; the physics and the
sensors are :class:`simrobot_sim.model.SimrobotWorld`'s, stepped once per ``step`` (one ``dt``).

- Observation (``Box(0, 1)``, float32): every sensor of the robot in file order, an ultrasonic
  sensor as one value (its nearest echo), a laser as one value per ray; each distance divided by
  the sensor's range, no echo reads 1.
- Action (``Box``, float32): wheel speeds ``[left, right]`` in rad/s within
  ``±max_wheel_speed``; values outside are clipped.
- Reward: the distance the robot moved forward this step (along its heading before the step)
  divided by the most it can move in a step (``wheel radius * max_wheel_speed * dt``): 1 per step
  at full speed straight on, 0 turning on the spot, negative backwards; ``-crash_penalty`` on
  the step it crashes.
- A crash (into a wall, the map's edge or another robot) terminates that agent; its robot stays
  where it stopped, an obstacle for the others. Every agent is truncated after ``max_steps``
  steps (default: the world file's ``steps_limit``, else 1000).
- ``reset(seed=…, options={"random_start": True})`` (or ``random_start=True`` at construction)
  places the robots at random free poses drawn from the seed; otherwise at the file's poses.

- ``render_mode="rgb_array"``: :meth:`render` draws the map, the tracks so far and every robot's
  body and heading in a few ms (:mod:`~sim_tools.rl.frames`); ``"human"`` shows those frames in a
  window where a display exists.

Deterministic: the same seed and actions give the same episode.
"""

from __future__ import annotations

import copy
import math
from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar

import numba
import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from sim_runtime.errors import InputError
from sim_runtime.paths import resolve_input_file
from sim_tools.rl.frames import FrameWindow, Robot, TopView, check_render_mode
from sim_tools.rl.kernels import clip_into
from simrobot_sim import raycast
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import MAX_ROBOTS_UINT8, RobotSpec, WorldSpec, load_world

#: The shipped world used when none is given (four robots, one ultrasonic sensor each).
DEFAULT_WORLD = "simrobot/demo.yaml"
#: Wheel speed limit (rad/s) of the action space: twice the demo's avoid algorithm's 0.5.
MAX_WHEEL_SPEED = 1.0
#: Steps before truncation when the world file sets no ``steps_limit``.
DEFAULT_MAX_STEPS = 1000
#: Reward on the step an agent crashes (subtracted).
CRASH_PENALTY = 10.0
#: Tries to find a free random pose for one robot before giving up.
_PLACEMENT_TRIES = 10_000


def _observation_size(robot: RobotSpec) -> int:
    # an ultrasonic sensor gives its nearest echo, a laser every ray
    return sum(1 if s.kind == "ultrasonic" else s.rays for s in robot.sensors)


def _normalised(distance: np.ndarray, max_range: float) -> np.ndarray:
    # distance / range in [0, 1]; no echo (inf) reads 1
    return np.minimum(distance / max_range, 1.0)


@numba.njit(cache=True)
def _progress(before: np.ndarray, after: np.ndarray, best_step_m: np.ndarray) -> np.ndarray:
    """Every robot's forward distance this step (along its heading before it) over the largest
    possible one (``best_step_m``), from the poses (n, 3: x, y, heading) before and after."""
    out = np.empty(before.shape[0])
    for i in range(before.shape[0]):
        heading = before[i, 2]
        dx, dy = after[i, 0] - before[i, 0], after[i, 1] - before[i, 1]
        out[i] = (dx * math.cos(heading) + dy * math.sin(heading)) / best_step_m[i]
    return out


def _world(spec: WorldSpec) -> SimrobotWorld:
    # the file's threads (results are the same whatever the number); wide ids beyond 254 robots
    return SimrobotWorld(spec, wide_ids=len(spec.robots) > MAX_ROBOTS_UINT8)


class SimrobotParallelEnv(ParallelEnv):
    """One agent per robot of a SIMROBOT world (see the module's docstring for the spaces and the
    reward). Agents are named after the robots."""

    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": ["human", "rgb_array"],
        "render_fps": 10,
        "name": "simrobot_parallel_v0",
        "is_parallelizable": True,
    }

    def __init__(
        self,
        world_file: str | Path = DEFAULT_WORLD,
        *,
        max_wheel_speed: float = MAX_WHEEL_SPEED,
        max_steps: int | None = None,
        crash_penalty: float = CRASH_PENALTY,
        random_start: bool = False,
        render_mode: str | None = None,
    ) -> None:
        """``world_file``: a SIMROBOT world file (absolute, relative to the current directory, or to
        the shipped ``config/``). Every robot needs at least one sensor."""
        check_render_mode(render_mode, self.metadata["render_modes"])
        if not (math.isfinite(max_wheel_speed) and max_wheel_speed > 0):
            raise InputError(f"max_wheel_speed: expected a finite number > 0 (rad/s), got {max_wheel_speed!r}")
        self.render_mode = render_mode
        self._view: TopView | None = None  # made at the first frame
        self._window: FrameWindow | None = None
        self.spec_file: WorldSpec = load_world(resolve_input_file(str(world_file), "world_file"))
        for i, robot in enumerate(self.spec_file.robots):
            if not robot.sensors:
                raise InputError(f"{self.spec_file.source}: robots[{i}] ({robot.name!r}): an agent needs a sensor")
        self.max_wheel_speed = float(max_wheel_speed)
        limit = self.spec_file.steps_limit
        default_steps = limit if math.isfinite(limit) else DEFAULT_MAX_STEPS
        self.max_steps = int(max_steps if max_steps is not None else default_steps)
        self.crash_penalty = float(crash_penalty)
        self.random_start = bool(random_start)
        self.possible_agents = [r.name for r in self.spec_file.robots]
        # PettingZoo asks for the same space objects every time
        speed = self.max_wheel_speed
        self._action_spaces = {a: spaces.Box(-speed, speed, shape=(2,), dtype=np.float32) for a in self.possible_agents}
        self._observation_spaces = {
            r.name: spaces.Box(0.0, 1.0, shape=(_observation_size(r),), dtype=np.float32) for r in self.spec_file.robots
        }
        self.agents: list[str] = []
        self._live: list[int] = []  # the agents' robots' numbers in the world
        self._clearance = raycast.clearance_field(self.spec_file.walls)
        self._template = _world(self.spec_file)
        self._template.compile_kernels()
        #: Each robot's sensor numbers in the world, in file order.
        self._sensors_of: list[list[int]] = [[] for _ in self.possible_agents]
        for k, sensor in enumerate(self._template.sensors):
            self._sensors_of[sensor.robot].append(k)
        #: Per robot (sensor number, range) when its only sensor is an ultrasonic one, else None.
        self._one_echo = [
            (ks[0], self._template.sensors[ks[0]].range)
            if len(ks) == 1 and self._template.sensors[ks[0]].kind == "ultrasonic"
            else None
            for ks in self._sensors_of
        ]
        #: The same when every robot has one ultrasonic sensor (the usual world), else None.
        self._echoes = [e for e in self._one_echo if e is not None] if None not in self._one_echo else None
        self.world = self._template
        self._steps = 0
        #: Every robot's pose (x, y, heading) where the last step (or the reset) left it, (n, 3).
        self._poses: np.ndarray = self.world.poses()
        #: Per robot, the most it can move in a step (m): wheel radius * top wheel speed * dt.
        self._best_step_m = np.array([r.R * self.max_wheel_speed * self._template.dt for r in self.spec_file.robots])

    def observation_space(self, agent: str) -> spaces.Box:
        """The agent's sensors, normalised to 0-1."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The agent's wheel speeds [left, right] (rad/s)."""
        return self._action_spaces[agent]

    # -- episode ---------------------------------------------------------------------------------
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict]]:
        """New episode; ``options={"random_start": bool}`` overrides the constructor's choice."""
        if seed is not None or not hasattr(self, "np_random"):
            self.np_random = np.random.default_rng(seed)
        random_start = (options or {}).get("random_start", self.random_start)
        if random_start:
            self.world = _world(replace(self.spec_file, robots=self._random_robots()))
        else:
            self.world = self._fresh_template()
        self._set_agents(list(self.possible_agents))
        self._steps = 0
        self._poses = self.world.poses()
        return {a: self._observe(i) for i, a in enumerate(self.possible_agents)}, {a: {} for a in self.agents}

    def _fresh_template(self) -> SimrobotWorld:
        # a copy of the file's world as built (a copy costs far less than building it again)
        return copy.deepcopy(self._template)

    def step(
        self, actions: dict[str, np.ndarray]
    ) -> tuple[dict[str, np.ndarray], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict]]:
        """Set every live agent's wheel speeds, advance the world one ``dt``, read the sensors."""
        world, agents, live, limit = self.world, self.agents, self._live, self.max_wheel_speed
        # every live agent's pair at once (a robot's pair clipped alone gives the same numbers)
        wheels = np.array([actions[agent] for agent in agents], dtype=float).reshape(len(agents), 2)
        clip_into(wheels.reshape(-1), 0, wheels.reshape(-1), -limit, limit)  # in place (NaN kept: the world refuses it)
        for i, (left, right) in zip(live, wheels.tolist(), strict=True):
            world.set_wheel_speeds(i, left, right)
        crashed = set(world.step().tolist())
        before, after = self._poses, world.poses()
        self._poses = after
        self._steps += 1
        truncate = self._steps >= self.max_steps
        progress = _progress(before, after, self._best_step_m).tolist()
        rows = list(after.copy())  # the infos' own (the next step starts from ``after``)
        obs, rewards, terms, truncs, infos = {}, {}, {}, {}, {}
        for agent, i, seen in zip(agents, live, self._observe_all(live), strict=True):
            hit = i in crashed
            obs[agent] = seen
            rewards[agent] = -self.crash_penalty if hit else progress[i]
            terms[agent] = hit
            truncs[agent] = truncate and not hit
            infos[agent] = {"pose": rows[i]}
        if crashed or truncate:
            self._set_agents([a for a in agents if not (terms[a] or truncs[a])])
        return obs, rewards, terms, truncs, infos

    def _set_agents(self, agents: list[str]) -> None:
        """The live agents, and their robots' numbers in the world."""
        self.agents = agents
        self._live = [self.world.index[agent] for agent in agents]

    def _observe_all(self, robots: list[int]) -> list[np.ndarray]:
        """The robots' observations; when each has one ultrasonic sensor (the usual world), rows of
        one array made at once (an array per robot costs more than its sensor read)."""
        echoes = self._echoes
        if echoes is None:
            return [self._observe(i) for i in robots]
        world = self.world
        values = [min(world.nearest(echoes[i][0])[0] / echoes[i][1], 1.0) for i in robots]
        return list(np.array(values, dtype=np.float32).reshape(-1, 1))

    def _observe(self, i: int) -> np.ndarray:
        # robot i's sensors, normalised (see the module's docstring)
        world = self.world
        echo = self._one_echo[i]
        if echo is not None:  # the usual robot: one number
            return np.array([min(world.nearest(echo[0])[0] / echo[1], 1.0)], dtype=np.float32)
        parts = []
        for k in self._sensors_of[i]:
            sensor = world.sensors[k]
            if sensor.kind == "ultrasonic":
                parts.append(_normalised(np.array([world.nearest(k)[0]]), sensor.range))
            else:
                parts.append(_normalised(world.ranges(k)[0], sensor.range))
        return np.concatenate(parts).astype(np.float32)

    # -- random start poses ----------------------------------------------------------------------
    def _random_robots(self) -> tuple[RobotSpec, ...]:
        """Every robot at a random free pose: its pivot on a cell whose clearance from the walls
        exceeds the robot's reach, its reach clear of the robots placed before it."""
        spec = self.spec_file
        placed: list[tuple[float, float, float]] = []  # x, y (cells), reach (cells)
        robots = []
        for robot in spec.robots:
            reach = max(math.hypot(x, y) for x, y in robot.shape) * robot.scale / spec.resolution + 2.0
            x, y = self._free_cell(reach, placed, robot.name)
            placed.append((x, y, reach))
            heading = float(self.np_random.uniform(-math.pi, math.pi))
            position = (float(spec.origin[0] + x * spec.resolution), float(spec.origin[1] + y * spec.resolution))
            robots.append(replace(robot, position=position, heading=heading))
        return tuple(robots)

    def _free_cell(self, reach: float, placed: list[tuple[float, float, float]], name: str) -> tuple[float, float]:
        nx, ny = self._clearance.shape
        for _ in range(_PLACEMENT_TRIES):
            x = float(self.np_random.uniform(reach, nx - reach))
            y = float(self.np_random.uniform(reach, ny - reach))
            clear = int(self._clearance[int(x), int(y)])
            if clear == raycast.WALL or clear <= reach:
                continue
            if all(math.hypot(x - px, y - py) > reach + pr for px, py, pr in placed):
                return x, y
        raise InputError(f"{self.spec_file.source}: no free place for robot {name!r} found at random")

    def render(self) -> np.ndarray | None:
        """The frame of now (:mod:`~sim_tools.rl.frames`): the map, every robot's track, body (its
        outline, in its colour; red once crashed) and heading. ``rgb_array``: returned, (height,
        width, 3) uint8; ``human``: shown in a window, None returned; no ``render_mode``: None."""
        if self.render_mode is None:
            return None
        frame = self._frame()
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            self._window = FrameWindow("robot_sims SIMROBOT", self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def _frame(self) -> np.ndarray:
        world = self.world
        if self._view is None:
            walls = np.asarray(self.spec_file.walls, dtype=bool).T  # rows along y, as an OccupancyGrid's
            origin = (float(world.origin[0]), float(world.origin[1]))
            self._view = TopView(image=walls, resolution=world.resolution, origin=origin)
        robots = []
        for i, (x, y, heading) in enumerate(world.poses().tolist()):
            outline = world.outline(i)
            reach = float(np.hypot(outline[:, 0] - x, outline[:, 1] - y).max())
            red, green, blue = (int(255 * c) for c in world.colors[i])
            hit = bool(world.crashed[i])
            robots.append(Robot(x, y, heading, reach, hit=hit, outline=outline, fill=(red, green, blue)))
        return self._view.frame(robots, list(world.tracks().values()), None, f"step {self._steps}")

    def close(self) -> None:
        """The window of ``render_mode="human"`` closed."""
        if self._window is not None:
            self._window.close()
            self._window = None


def parallel_env(**kwargs: Any) -> SimrobotParallelEnv:
    """PettingZoo's usual constructor name."""
    return SimrobotParallelEnv(**kwargs)
