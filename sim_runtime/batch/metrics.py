"""Episode metrics: the built-in ones per simulator, and the user's ``module:function``.

Every metric reads :class:`EpisodeData`, the arrays an episode recorded from the model after every
physics step (not from topics: the same whichever transport carried the messages). A user metric
is ``function(data: EpisodeData) -> float | dict[str, float]``; a float becomes the column named
after the function, a dict one column per key.
"""

from __future__ import annotations

import importlib
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Side of the floor squares counted by ``area_covered_m2`` (m).
COVERAGE_CELL_M = 0.05


@dataclass
class EpisodeData:
    """What an episode recorded: ``arrays`` of per-step samples, ``t`` their sim times (s).

    Create: ``x, y, theta`` (m, rad), ``bump`` (either bumper pressed), ``clearance`` (m from the
    body to the nearest wall). SIMROBOT: ``x, y`` (steps × robots, m), ``crashed`` (steps ×
    robots). Arm: ``error`` (m, flange to the current target), ``target`` (index of the target
    being held). ``info`` holds constants (``radius_m``, ``names``, ``dt``, ``ik_failures``...).
    """

    t: np.ndarray
    arrays: dict[str, np.ndarray]
    info: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    seed: int = 0


# ------------------------------------------------------------------------------------ Create
def create_distance_m(data: EpisodeData) -> float:
    """Path length of the body centre (m)."""
    x, y = data.arrays["x"], data.arrays["y"]
    return float(np.hypot(np.diff(x), np.diff(y)).sum())


def create_bumps(data: EpisodeData) -> int:
    """Bump events: steps at which a bumper became pressed."""
    bump = data.arrays["bump"].astype(np.int8)
    return int(np.count_nonzero(np.diff(bump, prepend=0) > 0))


def create_min_clearance_m(data: EpisodeData) -> float:
    """Smallest gap between the body and a wall over the episode (m; 0 = touching)."""
    return float(max(data.arrays["clearance"].min(), 0.0)) if len(data.t) else math.nan


def create_area_covered_m2(data: EpisodeData, cell_m: float = COVERAGE_CELL_M) -> float:
    """Floor area the body passed over (m²), counted in ``cell_m`` squares whose centre it covered."""
    radius = float(data.info["radius_m"])
    reach = int(math.ceil(radius / cell_m)) + 1
    span = 1 << 24  # cell (i, j) -> the int64 key i·span + j, unique while |j| < 2^23 cells (400 km)
    ij = np.floor(np.column_stack([data.arrays["x"], data.arrays["y"]]) / cell_m).astype(np.int64)
    keys = np.unique(ij[:, 0] * span + ij[:, 1])
    di, dj = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1), indexing="ij")
    # a cell counts when its centre is within the radius of a sample's cell centre
    disc = (np.hypot(di, dj) * cell_m <= radius).ravel()
    offsets = di.ravel()[disc] * span + dj.ravel()[disc]
    covered = np.unique((keys[:, None] + offsets[None, :]).ravel())
    return float(len(covered) * cell_m * cell_m)


def create_goal_time_s(data: EpisodeData, center: list[float], radius_m: float = 0.3) -> float:
    """Sim time at which the body centre first came within ``radius_m`` of ``center`` (NaN: never)."""
    inside = np.hypot(data.arrays["x"] - center[0], data.arrays["y"] - center[1]) <= radius_m
    hits = np.flatnonzero(inside)
    return float(data.t[hits[0]]) if len(hits) else math.nan


def create_final_pose(data: EpisodeData) -> dict[str, float]:
    """Where the robot ended: ``final_x``, ``final_y`` (m), ``final_theta`` (rad)."""
    return {f"final_{k}": float(data.arrays[k][-1]) for k in ("x", "y", "theta")} if len(data.t) else {}


# ----------------------------------------------------------------------------------- SIMROBOT
def simrobot_distance_m(data: EpisodeData) -> dict[str, float]:
    """Path length per robot (``distance_m.<robot>``) and their sum (``distance_m``), m."""
    per = np.hypot(np.diff(data.arrays["x"], axis=0), np.diff(data.arrays["y"], axis=0)).sum(axis=0)
    out = {f"distance_m.{name}": float(d) for name, d in zip(data.info["names"], per, strict=True)}
    return {"distance_m": float(per.sum()), **out}


def simrobot_crashes(data: EpisodeData) -> dict[str, float]:
    """Robots crashed at the end (``crashes``) and per robot 0/1 (``crashed.<robot>``)."""
    final = data.arrays["crashed"][-1] if len(data.t) else np.zeros(len(data.info["names"]), dtype=bool)
    out = {f"crashed.{name}": int(c) for name, c in zip(data.info["names"], final, strict=True)}
    return {"crashes": int(final.sum()), **out}


def simrobot_steps_survived(data: EpisodeData) -> dict[str, float]:
    """Steps each robot ran, the one it crashed in included (all steps if it never crashed), and
    their mean."""
    crashed = data.arrays["crashed"]  # row k: after step k (row 0: the start)
    steps = len(data.t) - 1
    first = np.where(crashed.any(axis=0), crashed.argmax(axis=0), steps)
    out = {f"steps_survived.{name}": int(s) for name, s in zip(data.info["names"], first, strict=True)}
    return {"steps_survived": float(first.mean()), **out}


# ---------------------------------------------------------------------------------------- arm
def arm_tracking_error_m(data: EpisodeData) -> dict[str, float]:
    """Flange-to-target distance at the end of each target's hold: mean and worst (m)."""
    ends = np.flatnonzero(np.diff(data.arrays["target"], append=-1) != 0)
    errors = data.arrays["error"][ends]
    return {"tracking_error_m": float(errors.mean()), "max_tracking_error_m": float(errors.max())}


def arm_ik_failures(data: EpisodeData) -> int:
    """Targets the inverse kinematics could not reach."""
    return int(data.info["ik_failures"])


BUILT_IN: dict[str, dict[str, Callable[..., Any]]] = {
    "create": {
        "distance_m": create_distance_m,
        "bumps": create_bumps,
        "min_clearance_m": create_min_clearance_m,
        "area_covered_m2": create_area_covered_m2,
        "goal_time_s": create_goal_time_s,
        "final_pose": create_final_pose,
    },
    "simrobot": {
        "distance_m": simrobot_distance_m,
        "crashes": simrobot_crashes,
        "steps_survived": simrobot_steps_survived,
    },
    "arm": {"tracking_error_m": arm_tracking_error_m, "ik_failures": arm_ik_failures},
}
#: Metrics that need options are not in the default set.
NEEDS_OPTIONS = {"goal_time_s"}


def default_metrics(simulator: str) -> tuple[str, ...]:
    """Every built-in metric of ``simulator`` that needs no options."""
    return tuple(name for name in BUILT_IN[simulator] if name not in NEEDS_OPTIONS)


def load_callable(target: str, search_path: str | None = None) -> Any:
    """``module:name`` → the object, importing ``module`` (the sweep's folder on sys.path)."""
    module_name, _, name = target.partition(":")
    if search_path and search_path not in sys.path:
        sys.path.insert(0, search_path)
    module = importlib.import_module(module_name)
    try:
        return getattr(module, name)
    except AttributeError:
        raise ImportError(f"module {module_name!r} has no {name!r}") from None


def check_metrics(simulator: str, metrics: tuple[Any, ...], fail: Callable[[str, str], Exception]) -> None:
    """Raise ``fail(field, message)`` for an unknown metric or bad options."""
    known = BUILT_IN[simulator]
    for k, entry in enumerate(metrics):
        name, options = (entry, {}) if isinstance(entry, str) else next(iter(entry.items()))
        where = f"metrics[{k}]"
        if ":" in name:
            continue  # a user's function: imported by load_sweep
        if name not in known:
            raise fail(where, f"{name!r}: {simulator} metrics are {', '.join(known)} or module:function")
        if name == "goal_time_s":
            center = options.get("center")
            if not (isinstance(center, list) and len(center) == 2 and all(isinstance(v, int | float) for v in center)):
                raise fail(f"{where}.goal_time_s.center", f"{center!r}: expected [x, y] in metres")
            radius = options.get("radius_m", 0.3)
            if not isinstance(radius, int | float) or radius <= 0:
                raise fail(f"{where}.goal_time_s.radius_m", f"{radius!r}: expected a radius > 0 m")
        try:
            import inspect

            inspect.signature(known[name]).bind(None, **options)
        except TypeError as exc:
            raise fail(f"{where}.{name}", f"bad options {options!r}: {exc}") from None


def compute(simulator: str, metrics: tuple[Any, ...], data: EpisodeData, search_path: str) -> dict[str, Any]:
    """The metric columns of one episode (``metrics`` empty = the simulator's defaults)."""
    row: dict[str, Any] = {}
    for entry in metrics or default_metrics(simulator):
        name, options = (entry, {}) if isinstance(entry, str) else next(iter(entry.items()))
        function = load_callable(name, search_path) if ":" in name else BUILT_IN[simulator][name]
        value = function(data, **options)
        column = name.rpartition(":")[2]
        if isinstance(value, dict):
            row.update({str(k): _plain(v) for k, v in value.items()})
        else:
            row[column] = _plain(value)
    return row


def _plain(value: Any) -> Any:
    """numpy scalars → Python numbers (the table's columns are plain types)."""
    if isinstance(value, np.generic):
        return value.item()
    return value
