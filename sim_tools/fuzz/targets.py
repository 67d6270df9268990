"""What the fuzzer feeds and how each input is judged; the contract of a simulator's ``fuzz`` part.

Each target makes one input from seeds (files written into a case folder, so a defect can be
saved and replayed) and runs it the way a user's program would: load the file(s); if that
succeeds, build the model and step it a few times with random commands, requiring finite
state. Loading may also fail, but only with :class:`~sim_runtime.errors.InputError`.

The target table is every registered simulator's targets (:func:`sim_tools.adapters.simulators`,
in registry order), then the tools' own: the bag readers, ``replay``, the world nodes' parameters
and the special paths (:mod:`sim_tools.fuzz.bags`, :mod:`~sim_tools.fuzz.nodes`,
:mod:`~sim_tools.fuzz.special`). A target's weight is its share of the inputs.

**A simulator's fuzz part** (the module ``<adapter>.fuzz``) builds on :mod:`sim_tools.fuzz_kit`
(``Case``, ``Defect``, ``check_finite``, the mutations) and defines:

- ``TARGETS: dict[str, tuple[float, CaseMaker]]`` — target name (unique over all simulators; it
  names the row of the summary) → (weight, ``make(rng, seeds, folder) -> Case``). ``make`` writes
  the input's files into ``folder`` using only ``rng`` (input *i* of seed *s* must be the same
  input every time) and returns how to run it;
- ``prepare_seeds(folder: Path) -> None`` — write the seed files into ``folder``, the simulator's
  own sub-folder of the campaign's seed folder (``<out>/seeds/<name>``);
- ``load_seeds(folder: Path) -> object`` — read them back, once per worker; what it returns is
  the ``seeds`` handed to the part's case makers and to the functions below.

and may define:

- ``warm_up(rng, seeds, folder) -> None`` — import and compile (numba) what its targets run, on
  the unmutated seeds, before the hang clock runs; ``folder`` is scratch space;
- ``loaders(rng) -> dict[str, Callable[[Path], object]]`` — each of its input file kinds' loader,
  for the special paths handed to it directly;
- ``field_cases(rng, seeds, folder, special) -> dict[str, Callable[[], object]]`` — files written
  into ``folder`` whose path field names ``special``, each with how to load it;
- ``WORLD_NODES: dict[str, str]`` — world executable → its node class as ``module:Class``, built
  with ``cli_args`` and stepped by ``node_parameters`` (it needs ``step(n)``, ``sim_time``, and a
  finite ``model.pose`` if it has one);
- ``REQUIRED_ARGS: dict[str, list[str]]`` — ROS arguments a world cannot start without;
- ``FILE_PARAMETERS: tuple[tuple[str, str], ...]`` — (world executable, file parameter) pairs the
  special paths are given to.
"""

from __future__ import annotations

import os
import random
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from sim_tools.fuzz.bags import (
    bag_reader_case,
    bag_to_rerun_case,
    draw_tracks_case,
    read_bag,
    replay_case,
    write_seed_bags,
)
from sim_tools.fuzz.corpus import Seeds, fuzz_parts
from sim_tools.fuzz.hostile import alias_bomb_case, huge_input_case, odd_text_case
from sim_tools.fuzz.nodes import node_parameters_case
from sim_tools.fuzz.selftest import selftest_case
from sim_tools.fuzz.special import SPECIAL_PATHS, special_path, special_path_case
from sim_tools.fuzz_kit import Case, CaseMaker, Defect

#: The tools' own targets, after the simulators': name → (weight, case maker taking :class:`Seeds`).
TOOL_TARGETS: dict[str, tuple[float, Callable[[random.Random, Seeds, Path], Case]]] = {
    "bag_reader": (10, bag_reader_case),
    "draw_tracks": (8, draw_tracks_case),
    "bag_to_rerun": (6, bag_to_rerun_case),
    "replay": (4, replay_case),
    "node_parameters": (4, node_parameters_case),
    "special_paths": (4, special_path_case),
    "alias_bombs": (3, alias_bomb_case),
    "odd_text": (2, odd_text_case),
    "huge_inputs": (0.15, huge_input_case),
}


@dataclass(frozen=True)
class Target:
    """One row of the target table: its weight, its case maker and whose seeds it draws from."""

    weight: float
    make: CaseMaker
    simulator: str | None = None  # None: a tool's target, handed the whole :class:`Seeds`

    def case(self, rng: random.Random, seeds: Seeds, folder: Path) -> Case:
        return self.make(rng, seeds if self.simulator is None else seeds.simulators[self.simulator], folder)


def _selftest() -> bool:
    """The harness's own test (its workers inherit the variable): one target, of the harness."""
    return bool(os.environ.get("ROBOT_SIMS_FUZZ_SELFTEST"))


def target_table() -> dict[str, Target]:
    """Target name → :class:`Target`: every simulator's fuzz part's, then the tools'."""
    if _selftest():
        return {"selftest": Target(1.0, selftest_case)}
    return _table(fuzz_parts())


@cache
def _table(parts: tuple[Any, ...]) -> dict[str, Target]:
    table: dict[str, Target] = {}
    for part in parts:
        for name, (weight, make) in part.targets.items():
            if name in table or name in TOOL_TARGETS:
                raise ValueError(f"fuzz target '{name}' of simulator '{part.name}' is already taken")
            table[name] = Target(weight, make, part.name)
    table.update({name: Target(weight, make) for name, (weight, make) in TOOL_TARGETS.items()})
    return table


def prepare_seeds(folder: Path) -> None:
    """Write the seed corpus: each simulator's in a sub-folder of its name, and the bags."""
    folder.mkdir(parents=True, exist_ok=True)
    for part in fuzz_parts():
        part.prepare_seeds(folder / part.name)
    write_seed_bags(folder / "bags")


def target_of(index: int, seed: int) -> str:
    """Which target input ``index`` of a campaign exercises (deterministic)."""
    rng = random.Random(f"{seed}/{index}/target")
    table = target_table()
    names = list(table)
    return rng.choices(names, weights=[table[n].weight for n in names])[0]


def make_case(index: int, seed: int, seeds: Seeds, folder: Path) -> tuple[str, Case]:
    """The input ``index`` of a campaign, written into ``folder`` (same index, same input)."""
    name = target_of(index, seed)
    rng = random.Random(f"{seed}/{index}")
    folder.mkdir(parents=True, exist_ok=True)
    return name, target_table()[name].case(rng, seeds, folder)


def warm_up(seeds: Seeds, folder: Path) -> None:
    """Import and compile (numba) everything once on the unmutated seeds, before the hang clock runs."""
    if _selftest():
        return
    rng = random.Random(0)
    for part in fuzz_parts():
        part.warm_up(rng, seeds.simulators[part.name], folder / part.name)
    read_bag(seeds.bags[0])
    shutil.rmtree(folder, ignore_errors=True)


def harness_files() -> set[str]:
    """The fuzz parts' source files: like this package's, not where a defect is."""
    return {str(part.module.__file__) for part in fuzz_parts()}


__all__ = [
    "SPECIAL_PATHS",
    "Case",
    "Defect",
    "Seeds",
    "Target",
    "harness_files",
    "make_case",
    "prepare_seeds",
    "special_path",
    "target_of",
    "target_table",
    "warm_up",
]
