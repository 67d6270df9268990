"""The ``special_paths`` target: paths no loader may hang on, read forever, or crash with an
OSError over, handed to every simulator's loaders, fields and file parameters, and to the tools'."""

from __future__ import annotations

import contextlib
import os
import random
import shutil
from collections.abc import Callable
from pathlib import Path

import yaml

from sim_tools.adapters import simulators
from sim_tools.fuzz.bags import read_bag
from sim_tools.fuzz.corpus import Seeds, fuzz_parts
from sim_tools.fuzz.nodes import file_parameters, run_world_node
from sim_tools.fuzz_kit import Case
from sim_tools.fuzz_kit.mutate import dump_yaml

#: Paths no loader may hang on, read forever, or crash with an OSError over.
SPECIAL_PATHS = (
    "long_name",
    "long_path",
    "nul_name",
    "fifo",
    "directory",
    "dev_zero",
    "zero_link",
    "link_loop",
    "missing",
)


def special_path(kind: str, folder: Path, suffix: str = "") -> Path:
    """A path of ``kind`` (see :data:`SPECIAL_PATHS`) in ``folder``, made on disk where it is a file:
    a name longer than a file name may be, a path longer than a path may be, a name holding a NUL
    (a YAML field can: ``"\\0"``), a FIFO (opening it for reading waits for a writer), a directory,
    ``/dev/zero`` (endless) and a link to it, a link to itself, or nothing."""
    if kind == "long_name":
        return folder / ("n" * 300 + suffix)
    if kind == "long_path":
        return folder.joinpath(*["d" * 200] * 25, "f" + suffix)
    if kind == "dev_zero":
        return Path("/dev/zero")
    if kind == "nul_name":
        return folder / f"nul\0name{suffix}"
    path = folder / f"special_{kind}{suffix}"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    elif kind == "zero_link":
        path.symlink_to("/dev/zero")
    elif kind == "link_loop":
        path.symlink_to(path.name)
    return path


def _bag_with_special_split(rng: random.Random, seeds: Seeds, folder: Path, kind: str) -> Path:
    """A seed bag whose metadata.yaml lists a special split, or holding one named like a split."""
    bag = folder / "bag"
    shutil.copytree(rng.choice(seeds.bags), bag)
    special = special_path(kind, bag, ".mcap")
    meta = bag / "metadata.yaml"
    if rng.random() < 0.5 and meta.exists():
        tree = yaml.safe_load(meta.read_text(encoding="utf-8"))
        with contextlib.suppress(KeyError, TypeError):
            tree["rosbag2_bagfile_information"]["relative_file_paths"].append(os.path.relpath(special, bag))
        meta.write_text(yaml.safe_dump(tree), encoding="utf-8")
    return bag


def _field_cases(rng: random.Random, seeds: Seeds, folder: Path, special: Path) -> dict[str, Callable[[], object]]:
    """Files whose field names ``special``: each simulator's (a world's map, a robot config's mesh…),
    and a sweep's world file."""
    cases: dict[str, Callable[[], object]] = {}
    for part in fuzz_parts():
        cases.update(part.field_cases(rng, seeds.simulators[part.name], folder, special))
    world = next((sim.part("world") for sim in simulators().values() if sim.has_part("world")), None)
    if world is not None:  # a sweep of the first simulator's world and controller
        sweep = {"worlds": [{world.WORLD_KEY: str(special)}], "controllers": [next(iter(world.CONTROLLERS))]}
        (folder / "sweep.yaml").write_text(dump_yaml({**sweep, "duration_s": 1}), encoding="utf-8")
        cases[f"sweep_{world.WORLD_KEY}"] = lambda: _load_sweep(folder / "sweep.yaml")
    return cases


def _load_sweep(path: Path) -> None:
    from sim_tools.batch.sweep import load_sweep

    load_sweep(path, out=str(path.parent / "sweep_out"))


def _loaders(rng: random.Random) -> dict[str, Callable[[Path], object]]:
    """Each input file kind's loader, as a user's program (or a node) calls it."""
    loaders: dict[str, Callable[[Path], object]] = {}
    for part in fuzz_parts():
        loaders.update(part.loaders(rng))
    loaders.update({"bag": read_bag, "sweep": _load_sweep})
    return loaders


def special_path_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """A loader handed a special path (:data:`SPECIAL_PATHS`) directly, through a field of a file,
    as a bag's split, or as a world node's file parameter: it must refuse it with InputError, at once."""
    how = rng.choice(("direct", "direct", "field", "bag_split", "parameter"))
    # A command line cannot hold a NUL: rcl would see the name cut short.
    kind = rng.choice([k for k in SPECIAL_PATHS if how != "parameter" or k != "nul_name"])
    special = special_path(kind, folder, rng.choice(("", ".yaml", ".map", ".png", ".stl", ".mcap")))
    note = f"{kind} {how}"
    if how == "field":
        name, run = rng.choice(sorted(_field_cases(rng, seeds, folder, special).items()))
        return Case(folder, run, f"{note} {name}")
    if how == "bag_split":
        bag = _bag_with_special_split(rng, seeds, folder, kind)
        return Case(folder, lambda: read_bag(bag), note)
    if how == "parameter":
        exe, name = rng.choice(file_parameters())
        args = ["--ros-args", "-p", f"{name}:={special}"]
        return Case(folder, lambda: run_world_node(exe, args, steps=1), f"{note} {exe} {name}")
    name, load = rng.choice(sorted(_loaders(rng).items()))
    return Case(folder, lambda: load(special), f"{note} {name}")
