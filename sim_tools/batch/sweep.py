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
  # - {name: cautious, use: create_bump_turn, parameters: {...}, transport: ros}
grid: {threshold: [0.1, 0.2]}   # controller parameters, every combination
poses: {random: 1000, seed: 1, margin_m: 0.05}  # or a list of [x, y, theta] (a simulator with random_poses)
seeds: [0, 1, 2]             # or {count: 5, start: 0}; seeds the world's noise and the controller
duration_s: 60               # sim time per episode
time_limit_s: 180            # wall seconds per episode (default max(60, 3 x duration_s))
memory_limit_mb: 2000        # an episode's process may use this much memory (default: no limit)
metrics: [distance_m, bumps, {goal_time_s: {center: [3, 1], radius_m: 0.4}}, my_metrics:score]
keep_bags: none              # none | all | failures
out: out/batch/my_sweep      # default out/batch/<sweep file name>
```

Paths in the sweep are relative to the sweep file, else to the shipped ``config/``. A bad sweep
raises :class:`InputError` naming the file and the field.
"""

from __future__ import annotations

import itertools
import math
import os
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem, shown
from sim_runtime.paths import config_path
from sim_runtime.yamlfile import load_yaml
from sim_tools.adapters.contract import world_part, world_parts
from sim_tools.batch.plan import Episode, Sweep

__all__ = ["Episode", "Sweep", "default_time_limit", "executable_controllers", "load_sweep", "world_keys"]

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
}
KEEP_BAGS = ("none", "all", "failures")
TOP = "(top level)"
TRANSPORTS = ("auto", "direct", "ros")


class _Reader:
    """Field-by-field checks with one-line errors naming the file and the field."""

    def __init__(self, source: Path) -> None:
        self.source = source

    def fail(self, where: str, message: str) -> InputError:
        return InputError(f"{self.source}: field '{where}': {message}")

    def number(self, value: Any, where: str, *, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise self.fail(where, f"{value!r} is not a finite number")
        if positive and value <= 0:
            raise self.fail(where, f"{value!r} must be > 0")
        return float(value)

    def integer(self, value: Any, where: str, *, minimum: int = 0) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.fail(where, f"{value!r} must be a whole number >= {minimum}")
        return int(value)

    def mapping(self, value: Any, where: str, allowed: set[str] | None = None) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a mapping, got {value!r}")
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
            raise self.fail(where, f"{value!r} is not a file path")
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
        raise r.fail(f"{where}.use", f"{use!r}: expected an executable ({', '.join(ours)}) or module:name")
    if use in ours:
        needs, target = ours[use]
        if needs != simulator:
            raise r.fail(where, f"{use} drives {needs} worlds, not {simulator} ones")
        kind = "ours"
    elif ":" in use:
        target, kind = use, "user"
        _importable(r, use, f"{where}.use")
    else:
        raise r.fail(where, f"{use!r}: not one of our controllers ({', '.join(ours)}) nor module:name")
    transport = entry.get("transport", "auto")
    if transport not in TRANSPORTS:
        raise r.fail(f"{where}.transport", f"{transport!r}: expected one of {', '.join(TRANSPORTS)}")
    parameters = r.mapping(entry.get("parameters", {}), f"{where}.parameters")
    return {
        "label": str(entry.get("name", use)),
        "target": target,
        "kind": kind,
        "parameters": {str(k): v for k, v in parameters.items()},
        "transport": transport,
    }


def _importable(r: _Reader, target: str, where: str) -> None:
    """Import a user's ``module:name`` now, so that a typo fails the sweep, not every episode."""
    from sim_tools.batch.metrics import load_callable

    try:
        load_callable(target, str(r.source.resolve().parent))
    except Exception as exc:
        raise r.fail(where, f"cannot import {target!r}: {type(exc).__name__}: {exc}") from None


def _seeds(r: _Reader, value: Any) -> list[int]:
    if isinstance(value, dict):
        value = r.mapping(value, "seeds", {"count", "start"})
        count = r.integer(value.get("count"), "seeds.count", minimum=1)
        start = r.integer(value.get("start", 0), "seeds.start")
        return list(range(start, start + count))
    return [r.integer(s, f"seeds[{k}]") for k, s in enumerate(r.listing(value, "seeds"))]


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
            raise r.fail(f"poses[{k}]", f"{pose!r}: expected [x, y, theta] (m, m, rad)")
        poses.append(tuple(r.number(v, f"poses[{k}]") for v in pose))
    return poses


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
            raise r.fail(f"metrics[{k}]", f"{entry!r}: expected a name, module:function or {{name: {{options}}}}")
    return tuple(out)


def load_sweep(path: str | os.PathLike[str], out: str | None = None) -> Sweep:
    """Read and expand the sweep file ``path`` (``out`` overrides its output folder)."""
    from sim_tools.batch.metrics import check_metrics

    source = Path(path)
    r = _Reader(source)
    data = r.mapping(load_yaml(source, "sweep file"), TOP, TOP_KEYS)
    simulator, worlds = _worlds(r, data)
    controllers = [
        _controller(r, c, f"controllers[{k}]", simulator)
        for k, c in enumerate(r.listing(_one_or_many(r, data, "controller"), "controllers"))
    ]
    grid = r.mapping(data.get("grid", {}), "grid")
    grid_keys = [str(k) for k in grid]
    grid_values = [r.listing(grid[k], f"grid.{k}") for k in grid]
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
    time_limit = r.number(data.get("time_limit_s", default_time_limit(duration)), "time_limit_s", positive=True)
    memory = data.get("memory_limit_mb")
    memory_limit = None if memory is None else r.number(memory, "memory_limit_mb", positive=True)
    keep = data.get("keep_bags", "none")
    if keep not in KEEP_BAGS:
        raise r.fail("keep_bags", f"{keep!r}: expected one of {', '.join(KEEP_BAGS)}")
    from sim_tools.batch.precheck import check_sweep  # builds nodes: after the cheap checks

    grid_values = check_sweep(r.fail, simulator, worlds, controllers, (grid_keys, grid_values), seeds[0], search)
    template = Episode(0, simulator, {}, {}, {}, None, seeds[0], duration, metrics, search, keep == "all")
    episodes = _expand(template, worlds, controllers, (grid_keys, grid_values), pose_specs, seeds)
    out_dir = _out_dir(source, data, out)
    return Sweep(source, episodes, keep, out_dir, grid_keys, time_limit_s=time_limit, memory_limit_mb=memory_limit)


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
    pose_specs: list[Any],
    seeds: list[int],
) -> list[Episode]:
    """Every episode: worlds × controllers × grid × poses × seeds, numbered in that order."""
    import dataclasses

    random_poses = world_part(template.simulator).random_poses
    grid_keys, grid_values = grid
    episodes: list[Episode] = []
    for (_, world), controller, combo in itertools.product(worlds, controllers, itertools.product(*grid_values)):
        poses: list[Any] = []
        for spec in pose_specs:
            if isinstance(spec, tuple) and spec and spec[0] == "random" and random_poses is not None:
                _, count, seed, margin = spec
                poses += random_poses(world, count, seed, margin)
            else:
                poses.append(spec)
        for pose, seed in itertools.product(poses, seeds):
            episodes.append(
                dataclasses.replace(
                    template,
                    index=len(episodes),
                    world=world,
                    controller=controller,
                    params=dict(zip(grid_keys, combo, strict=True)),
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
