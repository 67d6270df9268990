"""What a fuzz target is made of: an input case, the defect it may show, and mutated text.

The fuzzer (:mod:`sim_tools.fuzz`) finds its targets in the simulators' adapters (their ``fuzz``
part, whose contract is in :mod:`sim_tools.fuzz.targets`), and the adapters build their targets
from this package and :mod:`sim_tools.fuzz_kit.mutate`. It is a package of its own, below both,
so that the fuzzer can import the adapters without the adapters importing the fuzzer back: it
imports no adapter and no tool.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sim_tools.fuzz_kit.mutate import dump_yaml, mutate_text, mutate_tree


class Defect(AssertionError):
    """An input loaded but the model misbehaved (non-finite state, wrong shape)."""


def check_finite(values: Any, what: str) -> None:
    """Raise :class:`Defect` unless every value is finite (``what`` names them in the message)."""
    arr = np.asarray(values, dtype=float)
    if not np.isfinite(arr).all():
        raise Defect(f"{what} is not finite: {arr.ravel()[:8]}")


@dataclass
class Case:
    """One input: its files in ``folder`` and how to run it."""

    folder: Path
    run: Callable[[], object]  # what it returns is ignored; only how it ends counts
    note: str = ""


#: A target's case maker: (rng of the input, the seeds it draws from, the case folder) → the case.
CaseMaker = Callable[[random.Random, Any, Path], Case]


def mutated_text(rng: random.Random, seeds: list[str]) -> str:
    """One of the seed texts with text edits (lines or tokens of the other seeds may be spliced in)."""
    return mutate_text(rng, rng.choice(seeds), seeds)


def mutated_yaml(rng: random.Random, tree: Any) -> str:
    """A mutated YAML document: tree edits, then (sometimes) text edits of the dump."""
    text = dump_yaml(mutate_tree(rng, tree) if rng.random() < 0.75 else tree)
    if rng.random() < 0.4:
        text = mutate_text(rng, text)
    return text


__all__ = ["Case", "CaseMaker", "Defect", "check_finite", "mutated_text", "mutated_yaml"]
