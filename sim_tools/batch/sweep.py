"""The sweep file: worlds × controllers × parameter grid × poses × seeds → a list of episodes.

No ROS imports: the driver process reads and expands the sweep; workers get plain episodes.

```yaml
worlds:                      # one or more; all of one simulator
  - {map: create/example.map, config: ""}      # Create: map + noise config ("" = noise-free)
  # - {world_file: simrobot/demo.yaml}          # SIMROBOT
  # - {robot_config: arm/irb120.yaml, targets: [[0.4, 0.0, 0.5], ...]}   # arm
controllers:                 # one or more
  - create_bump_turn                            # an executable of ours
  # - my_pkg.my_node:MyNode                     # a user's rclpy node class (or module:main)
  # - my_pkg.policies:make_controller           # an in-process model controller
  # - {name: cautious, use: create_bump_turn, parameters: {...}, transport: ros}
grid: {threshold: [0.1, 0.2]}   # controller parameters, every combination
poses: {random: 1000, seed: 1, margin_m: 0.05}  # or a list of [x, y, theta] (Create only)
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

import hashlib
import itertools
import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem, shown
from sim_runtime.paths import config_path
from sim_runtime.yamlfile import load_yaml

#: Our executables that can drive an episode, and the node class each one runs.
EXECUTABLE_CONTROLLERS = {
    "create_bump_turn": ("create", "create_sim.bump_turn:BumpTurnNode"),
    "simrobot_avoid": ("simrobot", "simrobot_sim.avoid:AvoidNode"),
    "arm_targets": ("arm", "sim_tools.batch.arm_targets:ArmTargetsNode"),
}
#: Which key of a world entry names which simulator.
WORLD_KEYS = {"map": "create", "world_file": "simrobot", "robot_config": "arm"}
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


@dataclass(frozen=True)
class Episode:
    """One run: everything a worker needs, as plain data (pickles and hashes the same anywhere)."""

    index: int
    simulator: str
    world: dict[str, Any]
    controller: dict[str, Any]
    params: dict[str, Any]
    pose: tuple[float, float, float] | None
    seed: int
    duration_s: float
    metrics: tuple[Any, ...]
    search_path: str
    record_bag: bool = False
    bag_dir: str = ""

    @property
    def key(self) -> str:
        """A digest of what determines the result (not the index): a rerun of an edited sweep
        redoes exactly the episodes whose definition changed."""
        what = asdict(self)
        for volatile in ("index", "record_bag", "bag_dir", "search_path"):
            what.pop(volatile)
        what["controller"].pop("transport")  # how messages travel does not change the result
        if what["controller"]["kind"] == "user":
            # users' nodes run on sim time with seeded random/numpy since this mark: rows logged
            # before it (wall-clock timers, unseeded draws) must not be resumed beside new ones
            what["runs"] = "sim time, seeded"
        return hashlib.sha1(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass
class Sweep:
    """A parsed sweep file."""

    source: Path
    episodes: list[Episode]
    keep_bags: str
    out: Path
    grid_keys: list[str] = field(default_factory=list)
    time_limit_s: float = 60.0
    memory_limit_mb: float | None = None


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


def _world(r: _Reader, entry: Any, where: str) -> tuple[str, dict[str, Any]]:
    entry = r.mapping(entry, where, {"map", "config", "world_file", "robot_config", "targets", "hold_s", "name"})
    kinds = [WORLD_KEYS[k] for k in WORLD_KEYS if k in entry]
    if len(kinds) != 1:
        raise r.fail(where, f"give exactly one of {', '.join(WORLD_KEYS)} (got {sorted(entry)})")
    simulator = kinds[0]
    world: dict[str, Any] = {}
    if simulator == "create":
        world["map"] = r.file(entry["map"], f"{where}.map")
        world["config"] = r.file(entry.get("config", ""), f"{where}.config")
        label = entry.get("name") or Path(entry["map"]).stem
    elif simulator == "simrobot":
        world["world_file"] = r.file(entry["world_file"], f"{where}.world_file")
        label = entry.get("name") or Path(entry["world_file"]).stem
    else:
        world["robot_config"] = r.file(entry["robot_config"], f"{where}.robot_config")
        targets = r.listing(entry.get("targets"), f"{where}.targets")
        checked = []
        for k, target in enumerate(targets):
            if not isinstance(target, list) or len(target) != 3:
                raise r.fail(f"{where}.targets[{k}]", f"{target!r}: expected [x, y, z] (m)")
            checked.append([r.number(v, f"{where}.targets[{k}]") for v in target])
        world["targets"] = checked
        world["hold_s"] = r.number(entry.get("hold_s", 2.0), f"{where}.hold_s", positive=True)
        label = entry.get("name") or Path(entry["robot_config"]).stem
    for key in ("config",) if simulator != "create" else ():
        if key in entry:
            raise r.fail(f"{where}.{key}", "only Create worlds take a noise config")
    if simulator != "arm" and ("targets" in entry or "hold_s" in entry):
        raise r.fail(f"{where}.targets", "only arm worlds take targets")
    world["label"] = str(label)
    return simulator, world


def _controller(r: _Reader, entry: Any, where: str, simulator: str) -> dict[str, Any]:
    if isinstance(entry, str):
        entry = {"use": entry}
    entry = r.mapping(entry, where, {"use", "name", "parameters", "transport"})
    use = entry.get("use")
    if not isinstance(use, str) or not use:
        raise r.fail(
            f"{where}.use", f"{use!r}: expected an executable ({', '.join(EXECUTABLE_CONTROLLERS)}) or module:name"
        )
    if use in EXECUTABLE_CONTROLLERS:
        needs, target = EXECUTABLE_CONTROLLERS[use]
        if needs != simulator:
            raise r.fail(where, f"{use} drives {needs} worlds, not {simulator} ones")
        kind = "ours"
    elif ":" in use:
        target, kind = use, "user"
        _importable(r, use, f"{where}.use")
    else:
        raise r.fail(
            where, f"{use!r}: not one of our controllers ({', '.join(EXECUTABLE_CONTROLLERS)}) nor module:name"
        )
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
    """Fixed poses, or ("random", count, seed, margin) resolved per world by the worker-free
    :func:`random_create_poses` (the same list for every engine)."""
    if value is None:
        return [None]
    if simulator != "create":
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


def random_create_poses(map_file: str, count: int, seed: int, margin_m: float) -> list[tuple[float, float, float]]:
    """``count`` poses drawn uniformly in the walls' bounding box, each at least ``margin_m`` clear
    of every wall (rejection sampling); the same seed gives the same poses on any machine."""
    import numpy as np

    from create_sim.geometry import nearest_distance
    from create_sim.mapfile import CreateMap, load_map
    from create_sim.model import CreateModel

    world = load_map(map_file) if map_file else CreateMap()
    walls = np.asarray(world.walls, dtype=np.float64).reshape(-1, 4)
    if len(walls):
        lo = np.minimum(walls[:, :2].min(axis=0), walls[:, 2:].min(axis=0))
        hi = np.maximum(walls[:, :2].max(axis=0), walls[:, 2:].max(axis=0))
    else:
        lo, hi = np.array([-2.0, -2.0]), np.array([2.0, 2.0])
    rng = np.random.default_rng(seed)
    poses: list[tuple[float, float, float]] = []
    tries = 0
    while len(poses) < count:
        tries += 1
        if tries > 1000 * count:
            raise InputError(f"{map_file}: no room for a robot {margin_m} m clear of the walls")
        x, y = rng.uniform(lo, hi)
        theta = rng.uniform(-math.pi, math.pi)
        if not len(walls) or nearest_distance(walls, float(x), float(y)) - CreateModel.RADIUS >= margin_m:
            poses.append((float(x), float(y), float(theta)))
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
    data = load_yaml(source, "sweep file")
    r = _Reader(source)
    data = r.mapping(data, TOP, TOP_KEYS)
    for singular in ("world", "controller"):
        if singular in data and f"{singular}s" in data:
            raise r.fail(singular, f"give '{singular}' or '{singular}s', not both")
    worlds_raw = data.get("worlds", data.get("world"))
    if worlds_raw is None:
        raise r.fail("worlds", "missing: which world(s) to run")
    worlds = [_world(r, w, f"worlds[{k}]") for k, w in enumerate(r.listing(worlds_raw, "worlds"))]
    simulator = worlds[0][0]
    if any(sim != simulator for sim, _ in worlds):
        raise r.fail("worlds", "all worlds of a sweep must be of one simulator (their metrics differ)")
    controllers_raw = data.get("controllers", data.get("controller"))
    if controllers_raw is None:
        raise r.fail("controllers", "missing: which controller(s) drive the robot")
    controllers = [
        _controller(r, c, f"controllers[{k}]", simulator)
        for k, c in enumerate(r.listing(controllers_raw, "controllers"))
    ]
    grid = r.mapping(data.get("grid", {}), "grid")
    grid_keys = [str(k) for k in grid]
    grid_values = [r.listing(grid[k], f"grid.{k}") for k in grid]
    seeds = _seeds(r, data.get("seeds", [0]))
    pose_specs = _poses(r, data.get("poses"), simulator)
    duration = r.number(data.get("duration_s"), "duration_s", positive=True)
    metrics = _metrics(r, data.get("metrics"))
    check_metrics(simulator, metrics, lambda where, msg: r.fail(where, msg), str(source.resolve().parent))
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

    search = str(source.resolve().parent)
    grid_values = check_sweep(r.fail, simulator, worlds, controllers, (grid_keys, grid_values), seeds[0], search)
    out_dir = Path(out) if out else Path(data["out"]) if "out" in data else Path("out/batch") / source.stem
    if not out and "out" in data and not out_dir.is_absolute():
        out_dir = source.parent / out_dir

    episodes: list[Episode] = []
    for (_, world), controller, combo in itertools.product(worlds, controllers, itertools.product(*grid_values)):
        poses: list[Any] = []
        for spec in pose_specs:
            if isinstance(spec, tuple) and spec and spec[0] == "random":
                _, count, seed, margin = spec
                poses += random_create_poses(world["map"], count, seed, margin)
            else:
                poses.append(spec)
        for pose, seed in itertools.product(poses, seeds):
            episodes.append(
                Episode(
                    index=len(episodes),
                    simulator=simulator,
                    world=world,
                    controller=controller,
                    params=dict(zip(grid_keys, combo, strict=True)),
                    pose=pose,
                    seed=seed,
                    duration_s=duration,
                    metrics=metrics,
                    search_path=str(source.resolve().parent),
                    record_bag=keep == "all",
                )
            )
    return Sweep(
        source=source,
        episodes=episodes,
        keep_bags=keep,
        out=out_dir,
        grid_keys=grid_keys,
        time_limit_s=time_limit,
        memory_limit_mb=memory_limit,
    )


def default_time_limit(duration_s: float) -> float:
    """Wall seconds an episode may take unless the sweep says: it runs as fast as the CPU allows,
    so three times its sim time means something is wrong; a minute at least for set-up on a busy
    machine."""
    return max(60.0, 3.0 * duration_s)
