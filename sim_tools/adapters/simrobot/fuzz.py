"""SIMROBOT's fuzz targets: its world files and their bitmaps, and its world node's file parameter.

The contract (what this module defines) is in :mod:`sim_tools.fuzz.targets`.
"""

from __future__ import annotations

import random
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sim_runtime.paths import config_path
from sim_tools.adapters.simrobot.world import NODE_EXECUTABLES
from sim_tools.fuzz_kit import Case, check_finite, mutated_yaml
from sim_tools.fuzz_kit.mutate import dump_yaml, mutate_bytes

#: Executable → its world node class, as ``module:Class``.
WORLD_NODES = {"simrobot_world": NODE_EXECUTABLES["simrobot_world"][0]}
#: What a world cannot start without (the fuzzed ``-p`` values come after, so may replace it).
REQUIRED_ARGS = {"simrobot_world": ["-p", f"world_file:={config_path('simrobot/demo.yaml')}"]}
#: (world executable, a file parameter of it).
FILE_PARAMETERS = (("simrobot_world", "world_file"),)


@dataclass
class SimrobotSeeds:
    folder: Path
    worlds: list[Any]  # parsed YAML trees
    images: list[Path]


def prepare_seeds(folder: Path) -> None:
    """The shipped demo world and bitmap, a small two-robot world, and a small map in every bitmap
    mode the loader accepts."""
    from PIL import Image

    for sub in ("worlds", "images"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    shutil.copy(config_path("simrobot/demo.yaml"), folder / "worlds/demo.yaml")
    shutil.copy(config_path("simrobot/demo_map.png"), folder / "images/demo_map.png")
    (folder / "worlds/small.yaml").write_text(
        "map: small.png\nresolution: 0.01\ndt: 1.0\nsteps_limit: 20\nrobots:\n"
        "  - {name: a, position: [0.2, 0.2], heading: 45, controller: avoid, sensors: "
        "[{name: s, type: laser, range: 0.3, resolution: 5}]}\n"
        "  - {name: b, position: [0.45, 0.45], R: 0.02, la: 0.04, lb: 0.01, scale: 0.5}\n"
    )
    rng = np.random.default_rng(0)
    pixels = np.full((64, 64), 255, np.uint8)  # small.png beside small.yaml is written below
    pixels[0, :] = pixels[-1, :] = pixels[:, 0] = pixels[:, -1] = 0
    pixels[rng.integers(0, 64, 40), rng.integers(0, 64, 40)] = 0
    img = Image.fromarray(pixels)
    img.convert("1").save(folder / "images/small_1bit.bmp")
    img.save(folder / "images/small_grey.png")
    img.save(folder / "worlds/small.png")
    img.convert("P").save(folder / "images/small_palette.png")
    img.convert("RGB").save(folder / "images/small_rgb.bmp")
    Image.fromarray(pixels.astype(np.uint16) * 257).save(folder / "images/small_16bit.png")


def load_seeds(folder: Path) -> SimrobotSeeds:
    worlds = [yaml.safe_load(p.read_text(encoding="utf-8")) for p in sorted(folder.glob("worlds/*.yaml"))]
    return SimrobotSeeds(folder=folder, worlds=worlds, images=sorted(folder.glob("images/*")))


def drive(rng: random.Random, world_path: Path) -> None:
    """Load a world file, build the world and step it 3 times with random commands."""
    from simrobot_sim.model import SimrobotWorld
    from simrobot_sim.world_file import load_world

    world = SimrobotWorld(load_world(world_path))
    for _ in range(3):
        for i in range(len(world.names)):
            world.set_cmd_vel(i, rng.uniform(-0.2, 0.2), rng.uniform(-2.0, 2.0))
        world.step()
        world.sense()
        check_finite(world.poses(), "SIMROBOT poses")


def world_case(rng: random.Random, seeds: SimrobotSeeds, folder: Path) -> Case:
    image = rng.choice(seeds.images)
    tree = rng.choice(seeds.worlds)
    tree = dict(tree) if isinstance(tree, dict) else tree
    if isinstance(tree, dict) and image.name != "demo_map.png":
        tree["map"] = "case_map" + image.suffix
    shutil.copy(image, folder / ("case_map" + image.suffix))
    shutil.copy(seeds.folder / "images/demo_map.png", folder / "demo_map.png")
    shutil.copy(seeds.folder / "images/small_grey.png", folder / "small.png")
    (folder / "case.yaml").write_text(mutated_yaml(rng, tree), encoding="utf-8")
    return Case(folder, lambda: drive(rng, folder / "case.yaml"))


def bitmap_case(rng: random.Random, seeds: SimrobotSeeds, folder: Path) -> Case:
    image = rng.choice([p for p in seeds.images if p.name != "demo_map.png"] or seeds.images)
    name = "case_map" + (image.suffix if rng.random() < 0.9 else rng.choice((".png", ".bmp", ".jpg", "")))
    (folder / name).write_bytes(mutate_bytes(rng, image.read_bytes()))
    (folder / "case.yaml").write_text(
        f"map: {name}\nresolution: 0.01\nrobots:\n  - {{name: a, position: [0.2, 0.2], "
        "sensors: [{name: s, type: laser, range: 0.2, resolution: 4}]}\n",
        encoding="utf-8",
    )
    return Case(folder, lambda: drive(rng, folder / "case.yaml"))


TARGETS = {"simrobot_world": (10, world_case), "simrobot_bitmap": (8, bitmap_case)}


def loaders(rng: random.Random) -> dict[str, Callable[[Path], object]]:
    from simrobot_sim.world_file import load_bitmap

    return {"world": lambda p: drive(rng, p), "bitmap": load_bitmap}


def field_cases(
    rng: random.Random, seeds: SimrobotSeeds, folder: Path, special: Path
) -> dict[str, Callable[[], object]]:
    """A world file whose ``map`` names ``special``."""
    world = dict(rng.choice(seeds.worlds), map=str(special))
    (folder / "world.yaml").write_text(dump_yaml(world), encoding="utf-8")
    return {"world_map": lambda: drive(rng, folder / "world.yaml")}


def warm_up(rng: random.Random, seeds: SimrobotSeeds, folder: Path) -> None:
    drive(rng, seeds.folder / "worlds/small.yaml")
