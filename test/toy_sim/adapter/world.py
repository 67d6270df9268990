"""The toy simulator for batch, demo, warm-up and ``--help`` (the contract:
:mod:`sim_tools.adapters.contract`).

A sweep's world entry: ``{toy_start: FILE}``, a start file (:mod:`toy_sim.toy_file`); episodes
start at its pose, or at the sweep's poses (random ones within :data:`RANDOM_HALF_SIDE_M` of the
origin). Our controller is ``toy_circle``. The probe records the pose after every step.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim_tools.adapters.contract import EntryReader, EpisodeData, MakeController, Pose

LABEL = "toy"
WORLD_KEY = "toy_start"
WORLD_OPTIONS: dict[str, str] = {}
RESERVED = {"initial_pose": "the sweep's poses"}
CONTROLLERS = {"toy_circle": "toy_sim.driver:CircleNode"}
WORLD_NODE_NAME = "toy_world"
NODE_EXECUTABLES: dict[str, tuple[str, str]] = {}  # the toy has no executable of robot_sims
ROBOT_NAMESPACES = False
MFILE_CONTROLLERS = False
#: Random start poses lie in the square of this half side around the origin (m).
RANDOM_HALF_SIDE_M = 2.0
demo = None
sample_run = None


def _load_start(path: str) -> Any:
    from toy_sim.toy_file import load_start

    return load_start(path)


WORLD_FILES = {"toy_start": _load_start}


def read_world(r: EntryReader, entry: dict[str, Any], where: str) -> dict[str, Any]:
    return {"toy_start": r.file(entry["toy_start"], f"{where}.toy_start")}


def make_world(world: dict[str, Any], pose: Pose | None, overrides: list[Any], **node_kwargs: Any) -> Any:
    """A toy world at ``pose``, else at the start file's."""
    from rclpy.parameter import Parameter

    from toy_sim.world_node import ToyWorldNode

    start = pose if pose is not None else _load_start(world["toy_start"]).pose
    overrides = [*overrides, Parameter("initial_pose", value=[float(v) for v in start])]
    return ToyWorldNode(parameter_overrides=overrides, **node_kwargs)


def random_poses(world: dict[str, Any], count: int, seed: int, margin_m: float) -> list[Pose]:
    """Uniform in the square around the origin (an empty plane: no margin to keep)."""
    rng = np.random.default_rng(seed)
    half = RANDOM_HALF_SIDE_M
    return [
        (float(x), float(y), float(theta))
        for x, y, theta in rng.uniform((-half, -half, -math.pi), (half, half, math.pi), size=(count, 3))
    ]


def controller_nodes(
    cls: type, world_node: Any, world: dict[str, Any], make: MakeController, **node_kwargs: Any
) -> list[Any]:
    return [make(cls)]


def probe_kwargs(cls: type) -> dict[str, str] | None:
    return {}


class ToyProbe:
    """The pose after every step: arrays ``x, y`` (m), ``theta`` (rad)."""

    def __init__(self, world: Any, steps: int) -> None:
        self.world = world
        self.rows = np.empty((steps + 1, 4))
        self.n = 0
        self.sample()

    def sample(self) -> None:
        self.rows[self.n] = (self.world.sim_time, *self.world.model.pose)
        self.n += 1

    def data(self, params: dict[str, Any], seed: int) -> EpisodeData:
        r = self.rows[: self.n]
        return EpisodeData(r[:, 0], {"x": r[:, 1], "y": r[:, 2], "theta": r[:, 3]}, {}, params, seed)


def probe(world_node: Any, world: dict[str, Any], steps: int) -> ToyProbe:
    return ToyProbe(world_node, steps)


def toy_distance_m(data: EpisodeData) -> float:
    """Path length (m)."""
    return float(np.hypot(np.diff(data.arrays["x"]), np.diff(data.arrays["y"])).sum())


def toy_turned_rad(data: EpisodeData) -> float:
    """Heading change over the episode, unwrapped (rad)."""
    return float(np.unwrap(data.arrays["theta"])[-1] - data.arrays["theta"][0])


METRICS = {"distance_m": toy_distance_m, "turned_rad": toy_turned_rad}
METRIC_RULES: dict[tuple[str, str], Any] = {}


def warm_up() -> None:
    """Nothing to compile: the model is plain numpy."""


def describe_kwargs(executable: str) -> dict[str, Any]:
    return {}
