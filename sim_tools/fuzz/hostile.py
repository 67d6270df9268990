"""Targets of inputs made to hurt rather than mutated: alias bombs, odd line ends, huge legal files.

- ``alias_bombs``: a 10-level YAML alias bomb (10^10 values in ~400 bytes) at any key of any YAML
  input (a SIMROBOT world, an arm config or scene, a joint trajectory, a sweep, a bag's
  metadata.yaml), or at a key that is no field. Each YAML loader must refuse it with an
  InputError under 300 characters; the bag reader must read the bag from its splits.
- ``odd_text``: a seed text file (Create map and config, world, arm config, ASCII STL) with its
  lines ended by CR alone or CR LF, or after a UTF-8 byte-order mark: it must load exactly when
  the seed loads.
- ``huge_inputs``: a Create map of 50,000-150,000 walls read, indexed and rasterised as the world
  does at start-up; a map image up to 36,000,000 pixels read; one announcing far more pixels
  than the limit refused from its header.

The campaign's per-input budget (:mod:`sim_tools.fuzz.budget`) holds them to their cost: a bomb
refused after a minute, or a legal map taking gigabytes, is a defect.
"""

from __future__ import annotations

import random
import shutil
import struct
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sim_tools.fuzz.bags import read_bag
from sim_tools.fuzz.corpus import Seeds
from sim_tools.fuzz.special import _load_sweep, _loaders
from sim_tools.fuzz_kit import Case, Defect
from sim_tools.fuzz_kit.mutate import bombed_yaml, yaml_paths

#: Every message about an input is shorter than this (characters).
MESSAGE_CHARS = 300

#: Seed files of each input kind (a loader name of the parts' ``loaders``), under the seed folder.
SEED_FILES = {
    "world": "simrobot/worlds/*.yaml",
    "robot_config": "arm/*.yaml",
    "scene": "arm/scenes/*.yaml",
    "map": "create/maps/*.map",
    "config": "create/configs/*.txt",
    "stl": "arm/stl/*ascii*.stl",
}
YAML_KINDS = ("world", "robot_config", "scene")
#: Kinds whose seed trees are written here (no seed file of their own).
_TRAJECTORY = {"points": [{"time": 1.0, "positions": [0.0, 0.1, 0.2]}, {"time": 2.0, "positions": [0, 0, 0]}]}


def _sweep_tree() -> dict[str, Any]:
    from sim_tools.adapters import simulators

    world = next((sim.part("world") for sim in simulators().values() if sim.has_part("world")), None)
    if world is None:
        return {"worlds": [{"map": "x.map"}], "controllers": ["c"], "duration_s": 1}
    return {"worlds": [{world.WORLD_KEY: "w"}], "controllers": [next(iter(world.CONTROLLERS))], "duration_s": 1}


def _seed_files(seeds: Seeds, kind: str) -> list[Path]:
    return sorted(seeds.folder.glob(SEED_FILES[kind])) if kind in SEED_FILES else []


def _copy_seed(seed: Path, folder: Path) -> Path:
    """The seed's folder copied into the case folder (a world names its map relative to itself)."""
    target = folder / "in"
    shutil.copytree(seed.parent, target, dirs_exist_ok=True)
    return target / seed.name


def _short_enough(error: BaseException, what: str) -> None:
    if len(str(error)) >= MESSAGE_CHARS:
        raise Defect(f"{what}: a message of {len(str(error))} characters: {str(error)[:200]}")


def _must_refuse(
    load: Callable[[Path], object], path: Path, what: str, because: str, loaded: str
) -> Callable[[], None]:
    """The case's run: ``load(path)`` must raise an InputError (the case's outcome), a short one
    that says ``because``; loading, another reason first or a long message is a defect."""
    from sim_runtime.errors import InputError

    def run() -> None:
        try:
            load(path)
        except InputError as error:
            _short_enough(error, what)
            if because not in str(error):
                raise Defect(f"{what}: refused for another reason first: {str(error)[:200]}") from None
            raise
        raise Defect(f"{what}: {loaded}")

    return run


def alias_bomb_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """A YAML input with a 10-level alias bomb at one of its keys (or one that is no field)."""
    loaders = _loaders(rng)
    kinds = [k for k in YAML_KINDS if k in loaders and _seed_files(seeds, k)]
    kinds += [k for k in ("trajectory", "sweep") if k in loaders] + (["bag"] if seeds.bags else [])
    kind = rng.choice(kinds)
    if kind == "bag":
        bag = folder / "bag"
        shutil.copytree(rng.choice(seeds.bags), bag)
        meta = bag / "metadata.yaml"
        tree = yaml.safe_load(meta.read_text(encoding="utf-8")) if meta.exists() else {}
        path = rng.choice([*yaml_paths(tree), ("extra",)])
        meta.write_text(bombed_yaml(tree, path), encoding="utf-8")
        return Case(folder, lambda: read_bag(bag), f"bag metadata {path}")
    if kind in YAML_KINDS:
        seed = rng.choice(_seed_files(seeds, kind))
        file = _copy_seed(seed, folder)
        tree = yaml.safe_load(seed.read_text(encoding="utf-8"))
    else:
        file = folder / f"{kind}.yaml"
        tree = _TRAJECTORY if kind == "trajectory" else _sweep_tree()
    path = rng.choice([*yaml_paths(tree), ("not_a_field",)])
    file.write_text(bombed_yaml(tree, path), encoding="utf-8")
    load = _load_sweep if kind == "sweep" else loaders[kind]
    run = _must_refuse(load, file, f"{kind} bomb at {path}", "alias", "an alias bomb loaded")
    return Case(folder, run, f"{kind} {path}")


_VARIANTS: dict[str, Callable[[bytes], bytes]] = {
    "cr": lambda b: b.replace(b"\r\n", b"\n").replace(b"\n", b"\r"),
    "crlf": lambda b: b.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n"),
    "bom": lambda b: b"\xef\xbb\xbf" + b,
    "bom_cr": lambda b: b"\xef\xbb\xbf" + b.replace(b"\r\n", b"\n").replace(b"\n", b"\r"),
}


def odd_text_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """A seed text file with CR-only or CR LF line ends, or a byte-order mark: it loads as the seed does."""
    from sim_runtime.errors import InputError

    state = rng.random()  # both loads draw the same choices (meshes or not) from equal generators
    loaders = _loaders(random.Random(state))
    kind = rng.choice([k for k in SEED_FILES if k in loaders and _seed_files(seeds, k)])
    seed = rng.choice(_seed_files(seeds, kind))
    variant = rng.choice(sorted(_VARIANTS))
    original = _copy_seed(seed, folder)
    odd = original.with_name(f"odd_{variant}{seed.suffix}")
    odd.write_bytes(_VARIANTS[variant](seed.read_bytes()))

    def run() -> None:
        try:
            loaders[kind](original)
            seed_loads = True
        except InputError:
            seed_loads = False
        try:
            _loaders(random.Random(state))[kind](odd)
        except InputError as error:
            _short_enough(error, f"{kind} {variant}")
            if seed_loads:
                why = str(error)[:200]
                raise Defect(f"{kind} with {variant} line ends/mark refused, the seed loads: {why}") from None
            raise

    return Case(folder, run, f"{kind} {variant} {seed.name}")


def _png_header(width: int, height: int) -> bytes:
    """A 1-bit PNG announcing ``width`` x ``height`` pixels, with a few bytes of data."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    header = chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0))
    return b"\x89PNG\r\n\x1a\n" + header + chunk(b"IDAT", zlib.compress(b"\0" * 16)) + chunk(b"IEND", b"")


def _huge_map(rng: random.Random, folder: Path) -> Callable[[], None]:
    from create_sim.geometry import SegmentGrid, rasterise_walls
    from create_sim.mapfile import load_map

    walls = rng.randrange(50_000, 150_001)
    np_rng = np.random.default_rng(rng.randrange(2**32))
    start = np_rng.uniform(-rng.choice((10.0, 100.0, 1000.0)), 100.0, (walls, 2))
    rows = np.hstack([start, start + np_rng.normal(0.0, rng.choice((0.1, 0.5, 2.0)), (walls, 2))])
    path = folder / "huge.map"
    with path.open("w") as f:
        np.savetxt(f, rows, fmt="wall %.4f %.4f %.4f %.4f")

    def run() -> None:  # what create_world does with it at start-up
        create_map = load_map(path)
        SegmentGrid.build(create_map.walls)
        raster = rasterise_walls(create_map.walls, 0.05)
        if not raster.occupied.any():
            raise Defect("a map of walls rasterised to an empty grid")

    return run


def _big_bitmap(rng: random.Random, folder: Path) -> Callable[[], None]:
    from PIL import Image, ImageDraw

    from simrobot_sim.world_file import load_bitmap

    width, height = rng.choice(((2000, 2000), (6000, 6000), (8000, 4500), (36_000, 1000)))
    image = Image.new("1", (width, height), 1)
    draw = ImageDraw.Draw(image)
    for _ in range(20):
        x, y = rng.randrange(width), rng.randrange(height)
        draw.rectangle((x, y, x + rng.randrange(1, 200), y + rng.randrange(1, 200)), fill=0)
    path = folder / "big.png"
    image.save(path)

    def run() -> None:
        walls = load_bitmap(path)
        if walls.shape != (width, height) or not walls.any():
            raise Defect(f"a {width} x {height} map read as {walls.shape}")

    return run


def _beyond_limit_bitmap(rng: random.Random, folder: Path) -> Callable[[], None]:
    from simrobot_sim.world_file import load_bitmap

    side = rng.choice((8001, 13_000, 30_000, 100_000, 2**31 - 1))
    path = folder / "announced.png"
    path.write_bytes(_png_header(side, side))
    return _must_refuse(load_bitmap, path, f"a {side}² image", "limit", "it was read")


def huge_input_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """A huge but legal Create map or map image (read within the budget), or one beyond the limit."""
    how = rng.choice(("create_map", "bitmap", "beyond_limit", "beyond_limit"))
    make = {"create_map": _huge_map, "bitmap": _big_bitmap, "beyond_limit": _beyond_limit_bitmap}[how]
    return Case(folder, make(rng, folder), how)


__all__ = ["alias_bomb_case", "huge_input_case", "odd_text_case"]
