"""One episode's row of a sweep's table: every column it has and their order, defined here once.

A worker builds an episode's :class:`Row` (:mod:`.episode`, or :mod:`.supervisor` for an episode
that ended without one), the engines change it on the way back (:mod:`.engines`: the log file in
the error, the driver's key), and the result log stores it as its :class:`Columns`
(:meth:`Row.columns`), from which :mod:`.output` builds the table in :func:`column_order`.

The columns: the episode's ids (:data:`ID_COLUMNS`), its settings (``param.<name>`` per grid
parameter, the start pose, the seed), its outcome (:data:`STATUS_COLUMNS`), then its metrics by
name. No ROS imports: the driver, the workers and a notebook reading a table all use it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, NotRequired, TypedDict

if TYPE_CHECKING:
    from sim_tools.batch.plan import Episode

#: A row as the table and ``episodes.jsonl`` hold it: column name to value.
Columns = dict[str, Any]
Status = Literal["ok", "error"]

#: The columns that say which episode a row is (fields of :class:`Row` of the same names).
ID_COLUMNS = ("episode", "key", "world", "controller")
#: A grid parameter's column is its name after this prefix.
PARAM_PREFIX = "param."
POSE_COLUMNS = ("pose_x", "pose_y", "pose_theta")
#: Every column named so is a setting (:func:`is_setting`), as the start pose's are.
POSE_PREFIX = "pose_"
SEED_COLUMN = "seed"
#: How the episode ended (fields of :class:`Row` of the same names).
STATUS_COLUMNS = ("status", "error", "sim_time_s")
OK: Status = "ok"
ERROR: Status = "error"


@dataclass
class Row:
    """An episode's row: which episode it is, what it was run with, how it ended, its metrics."""

    episode: int
    key: str
    world: str
    controller: str
    params: dict[str, Any]
    pose: tuple[float, float, float] | None
    seed: int
    status: Status
    error: str = ""
    #: The sim time the episode got to (None: it never had a world; no such column then).
    sim_time_s: float | None = None
    metrics: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, ep: Episode, status: Status, error: str = "") -> Row:
        """The row of ``ep`` with its ids and settings, ending with ``status``."""
        return cls(
            episode=ep.index,
            key=ep.key,
            world=ep.world["label"],
            controller=ep.controller["label"],
            params=dict(ep.params),
            pose=ep.pose,
            seed=ep.seed,
            status=status,
            error=error,
        )

    def columns(self) -> Columns:
        """The row's columns in their order: ids, settings, outcome, metrics."""
        out: Columns = {name: getattr(self, name) for name in ID_COLUMNS}
        out.update({f"{PARAM_PREFIX}{k}": v for k, v in self.params.items()})
        if self.pose is not None:
            out.update(zip(POSE_COLUMNS, self.pose[:3], strict=True))
        out[SEED_COLUMN] = self.seed
        # no sim_time_s column for an episode that never had a world (a table of such is without it)
        out.update({name: getattr(self, name) for name in STATUS_COLUMNS if getattr(self, name) is not None})
        out.update(self.metrics)
        return out


class Result(TypedDict):
    """What a worker sends back for an episode: its row and wall seconds of its parts."""

    row: Row
    timing: dict[str, Any]
    #: An episode's log on a Ray node, sent back to the driver (only on the way back from Ray).
    log: NotRequired[bytes]


def is_ok(columns: Columns) -> bool:
    """Whether the episode of ``columns`` ended well."""
    return bool(columns.get("status") == OK)


def is_setting(name: str) -> bool:
    """Whether column ``name`` says what an episode was run with (a grid parameter, pose, seed)."""
    return name.startswith((PARAM_PREFIX, POSE_PREFIX)) or name == SEED_COLUMN


def column_order(rows: Iterable[Columns]) -> list[str]:
    """Every column of ``rows``: ids, settings, outcome, then the rest (metrics) as first seen."""
    seen: dict[str, None] = {}
    for row in rows:
        for key in row:
            seen.setdefault(key, None)
    first = [c for c in ID_COLUMNS if c in seen]
    settings = [c for c in seen if is_setting(c)]
    status = [c for c in STATUS_COLUMNS if c in seen]
    rest = [c for c in seen if c not in first and c not in settings and c not in status]
    return first + settings + status + rest
