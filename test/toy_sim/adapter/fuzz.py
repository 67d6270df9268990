"""The toy simulator's fuzz targets: its start file (:mod:`toy_sim.toy_file`), and its world node
for the fuzzer's ``node_parameters`` target.

The contract (what this module defines) is in :mod:`sim_tools.fuzz.targets`.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml

from sim_tools.fuzz_kit import Case, Defect, check_finite, mutated_yaml

#: Executable → its world node class, as ``module:Class``.
WORLD_NODES = {"toy_world": "toy_sim.world_node:ToyWorldNode"}

_SEEDS = {
    "plain.yaml": "pose: [0.5, -0.25, 0.3]\nmax_speed: 0.5\nmax_turn: 2.0\n",
    "formula.yaml": "# a heading as a formula\npose: [-3, 2, 90*deg]\nmax_speed: 1.5\nmax_turn: pi\n",
}


def prepare_seeds(folder: Path) -> None:
    (folder / "starts").mkdir(parents=True, exist_ok=True)
    for name, text in _SEEDS.items():
        (folder / "starts" / name).write_text(text, encoding="utf-8")


def load_seeds(folder: Path) -> list[Any]:
    """The start files as parsed trees (the cases mutate the tree, then the text)."""
    return [yaml.safe_load(p.read_text(encoding="utf-8")) for p in sorted(folder.glob("starts/*.yaml"))]


def drive(rng: random.Random, path: Path) -> None:
    """Load a start file, put the robot there and drive it 5 steps within the file's limits."""
    from toy_sim.model import PointRobot
    from toy_sim.toy_file import load_start

    start = load_start(path)
    robot = PointRobot(start.pose)
    for _ in range(5):
        robot.command(rng.uniform(-start.max_speed, start.max_speed), rng.uniform(-start.max_turn, start.max_turn))
        robot.step(rng.choice((0.01, 0.1, 1.0)))
        check_finite(robot.pose, "toy pose")
        check_finite(robot.distance, "toy distance")
    if not -3.2 < robot.pose[2] < 3.2:
        raise Defect(f"toy heading {robot.pose[2]} is not wrapped")


def start_case(rng: random.Random, seeds: list[Any], folder: Path) -> Case:
    (folder / "start.yaml").write_text(mutated_yaml(rng, rng.choice(seeds)), encoding="utf-8")
    return Case(folder, lambda: drive(rng, folder / "start.yaml"))


TARGETS = {"toy_start": (10, start_case)}


def loaders(rng: random.Random) -> dict[str, Callable[[Path], object]]:
    return {"toy_start": lambda p: drive(rng, p)}


def warm_up(rng: random.Random, seeds: list[Any], folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "start.yaml").write_text(_SEEDS["plain.yaml"], encoding="utf-8")
    drive(rng, folder / "start.yaml")
