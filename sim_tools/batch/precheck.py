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

from collections.abc import Callable
from typing import Any

from sim_runtime.errors import InputError
from sim_tools.adapters.contract import world_part, world_parts
from sim_tools.batch.plan import Episode

Fail = Callable[[str, str], InputError]

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


def check_world_files(fail: Fail, worlds: list[tuple[str, dict[str, Any]]]) -> None:
    """Parse every world's files once: a bad one fails the sweep at its field."""
    for k, (simulator, world) in enumerate(worlds):
        for key, parse in world_part(simulator).WORLD_FILES.items():
            path = world.get(key)
            if not path:
                continue
            try:
                parse(path)
            except (InputError, OSError, ValueError) as err:
                raise fail(f"worlds[{k}].{key}", " ".join(str(err).split())) from None  # one line


def check_parameters(
    fail: Fail,
    episodes: list[Any],
    grid_keys: list[str],
    grid_values: list[list[Any]],
) -> list[list[Any]]:
    """Check the controllers' forms and that every parameter the sweep sets is someone's;
    ``episodes`` holds one episode per controller (the sweep's first values). Returns the grid
    values with whole numbers made floats where the controllers declare a float (rclpy refuses
    an integer for a double parameter)."""
    declared = [_probe(fail, k, ep) for k, ep in enumerate(episodes)]
    world = _WorldParameters(episodes[0])
    for k, ep in enumerate(episodes):
        parameters = ep.controller["parameters"]
        for name in list(parameters):
            where = f"controllers[{k}].parameters.{name}"
            _check_name(fail, where, name, [declared[k]], [ep.controller["label"]], world)
            parameters[name] = _widened(parameters[name], [declared[k]], name)
    targets = [ep.controller["label"] for ep in episodes]
    for name in grid_keys:
        _check_name(fail, f"grid.{name}", name, declared, targets, world)
    return [[_widened(v, declared, name) for v in values] for name, values in zip(grid_keys, grid_values, strict=True)]


def _probe(fail: Fail, k: int, ep: Any) -> dict[str, Any] | None:
    """The controller's declared parameters, built with their defaults (the sweep's 1 for a
    float parameter would be refused before it is widened), else with the sweep's values (a node
    whose defaults are not enough)."""
    import dataclasses

    from sim_tools.batch.episode import probe_controller

    bare = dataclasses.replace(ep, params={}, controller={**ep.controller, "parameters": {}})
    try:
        return probe_controller(bare)
    except Exception:
        pass  # perhaps it needs the sweep's values (policy_controller needs its policy file)
    try:
        return probe_controller(ep)
    except InputError as err:
        raise fail(f"controllers[{k}].use", str(err)) from None
    except BaseException as err:  # a student's constructor or main() raising, sys.exit included
        if isinstance(err, KeyboardInterrupt):
            raise
        where = f"controllers[{k}].use" if isinstance(err, InputError) else f"controllers[{k}]"
        raise fail(
            where, f"{ep.controller['label']} failed before its first step: {type(err).__name__}: {err}"
        ) from None


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
) -> list[list[Any]]:
    """Everything above, for :func:`sim_tools.batch.sweep.load_sweep`; returns the grid values
    (see :func:`check_parameters`)."""
    check_world_files(fail, worlds)
    keys, values = grid
    first = {k: v[0] for k, v in zip(keys, values, strict=True)}
    episodes = [Episode(0, simulator, worlds[0][1], c, first, None, seed, 1.0, (), search_path) for c in controllers]
    return check_parameters(fail, episodes, keys, values)
