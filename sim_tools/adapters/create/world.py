"""The Create for batch, demo, warm-up and ``--help`` (the contract: :mod:`sim_tools.adapters.contract`).

A sweep's world entry: ``{map: FILE, config: FILE}`` (``config`` the noise file, ``""`` noise-free);
episodes may start at given or random poses. The probe records the pose, the bumpers and the
clearance to the nearest wall after every step.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sim_runtime.errors import InputError
from sim_tools.adapters.contract import EntryReader, EpisodeData, ExtraNodes, MakeController, Pose

LABEL = "Create"
WORLD_KEY = "map"
WORLD_OPTIONS = {"config": "a noise config"}
RESERVED = {
    "map_file": "the world's map",
    "config_file": "the world's config",
    "initial_pose": "the sweep's poses",
}
CONTROLLERS = {
    "create_bump_turn": "create_sim.bump_turn:BumpTurnNode",
    "policy_controller": "sim_tools.rl.policy_controller:PolicyControllerNode",
}
WORLD_NODE_NAME = "create_world"
NODE_EXECUTABLES = {
    "create_world": ("create_sim.world_node:CreateWorldNode", "[--ros-args -p NAME:=VALUE ...]"),
    "create_teleop": ("create_sim.teleop:TeleopNode", "[--ros-args -p NAME:=VALUE ...]  (in a terminal)"),
    "create_bump_turn": ("create_sim.bump_turn:BumpTurnNode", "[--ros-args -r __ns:=/ROBOT -p NAME:=VALUE ...]"),
    "policy_controller": (
        "sim_tools.rl.policy_controller:PolicyControllerNode",
        "--ros-args -p policy:=FILE.npz -p goal:=[X,Y] [-r __ns:=/ROBOT]",
    ),
}
ROBOT_NAMESPACES = False
MFILE_CONTROLLERS = True  # its toolbox's programs over the MATLAB bridge
#: Side of the floor squares counted by ``area_covered_m2`` (m).
COVERAGE_CELL_M = 0.05
#: A coverage cell (i, j) is the int64 key i·COVERAGE_KEY_SPAN + j: unique while |j| < 2^23 cells (400 km).
COVERAGE_KEY_SPAN = 1 << 24


# ---------------------------------------------------------------------------------- the world
def _load_map(path: str) -> Any:
    from create_sim.mapfile import load_map

    return load_map(path)


def _load_config(path: str) -> Any:
    from create_sim.configfile import load_config

    return load_config(path)


WORLD_FILES = {"map": _load_map, "config": _load_config}


def read_world(r: EntryReader, entry: dict[str, Any], where: str) -> dict[str, Any]:
    """The map and the noise config (``""``: noise-free), resolved."""
    return {"map": r.file(entry["map"], f"{where}.map"), "config": r.file(entry.get("config", ""), f"{where}.config")}


def make_world(world: dict[str, Any], pose: Pose | None, overrides: list[Any], **node_kwargs: Any) -> Any:
    """A ``create_world`` node on the entry's map and config, at ``pose`` if given."""
    from rclpy.parameter import Parameter

    from create_sim.world_node import CreateWorldNode

    overrides = [
        *overrides,
        Parameter("map_file", value=world["map"]),
        Parameter("config_file", value=world["config"]),
    ]
    if pose is not None:
        overrides.append(Parameter("initial_pose", value=[float(v) for v in pose]))
    return CreateWorldNode(parameter_overrides=overrides, **node_kwargs)


def random_poses(world: dict[str, Any], count: int, seed: int, margin_m: float) -> list[Pose]:
    """:func:`random_create_poses` on the entry's map."""
    return random_create_poses(world["map"], count, seed, margin_m)


def pose_problem(world: dict[str, Any], pose: Pose) -> str | None:
    """Why a sweep's start ``pose`` cannot be right on the entry's map: outside its walls'
    bounding box (the robot would drive in the void: ``ok`` rows of nothing), or the body
    overlapping a wall; None when it is fine (a map without walls takes any pose)."""
    from create_sim.geometry import nearest_distance
    from create_sim.mapfile import load_map
    from create_sim.model import CreateModel
    from create_sim.physics import OVERLAP_TOL

    walls = np.asarray(load_map(world["map"]).walls if world["map"] else np.zeros((0, 4)), dtype=np.float64)
    if not len(walls):
        return None
    x, y = float(pose[0]), float(pose[1])
    lo = np.minimum(walls[:, :2].min(axis=0), walls[:, 2:].min(axis=0))
    hi = np.maximum(walls[:, :2].max(axis=0), walls[:, 2:].max(axis=0))
    if not (lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1]):
        return f"outside the map (its walls span x {lo[0]:g}..{hi[0]:g} m, y {lo[1]:g}..{hi[1]:g} m)"
    gap = nearest_distance(walls, x, y) - CreateModel.RADIUS
    if gap < -OVERLAP_TOL:
        return f"the robot (a circle of radius {CreateModel.RADIUS} m) would be {-gap:.3g} m inside a wall"
    return None


def random_create_poses(map_file: str, count: int, seed: int, margin_m: float) -> list[Pose]:
    """``count`` poses drawn uniformly in the walls' bounding box, each at least ``margin_m`` clear
    of every wall (rejection sampling); the same seed gives the same poses on any machine."""
    from create_sim.geometry import nearest_distance
    from create_sim.mapfile import CreateMap, load_map
    from create_sim.model import CreateModel

    world = load_map(map_file) if map_file else CreateMap()
    walls = np.asarray(world.walls, dtype=np.float64).reshape(-1, 4)
    if len(walls):
        lo = np.minimum(walls[:, :2].min(axis=0), walls[:, 2:].min(axis=0))
        hi = np.maximum(walls[:, :2].max(axis=0), walls[:, 2:].max(axis=0))
    else:
        lo, hi = np.array([-2.0, -2.0]), np.array([2.0, 2.0])
    rng = np.random.default_rng(seed)
    poses: list[Pose] = []
    tries = 0
    while len(poses) < count:
        tries += 1
        if tries > 1000 * count:
            raise InputError(f"{map_file}: no room for a robot {margin_m} m clear of the walls")
        x, y = rng.uniform(lo, hi)
        theta = rng.uniform(-math.pi, math.pi)
        if not len(walls) or nearest_distance(walls, float(x), float(y)) - CreateModel.RADIUS >= margin_m:
            poses.append((float(x), float(y), float(theta)))
    return poses


# ---------------------------------------------------------------------------------- controllers
def controller_nodes(
    cls: type, world_node: Any, world: dict[str, Any], make: MakeController, **node_kwargs: Any
) -> list[Any]:
    """One controller node for the one robot."""
    return [make(cls)]


def probe_kwargs(cls: type) -> dict[str, str] | None:
    """Built as in an episode: nothing more to pass."""
    return {}


# ---------------------------------------------------------------------------------- the probe
class CreateProbe:
    """Pose, bumpers and wall clearance after every step: arrays ``x, y, theta`` (m, rad),
    ``bump`` (either bumper pressed), ``clearance`` (m from the body to the nearest wall); info
    ``radius_m``."""

    def __init__(self, world: Any, steps: int) -> None:
        self.world = world
        self.model = world.model
        self.rows = np.empty((steps + 1, 6))
        self.n = 0
        self.sample()

    def sample(self) -> None:
        m = self.model
        x, y, theta = m.pose
        left, right = m.bumps()
        self.rows[self.n] = (self.world.sim_time, x, y, theta, left or right, m.clearance())
        self.n += 1

    def data(self, params: dict[str, Any], seed: int) -> EpisodeData:
        r = self.rows[: self.n]
        arrays = {"x": r[:, 1], "y": r[:, 2], "theta": r[:, 3], "bump": r[:, 4] > 0, "clearance": r[:, 5]}
        return EpisodeData(r[:, 0], arrays, {"radius_m": self.model.RADIUS}, params, seed)


def probe(world_node: Any, world: dict[str, Any], steps: int) -> CreateProbe:
    return CreateProbe(world_node, steps)


# ---------------------------------------------------------------------------------- metrics
def create_distance_m(data: EpisodeData) -> float:
    """Path length of the body centre (m)."""
    x, y = data.arrays["x"], data.arrays["y"]
    return float(np.hypot(np.diff(x), np.diff(y)).sum())


def create_bumps(data: EpisodeData) -> int:
    """Bump events: steps at which a bumper became pressed."""
    bump = data.arrays["bump"].astype(np.int8)
    return int(np.count_nonzero(np.diff(bump, prepend=0) > 0))


def create_collisions(data: EpisodeData) -> int:
    """Collision events: steps at which a wall came to touch the body, from any side, bumper pressed
    or not (the bumpers cover only the front half: reversing into a wall is no bump). Touching is
    the model's contact state, ``CreateModel.touching``, from the clearance recorded every step."""
    from create_sim.model import CreateModel

    touching = (data.arrays["clearance"] <= CreateModel.CONTACT_M).astype(np.int8)
    return int(np.count_nonzero(np.diff(touching, prepend=0) > 0))


def create_min_clearance_m(data: EpisodeData) -> float:
    """Smallest gap between the body and a wall over the episode (m; 0 = touching)."""
    from create_sim.physics import _TOUCH

    if not len(data.t):
        return math.nan
    gap = float(data.arrays["clearance"].min())
    # the physics pushes a body that hit a wall out to 1e-8 m, and calls anything nearer than
    # _TOUCH touching: report that as 0, not as a 1e-8 the table and plots cannot tell from 0
    return 0.0 if gap < _TOUCH else gap


def create_area_covered_m2(data: EpisodeData, cell_m: float = COVERAGE_CELL_M) -> float:
    """Floor area the body passed over (m²), counted in ``cell_m`` squares whose centre it covered."""
    ij = np.floor(np.column_stack([data.arrays["x"], data.arrays["y"]]) / cell_m).astype(np.int64)
    keys = np.unique(ij[:, 0] * COVERAGE_KEY_SPAN + ij[:, 1])
    offsets = coverage_disc(float(data.info["radius_m"]), cell_m)
    covered = np.unique((keys[:, None] + offsets[None, :]).ravel())
    return float(len(covered) * cell_m * cell_m)


def coverage_disc(radius_m: float, cell_m: float = COVERAGE_CELL_M) -> np.ndarray:
    """The key offsets (see :data:`COVERAGE_KEY_SPAN`) of the cells a body of ``radius_m`` covers
    from a cell: those whose centre is within the radius of that cell's centre."""
    reach = int(math.ceil(radius_m / cell_m)) + 1
    di, dj = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1), indexing="ij")
    disc = (np.hypot(di, dj) * cell_m <= radius_m).ravel()
    return di.ravel()[disc] * COVERAGE_KEY_SPAN + dj.ravel()[disc]


def create_goal_time_s(data: EpisodeData, center: list[float], radius_m: float = 0.3) -> float:
    """Sim time at which the body centre first came within ``radius_m`` of ``center`` (NaN: never)."""
    inside = np.hypot(data.arrays["x"] - center[0], data.arrays["y"] - center[1]) <= radius_m
    hits = np.flatnonzero(inside)
    return float(data.t[hits[0]]) if len(hits) else math.nan


def create_final_pose(data: EpisodeData) -> dict[str, float]:
    """Where the robot ended: ``final_x``, ``final_y`` (m), ``final_theta`` (rad)."""
    return {f"final_{k}": float(data.arrays[k][-1]) for k in ("x", "y", "theta")} if len(data.t) else {}


METRICS: dict[str, Callable[..., Any]] = {
    "distance_m": create_distance_m,
    "bumps": create_bumps,
    "collisions": create_collisions,
    "min_clearance_m": create_min_clearance_m,
    "area_covered_m2": create_area_covered_m2,
    "goal_time_s": create_goal_time_s,
    "final_pose": create_final_pose,
}
#: What the type hints of the metrics' options cannot say: a test and what it expects.
METRIC_RULES = {
    ("goal_time_s", "center"): (lambda v: len(v) == 2, "[x, y] in metres"),
    ("goal_time_s", "radius_m"): (lambda v: v > 0, "a radius > 0 m"),
    ("area_covered_m2", "cell_m"): (lambda v: v > 0, "a cell side > 0 m"),
}


# ---------------------------------------------------------------------------------- demo, warm-up
def demo(out: Path, extra_nodes: ExtraNodes) -> dict[str, Any]:
    """Create world with the bump-and-turn controller for 60 sim seconds."""
    from create_sim.bump_turn import demo as bump_turn_demo

    return bump_turn_demo(60.0, extra_nodes=extra_nodes)


def sample_run(folder: Path) -> Path:
    """One second of a synthetic Create run, as a bag."""
    from create_sim.synthetic_run import write_create_run

    return write_create_run(folder / "run", 1.0)


def warm_up() -> None:
    """The model's step and every sensor, on the shipped example map and noise config; the walls'
    raster of the node's ``/map``."""
    from create_sim.configfile import load_config
    from create_sim.geometry import rasterise_walls
    from create_sim.mapfile import load_map
    from create_sim.model import CreateModel
    from sim_runtime.paths import config_path

    world = load_map(config_path("create/example.map"))
    CreateModel(world, load_config(config_path("create/example_config.txt"))).compile_kernels()
    rasterise_walls(world.walls, 0.05)


def describe_kwargs(executable: str) -> dict[str, Any]:
    return {}
