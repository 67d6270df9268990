"""Record learning-environment episodes as bags: replay, Rerun and the studio's Replay then work on rollouts.

:class:`RecordEpisodeBags` wraps a ``robot_sims/CreateNav-v0`` or ``CreateCover-v0`` env (named
as Gymnasium's ``RecordVideo`` names its videos) and writes each episode its ``episode_trigger``
picks into its own rosbag2 bag folder ``<folder>/<name_prefix>-episode-<n>`` (MCAP): the topics,
types, frames and default rates a recorded ``create_world`` has (``create_sim.synthetic_run``
writes them), the actions on ``/cmd_vel``, CreateNav's goal region on ``/map_markers`` (ns
``goal``), and next to the bag's ``metadata.yaml`` an ``episode.yaml`` with the seed, return and
outcome. ``ArmReach-v0`` episodes are written as an ``arm`` world's topics
(:mod:`sim_tools.rl.record_arm`).

Timing: the env calls the recorder after every physics step (``CreateNavEnv.on_physics_step``), so
each message is written at the sim time the world would publish it (log time = header stamp = sim
time from 0 at reset); an action is on ``/cmd_vel`` at the start of the control period it drives,
and the last ``/clock`` is at ``steps × control period``.

The episode is not changed by recording: the bag's poses, odometry and velocities are the env
model's own, and its sensor readings are taken on a second model placed at the same pose with its
own noise stream (reading the env's model would take its noise draws). With a noisy config the
bag's noisy readings are hence other draws from the same noise than the observations (as a ROS
world's are: it reads each sensor on its own schedule); noise-free, they are the same values.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml
from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker

from create_sim import spec
from create_sim.model import BeaconSighting, CreateModel
from create_sim.synthetic_run import PHYSICS_HZ, STEP_NS, bag_topics, twist_msg, write_due, write_latched
from sim_runtime.bag.writer import BagWriter
from sim_runtime.errors import InputError
from sim_runtime.msgs import color_msg
from sim_tools.rl.arm_reach import ArmReachEnv
from sim_tools.rl.create_cover import CreateCoverEnv
from sim_tools.rl.create_nav import GOAL_COLOR, CreateNavEnv
from sim_tools.rl.record_arm import ArmEpisodeBag, meshed_arm

#: The file next to a bag's metadata.yaml that says how its episode went.
EPISODE_FILE = "episode.yaml"
GOAL_NS = "goal"


class RecordEpisodeBags(gym.Wrapper):
    """Write episodes of a CreateNav, CreateCover or ArmReach env as bag folders (see the module's docstring).

    ``episode_trigger(n)`` (n = 0, 1, … counted from the first reset) says whether episode ``n`` is
    recorded: by default every one. ``recorded`` lists the bag folders written so far.
    """

    def __init__(
        self,
        env: gym.Env,
        folder: str | Path,
        episode_trigger: Callable[[int], bool] | None = None,
        name_prefix: str = "rl-bag",
        compression: str = "zstd",
    ) -> None:
        super().__init__(env)
        if not isinstance(env.unwrapped, CreateNavEnv | ArmReachEnv):
            kind = type(env.unwrapped).__name__
            raise InputError(f"RecordEpisodeBags records CreateNav, CreateCover and ArmReach envs, not {kind}")
        self.folder = Path(folder)
        taken = sorted(self.folder.glob(f"{name_prefix}-episode-*"))
        if taken:
            raise InputError.at(taken[0], None, "a bag of this name exists; choose another folder or name_prefix")
        self.folder.mkdir(parents=True, exist_ok=True)
        self.episode_trigger = episode_trigger if episode_trigger is not None else lambda _n: True
        self.name_prefix = name_prefix
        self.compression = compression
        self.episode_id = -1
        self.recorded: list[Path] = []
        self._episode: _EpisodeBag | ArmEpisodeBag | None = None
        #: The arm with its meshes (for its robot_markers), loaded once.
        self._meshed = meshed_arm(env.unwrapped) if isinstance(env.unwrapped, ArmReachEnv) else None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self._finish({"finished": False})  # the episode before was cut short
        obs, info = self.env.reset(seed=seed, options=options)
        self.episode_id += 1
        if self.episode_trigger(self.episode_id):
            self._episode = self._start(self.folder / f"{self.name_prefix}-episode-{self.episode_id}", seed)
        return obs, info

    def _start(self, path: Path, seed: int | None) -> _EpisodeBag | ArmEpisodeBag:
        env = self.env.unwrapped
        if isinstance(env, ArmReachEnv) and self._meshed is not None:
            return ArmEpisodeBag(path, env, self._meshed, seed, self.compression)
        assert isinstance(env, CreateNavEnv)  # checked in __init__
        return _EpisodeBag(path, env, seed, self.compression)

    def step(self, action: Any):
        episode = self._episode
        if episode is not None:
            episode.before_step(action)
        obs, reward, terminated, truncated, info = self.env.step(action)
        if episode is not None:
            episode.after_step(action, float(reward))
            if terminated or truncated:
                self._finish(_outcome(info, terminated, truncated))
        return obs, reward, terminated, truncated, info

    def close(self) -> None:
        self._finish({"finished": False})
        super().close()

    def _finish(self, outcome: dict[str, Any]) -> None:
        """Close the episode's bag and write its episode.yaml beside metadata.yaml."""
        if self._episode is not None:
            folder, summary = self._episode.close()
            (folder / EPISODE_FILE).write_text(yaml.safe_dump({**summary, **outcome}, sort_keys=False))
            self.recorded.append(folder)
            self._episode = None


def _outcome(info: dict[str, Any], terminated: bool, truncated: bool) -> dict[str, Any]:
    outcome = {"finished": True, "terminated": bool(terminated), "truncated": bool(truncated)}
    for key in (
        "is_success",
        "bumped",
        "collided",
        "distance_m",
        "area_covered_m2",
        "position_error_m",
        "rotation_error_rad",
    ):
        if key in info:
            outcome[key] = info[key].item() if isinstance(info[key], np.generic) else info[key]
    return outcome


class _EpisodeBag:
    """One episode being written: hooked into the env's physics steps until closed."""

    def __init__(self, path: Path, env: CreateNavEnv, seed: int | None, compression: str) -> None:
        self.env = env
        self.k = 0  # physics steps since reset
        # chunks close every half second of sim time, as synthetic runs do
        self.bag = BagWriter(path, compression=compression, clock=lambda: self.k / PHYSICS_HZ)
        self.put = bag_topics(self.bag, full=True)
        model = env._model()
        self.sensed = _Sensed(model, _shadow(env))
        is_nav = not isinstance(env, CreateCoverEnv)
        write_latched(self.put, env.map, 0, full=True, extra_markers=_goal_markers(env) if is_nav else ())
        write_due(self.put, self.sensed, 0, 0, full=True)
        env.on_physics_step = self._physics_step
        self.summary: dict[str, Any] = {
            "env": env.spec.id if env.spec is not None else type(env).__name__,
            "seed": seed,
            "model_seed": env.model_seed,
            "map_file": env.map_file,
            "start": list(env.start_pose),
            **({"goal": list(env.goal_xy), "goal_radius_m": env.goal_radius_m} if is_nav else {}),
            "control_period_s": env.substeps / PHYSICS_HZ,
            "return": 0.0,
        }

    def before_step(self, action: Any) -> None:
        """The action as a controller's ``cmd_vel``, at the start of the control period it drives."""
        self.put("/" + spec.CMD_VEL_TOPIC, self.k * STEP_NS, twist_msg(float(action[0]), float(action[1])))

    def after_step(self, _action: Any, reward: float) -> None:
        self.summary["return"] += reward  # the messages were written at each physics step

    def _physics_step(self, _model: CreateModel) -> None:
        self.k += 1
        self.sensed.sync()
        write_due(self.put, self.sensed, self.k, self.k * STEP_NS, full=True)

    def close(self) -> tuple[Path, dict[str, Any]]:
        """Unhook and close the bag: its folder and the episode's summary."""
        if self.env.on_physics_step == self._physics_step:
            self.env.on_physics_step = None
        self.bag.close()
        return self.bag.folder, {**self.summary, "steps": self.env.steps}


def _shadow(env: CreateNavEnv) -> CreateModel:
    """The recorder's sensing model: the env's map and noise, its own noise stream (from the episode's)."""
    rng = np.random.default_rng([env.model_seed, 1])
    x, y, theta = env.start_pose
    return CreateModel(env.map, env.noise, rng, pose=(x, y, theta))


def _goal_markers(env: CreateNavEnv) -> list[Marker]:
    """The goal region: a circle of the goal radius, drawn as the map is (Rerun shows it)."""
    gx, gy = env.goal_xy
    circle = np.linspace(0.0, 2 * math.pi, 33)
    m = Marker(ns=GOAL_NS, id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
    r = env.goal_radius_m
    m.points = [Point(x=float(gx + r * math.cos(a)), y=float(gy + r * math.sin(a))) for a in circle.tolist()]
    m.pose.orientation.w = 1.0
    m.scale.x = 0.03
    m.color = color_msg(*GOAL_COLOR)
    m.header.frame_id = "map"
    return [m]


class _Sensed:
    """The env's Create as its bag shows it: the env model's pose, odometry and velocity; the sensors
    read on the shadow model, placed at the env model's pose before each reading (:meth:`sync`)."""

    def __init__(self, model: CreateModel, shadow: CreateModel) -> None:
        self.model, self.shadow = model, shadow

    def sync(self) -> None:
        self.shadow.set_pose(*self.model.pose.tolist())

    @property
    def pose(self) -> np.ndarray:
        return self.model.pose

    @property
    def odometry_pose(self) -> np.ndarray:
        return self.model.odometry_pose

    @property
    def velocity(self) -> tuple[float, float]:
        return self.model.velocity

    def bumps(self) -> tuple[bool, bool]:
        return self.shadow.bumps()

    def wall_sensor(self) -> bool:
        return self.shadow.wall_sensor()

    def virtual_wall(self) -> bool:
        return self.shadow.virtual_wall()

    def cliff_signals(self) -> np.ndarray:
        return self.shadow.cliff_signals()

    def sonar(self) -> np.ndarray:
        return self.shadow.sonar()

    def lidar(self) -> np.ndarray:
        return self.shadow.lidar()

    def camera(self) -> list[BeaconSighting]:
        return self.shadow.camera()
