"""The Create's fuzz targets: its map and noise-config files, and its world node's file parameters.

The contract (what this module defines) is in :mod:`sim_tools.fuzz.targets`.
"""

from __future__ import annotations

import random
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from create_sim import spec
from sim_runtime.paths import config_path
from sim_tools.adapters.create.world import NODE_EXECUTABLES
from sim_tools.fuzz_kit import Case, Defect, check_finite, mutated_text

#: Executable → its world node class, as ``module:Class``.
WORLD_NODES = {"create_world": NODE_EXECUTABLES["create_world"][0]}
#: (world executable, a file parameter of it).
FILE_PARAMETERS = (("create_world", "map_file"), ("create_world", "config_file"))


@dataclass
class CreateSeeds:
    maps: list[str]
    configs: list[str]


def prepare_seeds(folder: Path) -> None:
    """The shipped example map and configs, and a map with a free wall end, a line, a beacon and a
    virtual wall."""
    for sub in ("maps", "configs"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    shutil.copy(config_path("create/example.map"), folder / "maps/example.map")
    (folder / "maps/corner.map").write_text(
        "% a free wall end, a line, a beacon, a virtual wall\n"
        "wall 2.45 0.55 2.45 2.0\nwall -1 -1 3 -1\nline 0 0.3 2 0.3\nbeacon 1 1 [1 0 0] b1\nvirtwall 0 1 0 2\n"
    )
    for name in ("example_config.txt", "ideal_config.txt"):
        shutil.copy(config_path(f"create/{name}"), folder / f"configs/{name}")


def load_seeds(folder: Path) -> CreateSeeds:
    def texts(pattern: str) -> list[str]:
        return [p.read_text(encoding="utf-8") for p in sorted(folder.glob(pattern))]

    return CreateSeeds(maps=texts("maps/*"), configs=texts("configs/*"))


def drive(rng: random.Random, map_path: Path, config_file: Path | None) -> None:
    """Load a map (and a noise config), place a Create where it fits and drive it 5 steps."""
    from create_sim.configfile import load_config
    from create_sim.mapfile import load_map

    world = load_map(map_path)
    noise = load_config(config_file) if config_file is not None else None
    robot = _place(rng, world, noise)
    if robot is None:
        return
    for _ in range(5):
        robot.set_velocity(rng.uniform(-1.0, 1.0), rng.uniform(-5.0, 5.0))
        robot.step(rng.choice((0.01, 0.1, 1.0)))
        _check_state(robot)


def _place(rng: random.Random, world, noise):
    """A Create at the first of a few poses not inside a wall (None if every one is)."""
    from create_sim.model import CreateModel
    from sim_runtime.errors import InputError

    for pose in ((0.0, 0.0, 0.0), (1.0, 0.5, 1.0), (-5.0, 7.0, -2.0), (100.0, 100.0, 0.0)):
        try:
            return CreateModel(world, noise, np.random.default_rng(rng.randrange(2**32)), pose=pose)
        except InputError as exc:
            if "inside a wall" not in str(exc):
                raise
    return None


def _check_state(robot) -> None:
    check_finite(robot.pose, "Create pose")
    check_finite(robot.odometry_pose, "Create odometry")
    scan = robot.lidar()
    if np.isnan(scan).any() or scan.shape != (spec.LIDAR_BEAMS,):
        raise Defect(f"LIDAR scan has NaN or shape {scan.shape}")
    if np.isnan(robot.sonar()).any() or np.isnan(robot.cliff_signals()).any():
        raise Defect("sonar or cliff reading is NaN")
    robot.bumps(), robot.wall_sensor(), robot.virtual_wall()
    for sighting in robot.camera():
        check_finite([sighting.distance, sighting.angle], "camera sighting")
    if robot.clearance() < -1e-9:
        raise Defect(f"robot inside a wall at {robot.pose}")


def map_case(rng: random.Random, seeds: CreateSeeds, folder: Path) -> Case:
    (folder / "case.map").write_text(mutated_text(rng, seeds.maps), encoding="utf-8")
    config = folder / "case_config.txt"
    config.write_text(rng.choice(seeds.configs), encoding="utf-8")
    return Case(folder, lambda: drive(rng, folder / "case.map", config))


def config_case(rng: random.Random, seeds: CreateSeeds, folder: Path) -> Case:
    (folder / "case.map").write_text(rng.choice(seeds.maps), encoding="utf-8")
    (folder / "case_config.txt").write_text(mutated_text(rng, seeds.configs), encoding="utf-8")
    return Case(folder, lambda: drive(rng, folder / "case.map", folder / "case_config.txt"))


TARGETS = {"create_map": (16, map_case), "create_config": (6, config_case)}


def loaders(rng: random.Random) -> dict[str, Callable[[Path], object]]:
    from create_sim.configfile import load_config
    from create_sim.mapfile import load_map

    return {"map": load_map, "config": load_config}


def warm_up(rng: random.Random, seeds: CreateSeeds, folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "w.map").write_text(seeds.maps[0], encoding="utf-8")
    (folder / "w.txt").write_text(seeds.configs[0], encoding="utf-8")
    drive(rng, folder / "w.map", folder / "w.txt")
