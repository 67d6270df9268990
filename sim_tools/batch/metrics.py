"""Episode metrics: the built-in ones per simulator, and the user's ``module:function``.

Every metric reads :class:`EpisodeData`, the arrays an episode recorded from the model after every
physics step (not from topics: the same whichever transport carried the messages). A user metric
is ``function(data: EpisodeData) -> float | dict[str, float]``; a float becomes the column named
after the function, a dict one column per key.
"""

from __future__ import annotations

import importlib
import inspect
import math
import sys
import typing
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Side of the floor squares counted by ``area_covered_m2`` (m).
COVERAGE_CELL_M = 0.05
#: A column named ``<event>_time_s`` is a "time to" metric: NaN when the event never happened.
TIME_TO_SUFFIX = "_time_s"
#: Units of a column, from the end of its name (the longest suffix that matches wins).
UNITS = {"_m": "m", "_m2": "m²", "_s": "s", "_rad": "rad", "_mps": "m/s"}


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
    from create_sim.physics import _TOUCH

    if not len(data.t):
        return math.nan
    gap = float(data.arrays["clearance"].min())
    # the physics pushes a body that hit a wall out to 1e-8 m, and calls anything nearer than
    # _TOUCH touching: report that as 0, not as a 1e-8 the table and plots cannot tell from 0
    return 0.0 if gap < _TOUCH else gap


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


def default_metrics(simulator: str) -> tuple[str, ...]:
    """Every built-in metric of ``simulator`` that needs no options (goal_time_s needs a goal)."""
    return tuple(name for name, function in BUILT_IN[simulator].items() if not _required_options(function))


def _required_options(function: Callable[..., Any]) -> list[str]:
    return [p.name for p in _options(function)[0] if p.default is p.empty]


def _options(function: Callable[..., Any]) -> tuple[list[inspect.Parameter], bool]:
    """The options ``function(data, ...)`` takes by name, and whether it takes ``**any``."""
    parameters = list(inspect.signature(function).parameters.values())[1:]  # after the data
    named = [p for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    return named, any(p.kind is p.VAR_KEYWORD for p in parameters)


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


#: What the type hints of built-in metrics' options cannot say: a test and what it expects.
OPTION_RULES: dict[tuple[str, str], tuple[Callable[[Any], bool], str]] = {
    ("goal_time_s", "center"): (lambda v: len(v) == 2, "[x, y] in metres"),
    ("goal_time_s", "radius_m"): (lambda v: v > 0, "a radius > 0 m"),
    ("area_covered_m2", "cell_m"): (lambda v: v > 0, "a cell side > 0 m"),
}


def metric_entry(entry: Any) -> tuple[str, dict[str, Any]]:
    """A sweep's metric entry (``name`` or ``{name: {options}}``) → name and options."""
    if isinstance(entry, str):
        return entry, {}
    name, options = next(iter(entry.items()))
    return str(name), dict(options)


def split_unit(name: str) -> tuple[str, str]:
    """A column's name → its stem and the unit it ends with: ``area_covered_m2`` → ``("area_covered",
    "m²")``; ``("bumps", "")`` without one."""
    matches = [suffix for suffix in UNITS if name.endswith(suffix)]
    if not matches:
        return name, ""
    suffix = max(matches, key=len)
    return name.removesuffix(suffix), UNITS[suffix]


def unit_of(name: str) -> str:
    """The unit a column's name ends with (``distance_m`` → ``m``), else ``""``."""
    return split_unit(name)[1]


def reached_column(metric: str) -> str | None:
    """``goal_time_s`` → ``goal_reached``: the yes/no column beside a "time to" metric."""
    return metric.removesuffix(TIME_TO_SUFFIX) + "_reached" if metric.endswith(TIME_TO_SUFFIX) else None


def check_metrics(
    simulator: str,
    metrics: tuple[Any, ...],
    fail: Callable[[str, str], Exception],
    search_path: str | None = None,
) -> None:
    """Raise ``fail(field, message)`` for an unknown metric, an option its function does not take,
    a missing one or one of the wrong type. A user's ``module:function`` that does not import is
    left to the caller (which says why)."""
    known = BUILT_IN[simulator]
    for k, entry in enumerate(metrics):
        name, options = metric_entry(entry)
        where = f"metrics[{k}]"
        if ":" in name:
            try:
                function = load_callable(name, search_path)
            except Exception:
                continue
        elif name in known:
            function = known[name]
        else:
            raise fail(where, f"{name!r}: {simulator} metrics are {', '.join(known)} or module:function")
        _check_options(function, name, options, f"{where}.{name}", fail)


def _check_options(
    function: Callable[..., Any], name: str, options: dict[str, Any], where: str, fail: Callable[[str, str], Exception]
) -> None:
    """``options`` against ``function(data, **options)``'s signature, type hints and rules."""
    try:
        named, takes_any = _options(function)
    except (TypeError, ValueError):
        return  # no signature to check against (a builtin or C function): the episode will say
    accepted = f"it takes: {', '.join(p.name for p in named)}" if named else "it takes no options"
    if not takes_any:
        for option in options:
            if option not in {p.name for p in named}:
                raise fail(f"{where}.{option}", f"unknown option of {name} ({accepted})")
    for p in named:
        if p.default is p.empty and p.name not in options:
            raise fail(f"{where}.{p.name}", f"missing: {name} needs it ({accepted})")
    hints = _type_hints(function)
    for option, value in options.items():
        expected = _type_problem(value, hints.get(option), option)
        rule = OPTION_RULES.get((name, option))
        if rule is not None and (expected is not None or not rule[0](value)):
            expected = rule[1]  # the rule says it better than the type hint
        if expected is not None:
            raise fail(f"{where}.{option}", f"{value!r}: expected {expected}")


def _type_hints(function: Callable[..., Any]) -> dict[str, Any]:
    try:
        return typing.get_type_hints(function)
    except Exception:
        return {}  # a user's hint that does not resolve is not ours to judge


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _type_problem(value: Any, hint: Any, option: str) -> str | None:
    """What ``value`` should have been for the type hint ``hint`` (None: it fits, or the hint is
    not one of the plain kinds a YAML value can have)."""
    unit = unit_of(option)
    number = f"a number ({unit})" if unit else "a number"
    if hint is float:
        return None if _is_number(value) else number
    if hint is int:
        return None if isinstance(value, int) and not isinstance(value, bool) else "a whole number"
    if hint is bool:
        return None if isinstance(value, bool) else "true or false"
    if hint is str:
        return None if isinstance(value, str) else "a string"
    if typing.get_origin(hint) in (list, tuple) and typing.get_args(hint)[:1] == (float,):
        fits = isinstance(value, list) and all(_is_number(v) for v in value)
        return None if fits else f"a list of numbers{f' ({unit})' if unit else ''}"
    return None


def compute(simulator: str, metrics: tuple[Any, ...], data: EpisodeData, search_path: str) -> dict[str, Any]:
    """The metric columns of one episode (``metrics`` empty = the simulator's defaults)."""
    row: dict[str, Any] = {}
    for entry in metrics or default_metrics(simulator):
        name, options = metric_entry(entry)
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
