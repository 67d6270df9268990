"""Episode metrics: the built-in ones of each simulator (its adapter's ``METRICS``), and the
user's ``module:function``.

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
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from sim_tools.adapters.contract import EpisodeData, world_part

#: A column named ``<event>_time_s`` is a "time to" metric: NaN when the event never happened.
TIME_TO_SUFFIX = "_time_s"
#: Units of a column, from the end of its name (the longest suffix that matches wins).
UNITS = {"_m": "m", "_m2": "m²", "_s": "s", "_rad": "rad", "_mps": "m/s"}


def built_in(simulator: str) -> Mapping[str, Callable[..., Any]]:
    """The built-in metrics of ``simulator`` by name (its adapter's ``METRICS``)."""
    return world_part(simulator).METRICS


def default_metrics(simulator: str) -> tuple[str, ...]:
    """Every built-in metric of ``simulator`` that needs no options (goal_time_s needs a goal)."""
    return tuple(name for name, function in built_in(simulator).items() if not _required_options(function))


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
    known = built_in(simulator)
    rules = world_part(simulator).METRIC_RULES
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
        _check_options(function, name, options, f"{where}.{name}", fail, rules)


def _check_options(
    function: Callable[..., Any],
    name: str,
    options: dict[str, Any],
    where: str,
    fail: Callable[[str, str], Exception],
    rules: Mapping[tuple[str, str], tuple[Callable[[Any], bool], str]],
) -> None:
    """``options`` against ``function(data, **options)``'s signature, type hints and ``rules``."""
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
        rule = rules.get((name, option))
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
    known = built_in(simulator)
    for entry in metrics or default_metrics(simulator):
        name, options = metric_entry(entry)
        function = load_callable(name, search_path) if ":" in name else known[name]
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
