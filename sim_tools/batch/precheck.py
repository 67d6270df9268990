"""What :func:`sim_tools.batch.sweep.load_sweep` checks before any episode runs, beyond the
sweep file's own fields: each world's files parsed by their real parsers, each user controller's
form, and each parameter the sweep sets declared by a controller or the world (a parameter nobody
reads would give rows that differ only in its column). A mistake is one error naming the sweep
file and the field, not an error row per episode.

A controller's parameters are learnt by building its node once, with the sweep's first values, in
a context of its own and without a world (:func:`sim_tools.batch.episode.probe_controller`);
the world's by building the first world once, only when a parameter is not a controller's.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_tools.adapters.contract import world_part, world_parts
from sim_tools.batch.plan import Episode

Fail = Callable[[str, str], InputError]
Stage = Callable[[int, str, str], None]

#: Parameters every sweep sets itself, and the field that says them (each simulator adds its
#: world's: its adapter's ``RESERVED``).
RESERVED = {
    "seed": "the sweep's seeds",
    "real_time_factor": "always 0 in a batch",
}
#: Parameters every rclpy node declares: not worth listing in an error.
STANDARD = {"use_sim_time", "start_type_description_service"}


def reserved() -> dict[str, str]:
    """Every parameter a sweep sets itself (:data:`RESERVED` and every simulator's world's)."""
    out = dict(RESERVED)
    for part in world_parts().values():
        out.update(part.RESERVED)
    return out


class Refused(Exception):
    """A controller that cannot run: the sweep's field that names it, and why."""

    def __init__(self, field: str, reason: str) -> None:
        super().__init__(f"field '{field}': {reason}")
        self.field, self.reason = field, reason


@dataclass
class Checked:
    """What :func:`check_sweep` learnt: the grid's values (widened, see :func:`check_parameters`),
    per working controller the grid parameters it is swept over, and the broken controllers."""

    grid_values: list[list[Any]]
    applies: dict[int, list[str]] = field(default_factory=dict)
    broken: dict[int, Refused] = field(default_factory=dict)


def check_world_files(fail: Fail, worlds: list[tuple[str, dict[str, Any]]], strict: bool) -> list[str]:
    """Parse every world's files once: a bad one fails the sweep at its field. What a parser warns
    about (a map row it skips, with file:line) fails it too when ``strict``; else it is returned,
    for the terminal."""
    said: list[str] = []
    for k, (simulator, world) in enumerate(worlds):
        for key, parse in world_part(simulator).WORLD_FILES.items():
            path = world.get(key)
            if not path:
                continue
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    parse(path)
                except (InputError, OSError, ValueError) as err:
                    raise fail(f"worlds[{k}].{key}", " ".join(str(err).split())) from None  # one line
            lines = [" ".join(str(w.message).split()) for w in caught]
            if lines and strict:
                raise fail(
                    f"worlds[{k}].{key}",
                    "; ".join(lines) + " (a row with a typo would be left out of every episode; fix it, or "
                    "set file_warnings: warn to run with it skipped)",
                )
            said += [f"warning: worlds[{k}].{key}: {line}" for line in lines]
    return said


def check_parameters(
    fail: Fail,
    episodes: list[Any],
    grid_keys: list[str],
    grid_values: list[list[Any]],
    checked: Checked,
    stage: Stage,
) -> None:
    """Check the controllers' forms and that every parameter the sweep sets is someone's;
    ``episodes`` holds one episode per controller (the sweep's first values). A controller that
    cannot be built goes to ``checked.broken`` (the others are checked on). Sets the grid values
    with whole numbers made floats where the controllers declare a float (rclpy refuses an
    integer for a double parameter), and which grid parameters each controller is swept over:
    those it declares or the world has (all of them when its form cannot tell)."""
    declared: dict[int, dict[str, Any] | None] = {}
    for k, ep in enumerate(episodes):
        if k in checked.broken:
            continue
        stage(k, ep.controller["label"], "building it")
        try:
            declared[k] = _probe(k, ep)
        except Refused as refused:
            checked.broken[k] = refused
    stage(-1, "", "checking the parameters")  # no controller's code runs from here on
    world = _WorldParameters(episodes[0])
    working = list(declared)
    for k in working:
        ep = episodes[k]
        parameters = ep.controller["parameters"]
        for name in list(parameters):
            where = f"controllers[{k}].parameters.{name}"
            _check_name(fail, where, name, [declared[k]], [ep.controller["label"]], world)
            parameters[name] = _widened(parameters[name], [declared[k]], name)
    found = [declared[k] for k in working]
    targets = [episodes[k].controller["label"] for k in working]
    for name in grid_keys:
        if checked.broken:
            # a parameter only a broken controller would declare is no typo we can tell: the
            # working ones are not swept over it (``applies``), the broken ones' rows are errors
            _check_name(fail, f"grid.{name}", name, [None], targets[:1] or ["?"], world)
        elif working:
            _check_name(fail, f"grid.{name}", name, found, targets, world)
    checked.grid_values = [
        [_widened(v, found, name) for v in values] for name, values in zip(grid_keys, grid_values, strict=True)
    ]
    for k in working:
        mine = declared[k]
        checked.applies[k] = [n for n in grid_keys if mine is None or n in mine or world.has(n)]


def _probe(k: int, ep: Any) -> dict[str, Any] | None:
    """The controller's declared parameters, built with their defaults (the sweep's 1 for a
    float parameter would be refused before it is widened), else with the sweep's values (a node
    whose defaults are not enough); :class:`Refused` when it cannot be built."""
    import dataclasses

    from sim_tools.batch.episode import probe_controller

    bare = dataclasses.replace(ep, params={}, controller={**ep.controller, "parameters": {}})
    try:
        return probe_controller(bare)
    except Exception:
        pass  # perhaps it needs the sweep's values (policy_controller needs its policy file)
    except SystemExit:
        pass  # the same again, to report it
    try:
        return probe_controller(ep)
    except InputError as err:
        raise Refused(f"controllers[{k}].use", str(err)) from None
    except BaseException as err:  # a student's constructor or main() raising, sys.exit included
        if isinstance(err, KeyboardInterrupt):
            raise
        what = f"SystemExit: it called sys.exit({err.code!r})" if isinstance(err, SystemExit) else _text(err)
        raise Refused(
            f"controllers[{k}]", f"{ep.controller['label']} failed before its first step: {what}{_student_line(err)}"
        ) from None


def _student_line(err: BaseException) -> str:
    """`` (at student.py:12)``: the innermost line of the error's stack in a user's file."""
    from sim_tools.batch.episode import user_frame

    frame = user_frame(err)
    return f" (at {Path(frame.filename).name}:{frame.lineno})" if frame is not None else ""


class _WorldParameters:
    """The world's parameter names, learnt the first time they are needed."""

    def __init__(self, ep: Any) -> None:
        self.ep = ep
        self.names: set[str] | None = None

    def has(self, name: str) -> bool:
        if self.names is None:
            from sim_tools.batch.episode import probe_world

            self.names = probe_world(self.ep)
        return name in self.names


def _check_name(
    fail: Fail, where: str, name: str, declared: list[dict[str, Any] | None], targets: list[str], world: Any
) -> None:
    sets = reserved()
    if name in sets:
        raise fail(where, f"{name!r} is set by {sets[name]}, not by a parameter")
    if any(d is None or name in d for d in declared) or world.has(name):
        return
    said = "; ".join(
        f"{target} declares {', '.join(sorted(set(d or {}) - STANDARD)) or 'none'}"
        for target, d in zip(targets, declared, strict=True)
    )
    raise fail(
        where,
        f"{name!r}: no controller declares it and the {world.ep.simulator} world has no such parameter "
        f"(a value nobody reads would give identical rows; {said})",
    )


def _widened(value: Any, declared: list[dict[str, Any] | None], name: str) -> Any:
    """``value`` as a float if it is a whole number and every controller declaring ``name``
    declares a float."""
    from rclpy.parameter import Parameter

    types = [d[name] for d in declared if d and name in d]
    whole = isinstance(value, int) and not isinstance(value, bool)
    if whole and types and all(t == Parameter.Type.DOUBLE for t in types):
        return float(value)
    return value


def _text(err: BaseException) -> str:
    return " ".join(f"{type(err).__name__}: {err}".split())


def check_sweep(
    fail: Fail,
    simulator: str,
    worlds: list[tuple[str, dict[str, Any]]],
    controllers: list[dict[str, Any]],
    grid: tuple[list[str], list[list[Any]]],
    seed: int,
    search_path: str,
    broken: dict[int, Refused],
    stage: Stage,
) -> Checked:
    """Everything above but the files (:func:`check_world_files`), for
    :func:`sim_tools.batch.sweep.load_sweep`; ``broken`` holds the controllers already refused."""
    keys, values = grid
    first = {k: v[0] for k, v in zip(keys, values, strict=True)}
    episodes = [Episode(0, simulator, worlds[0][1], c, first, None, seed, 1.0, (), search_path) for c in controllers]
    checked = Checked(values, broken=dict(broken))
    check_parameters(fail, episodes, keys, values, checked, stage)
    return checked
