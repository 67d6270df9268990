"""Joint trajectory files (YAML): a stored motion the studio's arm page plays on ``joint_trajectory``.

Format (angles in radians, lengths in metres; numbers may be expressions with ``pi`` and ``deg``)::

    joint_names: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6]   # optional: default all
    points:                         # at least one; time in seconds from the start, increasing
      - {time: 1.0, positions: [0, -30*deg, 30*deg, 0, 0, 0]}
      - {time: 3.0, positions: [90*deg, 0, 0, 0, 45*deg, 0], velocities: [0, 0, 0, 0, 0, 0]}

``joint_names`` omitted means every joint of the arm in order (the count must then match the
arm's). ``velocities`` are optional, but given for every point or for none (as the arm requires).
Errors name the file, the field and the index.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim_runtime.yamlfile import FieldReader, load_yaml, short

MAX_POINTS = 100_000


@dataclass(frozen=True)
class JointTrajectoryFile:
    """A parsed trajectory: joint names (empty = all of the arm's), times (k,), positions (k, n),
    velocities (k, n) or None."""

    path: Path
    joint_names: tuple[str, ...]
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None


def load_trajectory(path: str | os.PathLike[str]) -> JointTrajectoryFile:
    """Read and check a joint trajectory file; raises InputError naming file, field and index."""
    path = Path(path)
    r = FieldReader(path, expressions=True)
    raw = r.mapping(load_yaml(path, "joint trajectory file"), "", {"joint_names", "points"})
    names: tuple[str, ...] = ()
    if "joint_names" in raw:
        names = tuple(
            r.text(n, f"joint_names[{i}]") for i, n in enumerate(r.sequence(raw["joint_names"], "joint_names"))
        )
        if not names or len(set(names)) != len(names):
            raise r.error("joint_names", f"expected distinct joint names, got {short(list(names))}")
    points = r.sequence(r.require(raw, "points"), "points")
    if not points:
        raise r.error("points", "expected at least one point")
    if len(points) > MAX_POINTS:
        raise r.error("points", f"at most {MAX_POINTS} points, got {len(points)}")
    width = len(names) or None
    times: list[float] = []
    positions: list[np.ndarray] = []
    velocities: list[np.ndarray] = []
    for i, point in enumerate(points):
        where = f"points[{i}]"
        point = r.mapping(point, where, {"time", "positions", "velocities"})
        t = r.number(r.require(point, "time", f"{where}."), f"{where}.time", nonneg=True)
        if times and t <= times[-1]:
            raise r.error(f"{where}.time", f"times must increase, got {t} after {times[-1]}")
        q = r.vector(r.require(point, "positions", f"{where}."), f"{where}.positions", width)
        width = len(q)
        times.append(t)
        positions.append(q)
        if "velocities" in point:
            velocities.append(r.vector(point["velocities"], f"{where}.velocities", width))
    if velocities and len(velocities) != len(points):
        raise r.error("points", "velocities must be given for every point or for none")
    return JointTrajectoryFile(
        path=path,
        joint_names=names,
        times=np.array(times),
        positions=np.array(positions),
        velocities=np.array(velocities) if velocities else None,
    )
