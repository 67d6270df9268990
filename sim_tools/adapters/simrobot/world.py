"""SIMROBOT for batch, demo, warm-up and ``--help`` (the contract: :mod:`sim_tools.adapters.contract`).

A sweep's world entry: ``{world_file: FILE}``; the robots start where the world file puts them. A
controller class runs once per robot that has an ultrasonic sensor, in the robot's namespace. The
probe records every robot's position and crash flag after every step.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from sim_tools.adapters.contract import EntryReader, EpisodeData, ExtraNodes, MakeController, Pose

LABEL = "SIMROBOT"
WORLD_KEY = "world_file"
WORLD_OPTIONS: dict[str, str] = {}
RESERVED = {"world_file": "the world's world_file"}
CONTROLLERS = {"simrobot_avoid": "simrobot_sim.avoid:AvoidNode"}
WORLD_NODE_NAME = "simrobot_world"
NODE_EXECUTABLES = {
    "simrobot_world": ("simrobot_sim.world_node:SimrobotWorldNode", "--ros-args -p world_file:=WORLD.yaml [-p ...]"),
    "simrobot_avoid": ("simrobot_sim.avoid:AvoidNode", "--ros-args -r __ns:=/ROBOT [-p NAME:=VALUE ...]"),
}
ROBOT_NAMESPACES = True
MFILE_CONTROLLERS = False
random_poses = None


# ---------------------------------------------------------------------------------- the world
def _load_world(path: str) -> Any:
    from simrobot_sim.world_file import load_world

    return load_world(path)


WORLD_FILES = {"world_file": _load_world}
#: World files parsed in this process (a worker parses a bitmap once, not per episode).
_specs: dict[str, Any] = {}


def read_world(r: EntryReader, entry: dict[str, Any], where: str) -> dict[str, Any]:
    """The world file, resolved."""
    return {"world_file": r.file(entry["world_file"], f"{where}.world_file")}


def make_world(world: dict[str, Any], pose: Pose | None, overrides: list[Any], **node_kwargs: Any) -> Any:
    """A ``simrobot_world`` node on the entry's world file (its robots where the file puts them)."""
    from simrobot_sim.world_node import SimrobotWorldNode

    path = world["world_file"]
    if path not in _specs:
        _specs[path] = _load_world(path)
    return SimrobotWorldNode(_specs[path], parameter_overrides=overrides, **node_kwargs)


# ---------------------------------------------------------------------------------- controllers
def controller_nodes(
    cls: type, world_node: Any, world: dict[str, Any], make: MakeController, **node_kwargs: Any
) -> list[Any]:
    """One node per robot with an ultrasonic sensor, namespaced ``/<robot>``, told its sensor."""
    robots = [
        (r.name, next((s.name for s in r.sensors if s.kind == "ultrasonic"), None)) for r in world_node.spec.robots
    ]
    return [make(cls, namespace=f"/{name}", sensor=sonar) for name, sonar in robots if sonar is not None]


def probe_kwargs(cls: type) -> dict[str, str] | None:
    """A stand-in robot and sensor: the parameters do not depend on them."""
    return {"namespace": "/probe", "sensor": "sonar"}


# ---------------------------------------------------------------------------------- the probe
class SimrobotProbe:
    """Every robot's position and crash flag after every step: arrays ``x, y`` (steps × robots,
    m), ``crashed`` (steps × robots); info ``names`` (the robots'), ``dt`` (s)."""

    def __init__(self, world: Any, steps: int) -> None:
        self.world = world
        n = len(world.model.names)
        self.t = np.empty(steps + 1)
        self.xy = np.empty((steps + 1, n, 2))
        self.crashed = np.empty((steps + 1, n), dtype=bool)
        self.n = 0
        self.sample()

    def sample(self) -> None:
        model = self.world.model
        self.t[self.n] = self.world.sim_time
        self.xy[self.n] = model.poses()[:, :2]
        self.crashed[self.n] = model.crashed
        self.n += 1

    def data(self, params: dict[str, Any], seed: int) -> EpisodeData:
        k = self.n
        arrays = {"x": self.xy[:k, :, 0], "y": self.xy[:k, :, 1], "crashed": self.crashed[:k]}
        info = {"names": list(self.world.model.names), "dt": self.world.physics_dt}
        return EpisodeData(self.t[:k], arrays, info, params, seed)


def probe(world_node: Any, world: dict[str, Any], steps: int) -> SimrobotProbe:
    return SimrobotProbe(world_node, steps)


# ---------------------------------------------------------------------------------- metrics
def simrobot_distance_m(data: EpisodeData) -> dict[str, float]:
    """Path length per robot (``distance_m.<robot>``) and their sum (``distance_m``), m."""
    per = np.hypot(np.diff(data.arrays["x"], axis=0), np.diff(data.arrays["y"], axis=0)).sum(axis=0)
    out = {f"distance_m.{name}": float(d) for name, d in zip(data.info["names"], per, strict=True)}
    return {"distance_m": float(per.sum()), **out}


def simrobot_crashes(data: EpisodeData) -> dict[str, float]:
    """Robots crashed at the end (``crashes``) and per robot 0/1 (``crashed.<robot>``)."""
    final = data.arrays["crashed"][-1] if len(data.t) else np.zeros(len(data.info["names"]), dtype=bool)
    out = {f"crashed.{name}": int(c) for name, c in zip(data.info["names"], final, strict=True)}
    return {"crashes": int(final.sum()), **out}


def simrobot_steps_survived(data: EpisodeData) -> dict[str, float]:
    """Steps each robot ran, the one it crashed in included (all steps if it never crashed), and
    their mean."""
    crashed = data.arrays["crashed"]  # row k: after step k (row 0: the start)
    steps = len(data.t) - 1
    first = np.where(crashed.any(axis=0), crashed.argmax(axis=0), steps)
    out = {f"steps_survived.{name}": int(s) for name, s in zip(data.info["names"], first, strict=True)}
    return {"steps_survived": float(first.mean()), **out}


METRICS = {
    "distance_m": simrobot_distance_m,
    "crashes": simrobot_crashes,
    "steps_survived": simrobot_steps_survived,
}
METRIC_RULES: dict[tuple[str, str], Any] = {}


# ---------------------------------------------------------------------------------- demo, warm-up
def demo(out: Path, extra_nodes: ExtraNodes) -> dict[str, Any]:
    """The original SIMROBOT demo's four robots and one that crashes, 300 lockstep steps, tracks PNG."""
    from simrobot_sim.demo import run_demo

    summary = run_demo(out, extra_nodes=extra_nodes)
    print(f"simrobot demo: {summary}")
    return summary


sample_run = None

_SENSOR = "{{name: {0}, type: {1}, position: [0.05, 0], axis: 0, beamwidth: 60, range: 0.5, rays: 30}}"
_ROBOT = "  - name: r{0}\n    position: [{1}, 1.55]\n    sensors:\n      - {2}\n      - {3}\n"


def warm_up() -> None:
    """A two-robot world with both sensor types, under both sensor models; a world with enough
    sensors to sense on two threads."""
    from sim_runtime.paths import config_path
    from simrobot_sim.model import PARALLEL_MIN_SENSORS, SimrobotWorld
    from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec, load_world

    robots = "".join(
        _ROBOT.format(i, x, _SENSOR.format("us", "ultrasonic"), _SENSOR.format("lz", "laser"))
        for i, x in ((1, 1.3), (2, 1.8))
    )
    for model in ("exact", "original"):
        world_text = (
            f"map: {config_path('simrobot/demo_map.png')}\nresolution: 0.01\ndt: 1.0\n"
            f"sensor_model: {model}\nrobots:\n{robots}"
        )
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "warmup.yaml"
            path.write_text(world_text)
            SimrobotWorld(load_world(path)).compile_kernels()
    side = 8  # robots a row, 0.3 m apart
    sonar = SensorSpec("s", "ultrasonic", beamwidth=0.5, range=0.2, rays=5)
    swarm = tuple(
        RobotSpec(f"r{i}", (0.3 + 0.3 * (i % side), 0.3 + 0.3 * (i // side)), sensors=(sonar,))
        for i in range(PARALLEL_MIN_SENSORS)
    )
    walls = np.zeros((30 * side + 60, 30 * (PARALLEL_MIN_SENSORS // side) + 60), dtype=bool)
    SimrobotWorld(WorldSpec(walls=walls, robots=swarm), threads=2).compile_kernels()


def describe_kwargs(executable: str) -> dict[str, Any]:
    """simrobot_world reads its world file before it declares anything: a one-robot world stands in."""
    if executable != "simrobot_world":
        return {}
    from simrobot_sim.world_file import RobotSpec, WorldSpec

    spec = WorldSpec(walls=np.zeros((10, 10), dtype=bool), robots=(RobotSpec("r", (0.05, 0.05)),), source="")
    return {"spec": spec}
