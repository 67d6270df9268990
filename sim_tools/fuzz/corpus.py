"""The simulators' fuzz parts (read with defaults for what a part leaves out) and the seed corpus."""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

from sim_tools.adapters import Simulator, simulators
from sim_tools.fuzz_kit import CaseMaker


@dataclass(frozen=True)
class FuzzPart:
    """One simulator's ``fuzz`` module, as the contract of :mod:`sim_tools.fuzz.targets` reads it."""

    name: str  # the simulator's registry name: its seeds are in the seed folder's sub-folder of that name
    module: ModuleType

    @property
    def targets(self) -> dict[str, tuple[float, CaseMaker]]:
        return dict(self.module.TARGETS)

    @property
    def world_nodes(self) -> dict[str, str]:
        return dict(getattr(self.module, "WORLD_NODES", {}))

    @property
    def required_args(self) -> dict[str, list[str]]:
        return dict(getattr(self.module, "REQUIRED_ARGS", {}))

    @property
    def file_parameters(self) -> tuple[tuple[str, str], ...]:
        return tuple(getattr(self.module, "FILE_PARAMETERS", ()))

    def prepare_seeds(self, folder: Path) -> None:
        self.module.prepare_seeds(folder)

    def load_seeds(self, folder: Path) -> Any:
        return self.module.load_seeds(folder)

    def loaders(self, rng: random.Random) -> dict[str, Callable[[Path], object]]:
        return self.module.loaders(rng) if hasattr(self.module, "loaders") else {}

    def field_cases(
        self, rng: random.Random, seeds: Any, folder: Path, special: Path
    ) -> dict[str, Callable[[], object]]:
        if not hasattr(self.module, "field_cases"):
            return {}
        return self.module.field_cases(rng, seeds, folder, special)

    def warm_up(self, rng: random.Random, seeds: Any, folder: Path) -> None:
        if hasattr(self.module, "warm_up"):
            self.module.warm_up(rng, seeds, folder)


def fuzz_parts() -> tuple[FuzzPart, ...]:
    """The fuzz part of every registered simulator that has one, in registry order."""
    return _parts(tuple(simulators().values()))


@cache
def _parts(registered: tuple[Simulator, ...]) -> tuple[FuzzPart, ...]:
    return tuple(FuzzPart(sim.name, sim.part("fuzz")) for sim in registered if sim.has_part("fuzz"))


def world_nodes() -> dict[str, str]:
    """Every simulator's world executables → their node class (``module:Class``)."""
    return {exe: node for part in fuzz_parts() for exe, node in part.world_nodes.items()}


@dataclass
class Seeds:
    """Seed inputs, read once per process from the seed folder: the bags, and each simulator's own
    (what its part's ``load_seeds`` returned, by simulator name)."""

    folder: Path
    bags: list[Path]
    simulators: dict[str, Any]

    @classmethod
    def load(cls, folder: Path) -> Seeds:
        return cls(
            folder=folder,
            bags=sorted(p for p in folder.glob("bags/*") if p.is_dir()),
            simulators={part.name: part.load_seeds(folder / part.name) for part in fuzz_parts()},
        )
