"""The plan of a sweep as plain data: its episodes and where their results go.

No ROS imports and no imports of the rest of the batch: the driver, the checks before a sweep
(:mod:`.precheck`) and the workers (:mod:`.episode`) all read it.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Episode:
    """One run: everything a worker needs, as plain data (pickles and hashes the same anywhere)."""

    index: int
    simulator: str
    world: dict[str, Any]
    controller: dict[str, Any]
    params: dict[str, Any]
    pose: tuple[float, float, float] | None
    seed: int
    duration_s: float
    metrics: tuple[Any, ...]
    search_path: str
    record_bag: bool = False
    bag_dir: str = ""

    @property
    def key(self) -> str:
        """A digest of what determines the result (not the index): a rerun of an edited sweep
        redoes exactly the episodes whose definition changed."""
        what = asdict(self)
        for volatile in ("index", "record_bag", "bag_dir", "search_path"):
            what.pop(volatile)
        what["controller"].pop("transport")  # how messages travel does not change the result
        if what["controller"]["kind"] == "user":
            # users' nodes run on sim time with seeded random/numpy since this mark: rows logged
            # before it (wall-clock timers, unseeded draws) must not be resumed beside new ones
            what["runs"] = "sim time, seeded"
        return hashlib.sha1(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass
class Sweep:
    """A parsed sweep file."""

    source: Path
    episodes: list[Episode]
    keep_bags: str
    out: Path
    grid_keys: list[str] = field(default_factory=list)
    time_limit_s: float = 60.0
    memory_limit_mb: float | None = None
