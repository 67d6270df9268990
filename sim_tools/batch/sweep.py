"""The sweep file: worlds × controllers × parameter grid × poses × seeds → a list of episodes.

No ROS imports: the driver process reads and expands the sweep; workers get plain episodes.

```yaml
worlds:                      # one or more; all of one simulator (its adapter's WORLD_KEY says which)
  - {map: create/example.map, config: ""}      # Create: map + noise config ("" = noise-free)
  # - {world_file: simrobot/demo.yaml}          # SIMROBOT
  # - {robot_config: arm/irb120.yaml, targets: [[0.4, 0.0, 0.5], ...]}   # arm
controllers:                 # one or more
  - create_bump_turn                            # an executable of ours
  # - my_pkg.my_node:MyNode                     # a user's rclpy node class (or module:main)
  # - my_pkg.policies:make_controller           # an in-process model controller
  # - lab1.m                                    # an m-file function lab1(serPort), in Octave (Create)
  # - {name: cautious, use: create_bump_turn, parameters: {...}, transport: ros}
grid: {threshold: [0.1, 0.2]}   # controller parameters, every combination
poses: {random: 1000, seed: 1, margin_m: 0.05}  # or a list of [x, y, theta] (a simulator with random_poses)
seeds: [0, 1, 2]             # or {count: 5, start: 0}; seeds the world's noise and the controller
duration_s: 60               # sim time per episode
time_limit_s: 180            # wall seconds per episode (default max(60, 3 x duration_s))
memory_limit_mb: 2000        # an episode's process may use this much memory (default: no limit)
metrics: [distance_m, bumps, {goal_time_s: {center: [3, 1], radius_m: 0.4}}, my_metrics:score]
keep_bags: none              # none | all | failures
file_warnings: error         # error (default) | warn: a map row that does not parse
out: out/batch/my_sweep      # default out/batch/<sweep file name>
```

Paths in the sweep are relative to the sweep file, else to the shipped ``config/``. A bad sweep
raises :class:`InputError` naming the file and the field; so do two controllers or worlds of one
name, a seed, pose or grid value given twice (rows of one would be taken for the other's), a row
of a world's file that its parser skips (``file_warnings: warn`` only shows it) and a start pose
outside a world's walls or inside one. Controllers that cannot be imported or built are collected,
not stopped at: every broken one is named in one error (or, ``broken_as_rows``, kept in
:attr:`Sweep.broken` for error rows).
"""

from __future__ import annotations

import itertools
import math
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem, shown
from sim_runtime.paths import config_path
from sim_runtime.yamlfile import load_yaml, short
from sim_tools.adapters.contract import world_part, world_parts
from sim_tools.batch.plan import Broken, Episode, Sweep

__all__ = ["Episode", "Sweep", "default_time_limit", "executable_controllers", "load_sweep", "world_keys"]

Stage = Callable[[int, str, str], None]
"""Told ``(controller index, its name, what is being done)`` before a controller's code runs
(:mod:`.isolated_load` names the controller whose check crashed or hung)."""

TOP_KEYS = {
    "worlds",
    "world",
    "controllers",
    "controller",
    "grid",
    "poses",
    "seeds",
    "duration_s",
    "metrics",
    "keep_bags",
    "out",
    "time_limit_s",
    "memory_limit_mb",
    "name",
    "file_warnings",
}
KEEP_BAGS = ("none", "all", "failures")
FILE_WARNINGS = ("error", "warn")
TOP = "(top level)"
TRANSPORTS = ("auto", "direct", "ros")


class _Reader:
    """Field-by-field checks with one-line errors naming the file and the field."""

    def __init__(self, source: Path) -> None:
        self.source = source

    def fail(self, where: str, message: str) -> InputError:
        return InputError(f"{shown(self.source)}: field '{where}': {message}")

    def number(self, value: Any, where: str, *, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise self.fail(where, f"{short(value)} is not a finite number")
        if positive and value <= 0:
            raise self.fail(where, f"{short(value)} must be > 0")
        return float(value)

    def integer(self, value: Any, where: str, *, minimum: int = 0) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.fail(where, f"{short(value)} must be a whole number >= {minimum}")
        return int(value)

    def mapping(self, value: Any, where: str, allowed: set[str] | None = None) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a mapping, got {short(value)}")
        if allowed is not None:
            unknown = sorted(set(map(str, value)) - allowed)
            if unknown:
                field = unknown[0] if where == TOP else f"{where}.{unknown[0]}"
                raise self.fail(field, f"unknown key (known: {', '.join(sorted(allowed))})")
        return value

    def listing(self, value: Any, where: str) -> list[Any]:
        if isinstance(value, list):
            if not value:
                raise self.fail(where, "the list is empty")
            return value
        return [value]

    def file(self, value: Any, where: str) -> str:
        """A path relative to the sweep file, else to the shipped config/; '' stays ''."""
        if not isinstance(value, str):
            raise self.fail(where, f"{short(value)} is not a file path")
        if value == "":
            return ""
        for candidate in (self.source.parent / value, config_path(value)):
            problem = file_problem(candidate)  # a FIFO, a device, a name too long: never raises
            if problem is None:
                return str(candidate.resolve())
            if problem != "not found":
                raise self.fail(where, f"{shown(candidate)}: {problem}, not a readable file")
        looked = "next to the sweep file or in the shipped config/"
        raise self.fail(where, f"file {shown(repr(value))} not found ({looked})")


def world_keys() -> dict[str, str]:
    """Which key of a world entry names which simulator (each adapter's ``WORLD_KEY``)."""
    return {part.WORLD_KEY: name for name, part in world_parts().items()}


def executable_controllers() -> dict[str, tuple[str, str]]:
    """Our executables that can drive an episode: the simulator each drives and its node class."""
    return {exe: (name, target) for name, part in world_parts().items() for exe, target in part.CONTROLLERS.items()}


def _world(r: _Reader, entry: Any, where: str) -> tuple[str, dict[str, Any]]:
    parts = world_parts()
    keys = world_keys()
    options = {key for part in parts.values() for key in part.WORLD_OPTIONS}
    entry = r.mapping(entry, where, {*keys, *options, "name"})
    kinds = [keys[k] for k in keys if k in entry]
    if len(kinds) != 1:
        raise r.fail(where, f"give exactly one of {', '.join(keys)} (got {sorted(entry)})")
    simulator = kinds[0]
    part = parts[simulator]
    world = part.read_world(r, entry, where)
    for other in parts.values():
        for key, what in other.WORLD_OPTIONS.items():
            if other is not part and key in entry:
                raise r.fail(f"{where}.{key}", f"only {other.LABEL} worlds take {what}")
    world["label"] = str(entry.get("name") or Path(str(entry[part.WORLD_KEY])).stem)
    return simulator, world


def _controller(r: _Reader, entry: Any, where: str, simulator: str) -> dict[str, Any]:
    if isinstance(entry, str):
        entry = {"use": entry}
    entry = r.mapping(entry, where, {"use", "name", "parameters", "transport"})
    use = entry.get("use")
    ours = executable_controllers()
    if not isinstance(use, str) or not use:
        raise r.fail(f"{where}.use", f"{short(use)}: expected an executable ({', '.join(ours)}) or module:name")
    if use in ours:
        needs, target = ours[use]
        if needs != simulator:
            raise r.fail(where, f"{use} drives {needs} worlds, not {simulator} ones")
        kind = "ours"
    elif use.endswith(".m"):
        target, kind = _mfile(r, use, f"{where}.use", simulator), "mfile"
    elif ":" in use:
        target, kind = use, "user"
    else:
        raise r.fail(where, f"{short(use)}: not one of our controllers ({', '.join(ours)}), module:name nor an m-file")
    transport = entry.get("transport", "auto")
    if transport not in TRANSPORTS or (kind == "mfile" and transport == "direct"):
        allowed = ("auto", "ros") if kind == "mfile" else TRANSPORTS
        raise r.fail(f"{where}.transport", f"{short(transport)}: expected one of {', '.join(allowed)}")
    parameters = r.mapping(entry.get("parameters", {}), f"{where}.parameters")
    if "name" in entry and (not isinstance(entry["name"], str) or not entry["name"].strip()):
        raise r.fail(f"{where}.name", f"{short(entry['name'])}: expected a name (text)")
    return {
        "label": str(entry.get("name", use)),
        "target": target,
        "kind": kind,
        "parameters": {str(k): v for k, v in parameters.items()},
        "transport": transport,
    }


def _mfile(r: _Reader, use: str, where: str, simulator: str) -> str:
    """An m-file controller's path (for the worlds whose adapter takes them: ``MFILE_CONTROLLERS``)."""
    from sim_tools.matlab.octave import program_name_problem

    if not world_part(simulator).MFILE_CONTROLLERS:
        labels = " or ".join(part.LABEL for part in world_parts().values() if part.MFILE_CONTROLLERS)
        raise r.fail(where, f"{short(use)}: an m-file controller drives {labels} worlds (their MATLAB toolbox)")
    path = r.file(use, where)
    problem = program_name_problem(Path(path))
    if problem:
        raise r.fail(where, f"{short(use)}: {problem}")
    return path


def _importable(r: _Reader, target: str, where: str) -> None:
    """Import a user's ``module:name`` now, so that a typo fails the sweep, not every episode."""
    from sim_tools.batch.metrics import load_callable

    try:
        load_callable(target, str(r.source.resolve().parent))
    except Exception as exc:
        raise r.fail(where, f"cannot import {short(target)}: {type(exc).__name__}: {exc}") from None
    except SystemExit as exc:  # a student's module that exits when imported
        code = short(exc.code)
        raise r.fail(where, f"cannot import {short(target)}: it called sys.exit({code}) when imported") from None


def _unique(r: _Reader, names: list[Any], where: list[str], what: str, hint: str) -> None:
    """Every name once: two rows of one name would be averaged, or share a key, as one."""
    seen: dict[Any, int] = {}
    for k, name in enumerate(names):
        key = repr(name)
        if key in seen:
            first = where[seen[key]]
            raise r.fail(where[k], f"{what} {short(name)} is given twice (also at {first}): {hint}")
        seen[key] = k


def _seeds(r: _Reader, value: Any) -> list[int]:
    if isinstance(value, dict):
        value = r.mapping(value, "seeds", {"count", "start"})
        count = r.integer(value.get("count"), "seeds.count", minimum=1)
        start = r.integer(value.get("start", 0), "seeds.start")
        return list(range(start, start + count))
    seeds = [r.integer(s, f"seeds[{k}]") for k, s in enumerate(r.listing(value, "seeds"))]
    _unique(
        r, seeds, [f"seeds[{k}]" for k in range(len(seeds))], "seed", "each seed once (a seed twice is the same run)"
    )
    return seeds


def _poses(r: _Reader, value: Any, simulator: str) -> list[Any]:
    """Fixed poses, or ("random", count, seed, margin) resolved per world by the adapter's
    ``random_poses`` in the driver (the same list for every engine)."""
    if value is None:
        return [None]
    if world_part(simulator).random_poses is None:
        raise r.fail("poses", f"{simulator} episodes start where their world file puts the robots")
    if isinstance(value, dict):
        value = r.mapping(value, "poses", {"random", "seed", "margin_m"})
        count = r.integer(value.get("random"), "poses.random", minimum=1)
        seed = r.integer(value.get("seed", 0), "poses.seed")
        margin = r.number(value.get("margin_m", 0.05), "poses.margin_m")
        return [("random", count, seed, margin)]
    poses = []
    for k, pose in enumerate(r.listing(value, "poses")):
        if not isinstance(pose, list) or len(pose) != 3:
            raise r.fail(f"poses[{k}]", f"{short(pose)}: expected [x, y, theta] (m, m, rad)")
        poses.append(tuple(r.number(v, f"poses[{k}]") for v in pose))
    _unique(
        r, poses, [f"poses[{k}]" for k in range(len(poses))], "pose", "each pose once (a pose twice is the same run)"
    )
    return poses


def _check_poses(r: _Reader, simulator: str, worlds: list[tuple[str, dict[str, Any]]], poses: list[Any]) -> None:
    """Each fixed start pose inside every world's walls and clear of them (the adapter's
    ``pose_problem``): a robot placed outside the map drives in the void and gives ``ok`` rows."""
    problem_of = getattr(world_part(simulator), "pose_problem", None)
    if problem_of is None:
        return
    for k, pose in enumerate(poses):
        if not isinstance(pose, tuple) or (pose and pose[0] == "random"):
            continue
        for _, world in worlds:
            with warnings.catch_warnings():  # the files' warnings were said already
                warnings.simplefilter("ignore")
                problem = problem_of(world, pose)
            if problem:
                where = shown(world.get("map") or world.get("world_file") or world["label"])
                raise r.fail(f"poses[{k}]", f"{list(pose)}: {problem} of world {short(world['label'])} ({where})")


def _metrics(r: _Reader, value: Any) -> tuple[Any, ...]:
    if value is None:
        return ()
    out: list[str | dict[str, Any]] = []
    for k, entry in enumerate(r.listing(value, "metrics")):
        if isinstance(entry, str):
            out.append(entry)
        elif isinstance(entry, dict) and len(entry) == 1:
            name, options = next(iter(entry.items()))
            out.append({str(name): r.mapping(options, f"metrics[{k}].{name}")})
        else:
            raise r.fail(f"metrics[{k}]", f"{short(entry)}: expected a name, module:function or {{name: {{options}}}}")
    return tuple(out)


def load_sweep(
    path: str | os.PathLike[str],
    out: str | None = None,
    *,
    broken_as_rows: bool = False,
    refused: dict[int, str] | None = None,
    stage: Stage | None = None,
) -> Sweep:
    """Read and expand the sweep file ``path`` (``out`` overrides its output folder).

    Every controller that cannot be imported or built is checked on past, then named in one
    InputError; with ``broken_as_rows`` they are in the sweep's ``broken`` instead (their
    episodes in ``broken_episodes``). ``refused`` (controller index: why) are refused without
    being tried (their check crashed a process before); ``stage`` is told which controller's code
    is about to run."""
    from sim_tools.batch.metrics import check_metrics
    from sim_tools.batch.precheck import check_sweep, check_world_files

    source = Path(path)
    r = _Reader(source)
    data = r.mapping(load_yaml(source, "sweep file"), TOP, TOP_KEYS)
    simulator, worlds = _worlds(r, data)
    raw_controllers = r.listing(_one_or_many(r, data, "controller"), "controllers")
    controllers = [_controller(r, c, f"controllers[{k}]", simulator) for k, c in enumerate(raw_controllers)]
    _unique_names(r, worlds, controllers, raw_controllers, data)
    grid_keys, grid_values = _grid(r, data)
    seeds = _seeds(r, data.get("seeds", [0]))
    pose_specs = _poses(r, data.get("poses"), simulator)
    duration = r.number(data.get("duration_s"), "duration_s", positive=True)
    metrics = _metrics(r, data.get("metrics"))
    search = str(source.resolve().parent)
    check_metrics(simulator, metrics, lambda where, msg: r.fail(where, msg), search)
    for k, entry in enumerate(metrics):
        name = entry if isinstance(entry, str) else next(iter(entry))
        if ":" in name:
            _importable(r, name, f"metrics[{k}]")
    time_limit, memory_limit = _limits(r, data, duration)
    keep = _choice(r, data, "keep_bags", "none", KEEP_BAGS)
    strict = _choice(r, data, "file_warnings", "error", FILE_WARNINGS)
    said = check_world_files(r.fail, worlds, strict == "error")
    _check_poses(r, simulator, worlds, pose_specs)
    tell = stage or (lambda k, label, what: None)
    broken = _unimportable(r, controllers, refused or {}, tell)
    checked = check_sweep(
        r.fail, simulator, worlds, controllers, (grid_keys, grid_values), seeds[0], search, broken, tell
    )
    refusals = [
        Broken(k, controllers[k]["label"], refusal.field, refusal.reason)
        for k, refusal in sorted(checked.broken.items())
    ]
    if refusals and not broken_as_rows:
        raise broken_error(source, refusals, len(controllers))
    template = Episode(0, simulator, {}, {}, {}, None, seeds[0], duration, metrics, search, keep == "all")
    applies = [checked.applies.get(k, grid_keys) for k in range(len(controllers))]
    episodes = _expand(template, worlds, controllers, (grid_keys, checked.grid_values), applies, pose_specs, seeds)
    _no_twins(source, episodes)
    out_dir = _out_dir(source, data, out)
    dead = {b.label for b in refusals}
    return Sweep(
        source,
        [ep for ep in episodes if ep.controller["label"] not in dead],
        keep,
        out_dir,
        grid_keys,
        time_limit_s=time_limit,
        memory_limit_mb=memory_limit,
        warnings=said,
        broken=refusals,
        broken_episodes=[ep for ep in episodes if ep.controller["label"] in dead],
        grid_applies={c["label"]: applies[k] for k, c in enumerate(controllers) if c["label"] not in dead},
    )


def _grid(r: _Reader, data: dict[str, Any]) -> tuple[list[str], list[list[Any]]]:
    """The grid's parameter names and each one's values (each value once)."""
    grid = r.mapping(data.get("grid", {}), "grid")
    grid_keys = [str(k) for k in grid]
    grid_values = [r.listing(grid[k], f"grid.{k}") for k in grid]
    for name, values in zip(grid_keys, grid_values, strict=True):
        where = [f"grid.{name}[{k}]" for k in range(len(values))]
        _unique(r, values, where, "value", "each value once (a value twice is the same run)")
    return grid_keys, grid_values


def _limits(r: _Reader, data: dict[str, Any], duration: float) -> tuple[float, float | None]:
    """An episode's time limit (s) and memory limit (MB, None: none)."""
    time_limit = r.number(data.get("time_limit_s", default_time_limit(duration)), "time_limit_s", positive=True)
    memory = data.get("memory_limit_mb")
    return time_limit, None if memory is None else r.number(memory, "memory_limit_mb", positive=True)


def _choice(r: _Reader, data: dict[str, Any], key: str, default: str, allowed: Sequence[str]) -> str:
    value = data.get(key, default)
    if value not in allowed:
        raise r.fail(key, f"{short(value)}: expected one of {', '.join(allowed)}")
    return str(value)


def _unimportable(
    r: _Reader, controllers: list[dict[str, Any]], refused: dict[int, str], tell: Stage
) -> dict[int, Any]:
    """The controllers refused up front: those ``refused`` names, and each student's module that
    does not import (the next one is tried)."""
    from sim_tools.batch.precheck import Refused

    broken = {k: Refused(f"controllers[{k}]", why) for k, why in refused.items()}
    for k, c in enumerate(controllers):
        if c["kind"] == "user" and k not in broken:
            tell(k, c["label"], "importing it")
            try:
                _importable(r, c["target"], f"controllers[{k}].use")
            except InputError as err:
                broken[k] = Refused(f"controllers[{k}].use", str(err).split(f"field 'controllers[{k}].use': ", 1)[-1])
    return broken


def broken_error(source: Path, refusals: list[Broken], total: int) -> InputError:
    """One error naming every controller that cannot run (one line when there is one)."""
    if len(refusals) == 1:
        return InputError(
            f"{source}: {refusals[0].line()} (fix it, or run with --broken-as-rows to grade it as error rows)"
        )
    hint = "fix them, or run with --broken-as-rows to grade them as error rows"
    lines = [f"{source}: {len(refusals)} of {total} controllers cannot run ({hint}):"]
    return InputError("\n".join(lines + [f"  {b.line()}" for b in refusals]))


def _unique_names(
    r: _Reader,
    worlds: list[tuple[str, dict[str, Any]]],
    controllers: list[dict[str, Any]],
    raw: list[Any],
    data: dict[str, Any],
) -> None:
    """A name per controller and per world: the table, the summary and the plots tell them apart
    by it."""
    wheres = [
        f"controllers[{k}].name" if isinstance(c, dict) and "name" in c else f"controllers[{k}]"
        for k, c in enumerate(raw)
    ]
    hint = (
        "give every controller a name of its own (the table would mix their rows; to run one twice "
        "with other parameters: {name: cautious, use: create_bump_turn, parameters: {...}})"
    )
    _unique(r, [c["label"] for c in controllers], wheres, "name", hint)
    raw_worlds = r.listing(data.get("worlds", data.get("world")), "worlds")
    wheres = [
        f"worlds[{k}].name" if isinstance(w, dict) and "name" in w else f"worlds[{k}]" for k, w in enumerate(raw_worlds)
    ]
    hint = "give every world a name of its own (name: ...); the same world twice would run each episode twice"
    _unique(r, [w["label"] for _, w in worlds], wheres, "name", hint)


def _no_twins(source: Path, episodes: list[Episode]) -> None:
    """No two episodes the same run (one key): the checks above should have said why already."""
    seen: dict[str, int] = {}
    for ep in episodes:
        if ep.key in seen:
            raise InputError(f"{source}: episodes {seen[ep.key]} and {ep.index} are the same run (one key {ep.key})")
        seen[ep.key] = ep.index


def _one_or_many(r: _Reader, data: dict[str, Any], singular: str) -> Any:
    """The value of ``<singular>s`` or ``<singular>`` (missing is an error)."""
    value = data.get(f"{singular}s", data.get(singular))
    if value is None:
        what = "which world(s) to run" if singular == "world" else "which controller(s) drive the robot"
        raise r.fail(f"{singular}s", f"missing: {what}")
    return value


def _worlds(r: _Reader, data: dict[str, Any]) -> tuple[str, list[tuple[str, dict[str, Any]]]]:
    """The sweep's simulator and its worlds (all of that simulator)."""
    for singular in ("world", "controller"):
        if singular in data and f"{singular}s" in data:
            raise r.fail(singular, f"give '{singular}' or '{singular}s', not both")
    raw = _one_or_many(r, data, "world")
    worlds = [_world(r, w, f"worlds[{k}]") for k, w in enumerate(r.listing(raw, "worlds"))]
    simulator = worlds[0][0]
    if any(sim != simulator for sim, _ in worlds):
        raise r.fail("worlds", "all worlds of a sweep must be of one simulator (their metrics differ)")
    return simulator, worlds


def _out_dir(source: Path, data: dict[str, Any], out: str | None) -> Path:
    """``out`` if given, else the sweep's ``out`` (relative to the sweep file), else
    ``out/batch/<sweep file name>``."""
    out_dir = Path(out) if out else Path(data["out"]) if "out" in data else Path("out/batch") / source.stem
    if not out and "out" in data and not out_dir.is_absolute():
        out_dir = source.parent / out_dir
    return out_dir


def _expand(
    template: Episode,
    worlds: list[tuple[str, dict[str, Any]]],
    controllers: list[dict[str, Any]],
    grid: tuple[list[str], list[list[Any]]],
    applies: list[list[str]],
    pose_specs: list[Any],
    seeds: list[int],
) -> list[Episode]:
    """Every episode: worlds × controllers × grid × poses × seeds, numbered in that order; a
    controller runs over the grid parameters it is swept over (``applies``), not once per value
    of one it does not read."""
    import dataclasses

    random_poses = world_part(template.simulator).random_poses
    grid_keys, grid_values = grid
    episodes: list[Episode] = []
    for (_, world), (k, controller) in itertools.product(worlds, enumerate(controllers)):
        keys = [key for key in grid_keys if key in applies[k]]
        values = [grid_values[grid_keys.index(key)] for key in keys]
        poses: list[Any] = []
        for spec in pose_specs:
            if isinstance(spec, tuple) and spec and spec[0] == "random" and random_poses is not None:
                _, count, seed, margin = spec
                poses += random_poses(world, count, seed, margin)
            else:
                poses.append(spec)
        for combo, pose, seed in itertools.product(itertools.product(*values), poses, seeds):
            episodes.append(
                dataclasses.replace(
                    template,
                    index=len(episodes),
                    world=world,
                    controller=controller,
                    params=dict(zip(keys, combo, strict=True)),
                    pose=pose,
                    seed=seed,
                )
            )
    return episodes


def default_time_limit(duration_s: float) -> float:
    """Wall seconds an episode may take unless the sweep says: it runs as fast as the CPU allows,
    so three times its sim time means something is wrong; a minute at least for set-up on a busy
    machine."""
    return max(60.0, 3.0 * duration_s)
