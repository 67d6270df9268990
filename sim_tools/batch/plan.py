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
        # the world's files by where they are in the sweep's folder (or the shipped config/), not
        # by absolute path: a sweep folder moved or copied elsewhere resumes without rerunning
        what["world"] = {k: relative_path(v, self.search_path) for k, v in what["world"].items()}
        what["controller"].pop("transport")  # how messages travel does not change the result
        if what["controller"]["kind"] == "user":
            # users' nodes run on sim time with seeded random/numpy since this mark: rows logged
            # before it (wall-clock timers, unseeded draws) must not be resumed beside new ones
            what["runs"] = "sim time, seeded"
        return hashlib.sha1(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:16]


def relative_path(value: Any, sweep_dir: str) -> Any:
    """``value`` as ``sweep:<path>`` under ``sweep_dir`` or ``config:<path>`` under the shipped
    ``config/`` when it is an absolute path there; anything else unchanged."""
    from sim_runtime.paths import config_dir

    if not isinstance(value, str) or not value.startswith("/"):
        return value
    path = Path(value)
    for tag, root in (("sweep", Path(sweep_dir)), ("config", config_dir().resolve())):
        if path.is_relative_to(root):
            return f"{tag}:{path.relative_to(root).as_posix()}"
    return value


@dataclass(frozen=True)
class Broken:
    """A controller refused before the sweep: its index and name in the sweep, the field and why."""

    index: int
    label: str
    field: str
    reason: str

    def line(self) -> str:
        return f"field '{self.field}' ({self.label}): {self.reason}"


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
    #: What the files' parsers warned about (file:line), shown before any episode.
    warnings: list[str] = field(default_factory=list)
    #: Controllers that cannot run (see ``--broken-as-rows``), and the episodes they would have had.
    broken: list[Broken] = field(default_factory=list)
    broken_episodes: list[Episode] = field(default_factory=list)
    #: Per controller name: the grid parameters it is swept over (those it or the world declares).
    grid_applies: dict[str, list[str]] = field(default_factory=dict)
