"""The toy simulator's one input file: where the point robot starts and how fast it may go.

::

    pose: [0.5, -0.25, 90*deg]   # x, y (m), theta (rad; pi and deg allowed)
    max_speed: 0.5               # m/s, > 0
    max_turn: 2.0                # rad/s, > 0

Every problem is an :class:`~sim_runtime.errors.InputError` naming the file and the field. The
limits keep a driven pose finite: a plane of 2,000 km and commands a robot could give.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from sim_runtime.angles import wrap_angle
from sim_runtime.yamlfile import FieldReader, load_yaml

FIELDS = {"pose", "max_speed", "max_turn"}
#: The largest |x| or |y| a start may have (m).
MAX_COORDINATE = 1e6
#: The largest speed (m/s) and turn rate (rad/s) a file may allow.
MAX_SPEED = 100.0
MAX_TURN = 100.0


@dataclass(frozen=True)
class ToyStart:
    """A start file's content: ``pose`` (x m, y m, theta rad in [-pi, pi)) and the command limits."""

    pose: tuple[float, float, float]
    max_speed: float
    max_turn: float


def load_start(path: str | os.PathLike[str]) -> ToyStart:
    """Read a toy start file (see the module docstring)."""
    read = FieldReader(Path(path), expressions=True)
    tree = read.mapping(load_yaml(path, "toy start file"), "", FIELDS)
    x, y, theta = read.vector(read.require(tree, "pose"), "pose", 3)
    for value, field in ((x, "pose[0]"), (y, "pose[1]")):
        if abs(value) > MAX_COORDINATE:
            raise read.error(field, f"must be within ±{MAX_COORDINATE:g} m, got {value:g}")
    return ToyStart(
        pose=(float(x), float(y), float(wrap_angle(theta))),
        max_speed=_limit(read, tree, "max_speed", MAX_SPEED),
        max_turn=_limit(read, tree, "max_turn", MAX_TURN),
    )


def _limit(read: FieldReader, tree: dict, field: str, largest: float) -> float:
    value = read.number(read.require(tree, field), field, positive=True)
    if value > largest:
        raise read.error(field, f"must be at most {largest:g}, got {value:g}")
    return value
