"""Bounds every input of every simulator shares (files and parameters); no ROS imports.

One number for "how far is too far": a map's coordinates, a pose, a size, any number read from a
world file, a robot config or a parameter. ±1,000 km is far beyond any room or workcell, and small
enough that squared distances, sums of a million walls and float32 messages stay exact enough.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

#: Largest |coordinate| (m) of a map, a pose or any length read from a file or a parameter.
MAX_COORDINATE_M = 1e6
#: Largest |value| of any other number read from a file (a gain, a mass, a time in seconds):
#: the same bound, so one rule covers every field.
MAX_MAGNITUDE = MAX_COORDINATE_M


def within(value: float, bound: float = MAX_COORDINATE_M) -> bool:
    """Whether ``value`` is a finite number within ``±bound``."""
    return math.isfinite(value) and abs(value) <= bound


def all_within(values: Sequence[float], bound: float = MAX_COORDINATE_M) -> bool:
    """Whether every value is a finite number within ``±bound``."""
    return all(within(float(v), bound) for v in values)
