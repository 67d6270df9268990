"""SIMROBOT world files (YAML) and bitmap maps → validated specs (pure Python, no ROS)."""

from __future__ import annotations

import io
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, UnidentifiedImageError

from sim_runtime.errors import InputError
from sim_runtime.inputfile import read_input_bytes, shown
from sim_runtime.yamlfile import check_keys as _check_keys
from sim_runtime.yamlfile import load_yaml, short_text
from sim_runtime.yamlfile import read_bool as _bool
from sim_runtime.yamlfile import read_number as _number
from sim_runtime.yamlfile import read_pair as _pair
from sim_runtime.yamlfile import short as _brief
from simrobot_sim.spec import ROBOT_ENDPOINTS

#: Grey level (0-255) below which a pixel of an 8-bit/greyscale image is an obstacle.
OBSTACLE_THRESHOLD = 128

#: The original's default robot outline (cells at 1 cm, heading east, pivot at 0,0), in metres.
DEFAULT_SHAPE = ((-0.02, 0.03), (0.0, 0.04), (0.04, 0.0), (0.0, -0.04), (-0.02, -0.03))

#: Most pixels a map image may have (8000 x 8000: 80 m square at the original's 1 cm a cell). A
#: world holds several arrays per cell (the obstacle matrix, the robots' matrix, the sensors'
#: distance fields): about MAP_BYTES_PER_PIXEL bytes a pixel, 2 GB at this limit.
MAX_MAP_PIXELS = 64_000_000
MAP_BYTES_PER_PIXEL = 30

#: Highest robot count whose ids fit the original's uint8 matrix (ids 2-255).
MAX_ROBOTS_UINT8 = 254

#: Most rays one sensor may cast per reading.
MAX_RAYS = 100_000

SENSOR_TYPES = ("ultrasonic", "laser")
#: ``exact``: our sensor model; ``original``: the original SIMROBOT's sensor rules.
SENSOR_MODELS = ("exact", "original")
#: Readable names of the original's robot keys (the short ones stay accepted).
ROBOT_KEY_ALIASES = {"wheel_radius": "R", "half_track": "la", "axle_offset": "lb"}
CONTROLLERS = ("avoid",)


@dataclass(frozen=True)
class SensorSpec:
    """One ray-cast sensor; lengths in metres, angles in radians."""

    name: str
    kind: str
    position: tuple[float, float] = (0.05, 0.0)
    axis: float = 0.0
    beamwidth: float = math.radians(60.0)
    range: float = 0.30
    rays: int = 30


@dataclass(frozen=True)
class RobotSpec:
    """One robot as written in the world file; lengths in metres, heading in radians."""

    name: str
    position: tuple[float, float]
    heading: float = 0.0
    color: tuple[float, float, float] = (1.0, 1.0, 0.0)
    shape: tuple[tuple[float, float], ...] = DEFAULT_SHAPE
    scale: float = 1.0
    power: bool = True
    R: float = 0.01
    la: float = 0.03
    lb: float = 0.0
    sensors: tuple[SensorSpec, ...] = ()
    controller: str | None = None
    #: The original-style algorithm m-file driving this robot (absolute path), run in Octave.
    algorithm: str | None = None
    #: The robot's memory (the original's userdata) when the world starts: rows of numbers its
    #: algorithm reads with readmem (None: empty, [] in the algorithm).
    memory: tuple[tuple[float, ...], ...] | None = None


@dataclass(frozen=True)
class WorldSpec:
    """A loaded world: obstacle matrix ``walls[x, y]`` (x = image column, y = image row counted
    from the bottom), map geometry and robots in file order (robot ``i`` has id ``i + 2``)."""

    walls: np.ndarray
    resolution: float = 0.01
    origin: tuple[float, float] = (0.0, 0.0)
    dt: float = 1.0
    steps_limit: float = math.inf
    #: The original's "step time": the least wall seconds a replay shows each step (the run is not affected).
    replay_step_time: float = 0.0
    lockstep: bool = False
    lockstep_timeout: float = 5.0
    history_steps: int = 10000
    robots: tuple[RobotSpec, ...] = ()
    sensor_model: str = "exact"
    threads: int = 0
    source: str = "<memory>"
    map_path: str = ""


def load_bitmap(path: str | Path, threshold: int = OBSTACLE_THRESHOLD) -> np.ndarray:
    """Read a black-and-white map image into ``walls[x, y]`` (bool, True = obstacle).

    1-bit images (the original's BMP): black is an obstacle. Greyscale (8/16-bit, palette with grey
    entries, or RGB whose three channels are equal): a pixel darker than ``threshold`` (of 255) is
    an obstacle. Colour images are refused (say which colour means wall by converting first).
    The image's top row is the map's highest y, its left column x = 0 (the original's orientation).
    """
    path = Path(path)
    data = read_input_bytes(path, "map image")
    try:
        img: Image.Image  # a file as opened, then maybe a converted copy
        with _open_image(path, data) as img:
            img.load()
            mode = img.mode
            if mode == "P":
                img = img.convert("RGBA" if "transparency" in img.info else "RGB")
                mode = img.mode
            if mode == "1":
                grey = np.asarray(img, dtype=np.uint8) * 255
            elif mode in ("L", "LA"):
                grey = np.asarray(img.getchannel("L"), dtype=np.uint8)
            elif mode in ("I;16", "I;16B", "I;16L", "I"):
                raw = np.asarray(img, dtype=np.float64)
                grey = np.clip(raw / (65535.0 if raw.max() > 255 else 255.0) * 255.0, 0, 255).astype(np.uint8)
            elif mode in ("RGB", "RGBA"):
                rgb = np.asarray(img.convert("RGB"), dtype=np.int16)
                if np.any(rgb[..., 0] != rgb[..., 1]) or np.any(rgb[..., 1] != rgb[..., 2]):
                    raise InputError.at(
                        shown(path), None, f"colour image ({mode}): maps must be black and white or greyscale"
                    )
                grey = rgb[..., 0].astype(np.uint8)
            else:
                raise InputError.at(
                    shown(path), None, f"unsupported image mode {_brief(mode)}: use a 1-bit or greyscale PNG/BMP"
                )
    except InputError:
        raise
    except UnidentifiedImageError:  # its message is the repr of our buffer: say what the file should be
        raise InputError.at(
            shown(path),
            None,
            "cannot read map image: the file is not an image; save the map as a 1-bit or greyscale PNG or BMP",
        ) from None
    except Exception as exc:  # PIL raises many types for unreadable files
        raise InputError.at(shown(path), None, f"cannot read map image: {short_text(str(exc), 120)}") from exc
    if grey.ndim != 2 or grey.size == 0:
        raise InputError.at(shown(path), None, f"map image has shape {grey.shape}, expected a 2-D image")
    # image rows run top-down; matrix y runs bottom-up
    return np.ascontiguousarray((grey < threshold)[::-1].T)


def _open_image(path: Path, data: bytes) -> Image.Image:
    """The image of ``data``, its header read and its size checked against MAX_MAP_PIXELS before
    any pixel is decoded (Pillow's own "decompression bomb" check, at a higher count, never
    speaks first)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        try:
            img = Image.open(io.BytesIO(data))
        except Image.DecompressionBombError:
            raise InputError.at(shown(path), None, _too_large(None)) from None
    width, height = img.size
    if width * height > MAX_MAP_PIXELS:
        img.close()
        raise InputError.at(shown(path), None, _too_large(f"{width} x {height} = {width * height}"))
    return img


def _too_large(count: str | None) -> str:
    size = "far more pixels than" if count is None else f"{count} pixels, beyond"
    return (
        f"map image has {size} the limit of {MAX_MAP_PIXELS} "
        f"(about {MAP_BYTES_PER_PIXEL} bytes of memory each; see docs/file_formats.md)"
    )


_SENSOR_KEYS = {"name", "type", "position", "axis", "beamwidth", "range", "rays", "resolution"}
_ROBOT_KEYS = {
    "name",
    "color",
    "shape",
    "scale",
    "position",
    "heading",
    "power",
    "R",
    "la",
    "lb",
    *ROBOT_KEY_ALIASES,
    "sensors",
    "controller",
    "algorithm",
    "memory",
}
_WORLD_KEYS = {
    "map",
    "resolution",
    "origin",
    "dt",
    "steps_limit",
    "replay_step_time",
    "lockstep",
    "lockstep_timeout",
    "history_steps",
    "robots",
    "sensor_model",
    "threads",
}


def _resolve_aliases(entry: dict[str, Any], where: str) -> dict[str, Any]:
    # the readable robot keys stand for the original's short ones; one of each pair at most
    out = dict(entry)
    for long, short in ROBOT_KEY_ALIASES.items():
        if long in out:
            if short in out:
                raise InputError(f"{where}: {_brief(long)} and {_brief(short)} are the same field: give one")
            out[short] = out.pop(long)
    return out


def _sensor(entry: Any, where: str) -> SensorSpec:
    if not isinstance(entry, dict):
        raise InputError(f"{where}: expected a mapping, got {_brief(entry)}")
    _check_keys(entry, _SENSOR_KEYS, where)
    if "name" not in entry or not isinstance(entry["name"], str) or not entry["name"]:
        raise InputError(f"{where}.name: required non-empty string, got {_brief(entry.get('name'))}")
    name = entry["name"]
    if not all(c.isalnum() or c == "_" for c in name) or name[0].isdigit():
        raise InputError(
            f"{where}.name: {_brief(name)} must be a ROS name (letters, digits, _; not starting with a digit)"
        )
    kind = entry.get("type", "ultrasonic")
    if kind not in SENSOR_TYPES:
        raise InputError(f"{where}.type: unknown sensor type {_brief(kind)}; expected one of {', '.join(SENSOR_TYPES)}")
    # ``rays``; ``resolution`` is the original's name for it (a top-level resolution is m per cell)
    if "rays" in entry and "resolution" in entry:
        raise InputError(f"{where}: 'rays' and 'resolution' are the same field: give one")
    rays_key = "resolution" if "resolution" in entry else "rays"
    rays = entry.get(rays_key, 30)
    if isinstance(rays, bool) or not isinstance(rays, int) or not 0 < rays <= MAX_RAYS:
        raise InputError(
            f"{where}.{rays_key}: number of rays must be a positive integer (at most {MAX_RAYS}), got {_brief(rays)}"
        )
    beamwidth = _number(entry.get("beamwidth", 60.0), f"{where}.beamwidth", nonneg=True)
    if beamwidth > 360.0:
        raise InputError(f"{where}.beamwidth: at most 360 degrees, got {_brief(beamwidth)}")
    return SensorSpec(
        name=name,
        kind=kind,
        position=_pair(entry.get("position", [0.05, 0.0]), f"{where}.position"),
        axis=math.radians(_number(entry.get("axis", 0.0), f"{where}.axis")),
        beamwidth=math.radians(beamwidth),
        range=_number(entry.get("range", 0.30), f"{where}.range", positive=True),
        rays=rays,
    )


#: Most numbers a robot's memory may hold in the world file.
MAX_MEMORY_VALUES = 100_000


def read_memory(value: Any, where: str) -> tuple[tuple[float, ...], ...] | None:
    """A robot's memory: a number, a list of numbers (one row) or a list of equal rows."""
    if value is None:
        return None
    rows_in = value if isinstance(value, list) and value and isinstance(value[0], list) else [value]
    rows_in = [row if isinstance(row, list) else [row] for row in rows_in]
    if sum(len(row) for row in rows_in) > MAX_MEMORY_VALUES:
        raise InputError(f"{where}: more than {MAX_MEMORY_VALUES} numbers: keep big data in a file the algorithm loads")
    rows = tuple(tuple(_number(x, f"{where}[{i}][{k}]") for k, x in enumerate(row)) for i, row in enumerate(rows_in))
    if len({len(row) for row in rows}) != 1 or not rows[0]:
        raise InputError(f"{where}: expected a number, a list of numbers or rows of equal length, got {_brief(value)}")
    return rows


def _algorithm(entry: dict[str, Any], where: str, base_dir: Path) -> str | None:
    # an m-file path, relative to the world file; a robot has a controller or an algorithm
    value = entry.get("algorithm")
    if value is None:
        return None
    if not isinstance(value, str) or not value.endswith(".m"):
        raise InputError(f"{where}.algorithm: expected the path of an m-file (e.g. alg2.m), got {_brief(value)}")
    if entry.get("controller") is not None:
        raise InputError(f"{where}: give a controller or an algorithm, not both")
    path = Path(value).expanduser()
    path = path if path.is_absolute() else base_dir / path
    if not path.is_file():
        raise InputError(f"{where}.algorithm: {_brief(str(path))}: no such file")
    return str(path.resolve())


def _robot(entry: Any, where: str, base_dir: Path = Path()) -> RobotSpec:
    if not isinstance(entry, dict):
        raise InputError(f"{where}: expected a mapping, got {_brief(entry)}")
    _check_keys(entry, _ROBOT_KEYS, where)
    # errors name the key as the user wrote it
    key = {short: long for long, short in ROBOT_KEY_ALIASES.items() if long in entry}
    entry = _resolve_aliases(entry, where)
    name = entry.get("name")
    if not isinstance(name, str) or not name or not all(c.isalnum() or c == "_" for c in name) or name[0].isdigit():
        raise InputError(f"{where}.name: required ROS name (letters, digits, _; no leading digit), got {_brief(name)}")
    where = f"{where} ({_brief(name)})"
    if "position" not in entry:
        raise InputError(f"{where}.position: required [x, y] in metres")
    color = entry.get("color", [1.0, 1.0, 0.0])
    if not isinstance(color, (list, tuple)) or len(color) != 3:
        raise InputError(f"{where}.color: expected [r, g, b] in 0-1, got {_brief(color)}")
    rgb = tuple(_number(c, f"{where}.color[{i}]") for i, c in enumerate(color))
    if any(c < 0 or c > 1 for c in rgb):
        raise InputError(f"{where}.color: components must be in 0-1, got {_brief(color)}")
    shape_in = entry.get("shape", [list(p) for p in DEFAULT_SHAPE])
    if not isinstance(shape_in, (list, tuple)) or len(shape_in) < 3:
        raise InputError(
            f"{where}.shape: expected at least 3 [x, y] vertices (metres, pivot at 0,0), got {_brief(shape_in)}"
        )
    shape = tuple(_pair(p, f"{where}.shape[{i}]") for i, p in enumerate(shape_in))
    xs = [p[0] for p in shape]
    ys = [p[1] for p in shape]
    area = 0.5 * abs(sum(xs[i] * ys[(i + 1) % len(xs)] - xs[(i + 1) % len(xs)] * ys[i] for i in range(len(xs))))
    if area <= 0:
        raise InputError(f"{where}.shape: polygon has zero area: {_brief(shape_in)}")
    sensors_in = entry.get("sensors", [])
    if not isinstance(sensors_in, list):
        raise InputError(f"{where}.sensors: expected a list, got {_brief(sensors_in)}")
    sensors = tuple(_sensor(s, f"{where}.sensors[{i}]") for i, s in enumerate(sensors_in))
    seen: set[str] = set()
    for i, s in enumerate(sensors):
        if s.name in seen or s.name in ROBOT_ENDPOINTS:
            raise InputError(f"{where}.sensors[{i}].name: {_brief(s.name)} is used twice or clashes with a robot topic")
        seen.add(s.name)
    controller = entry.get("controller")
    if controller is not None and controller not in CONTROLLERS:
        known = ", ".join(CONTROLLERS)
        raise InputError(f"{where}.controller: unknown controller {_brief(controller)}; expected one of {known}")
    lb = _number(entry.get("lb", 0.0), f"{where}.{key.get('lb', 'lb')}")
    return RobotSpec(
        name=name,
        position=_pair(entry["position"], f"{where}.position"),
        heading=math.radians(_number(entry.get("heading", 0.0), f"{where}.heading")),
        color=rgb,  # type: ignore[arg-type]
        shape=shape,
        scale=_number(entry.get("scale", 1.0), f"{where}.scale", positive=True),
        power=_bool(entry.get("power", True), f"{where}.power"),
        R=_number(entry.get("R", 0.01), f"{where}.{key.get('R', 'R')}", positive=True),
        la=_number(entry.get("la", 0.03), f"{where}.{key.get('la', 'la')}", positive=True),
        lb=lb,
        sensors=sensors,
        controller=controller,
        algorithm=_algorithm(entry, where, base_dir),
        memory=read_memory(entry.get("memory"), f"{where}.memory"),
    )


def parse_world(data: Any, source: str, base_dir: Path) -> WorldSpec:
    """Validate an already-parsed world-file mapping (see :func:`load_world` for the format)."""
    shown_source = shown(source)  # a path of any length, cut for messages
    if not isinstance(data, dict):
        raise InputError(f"{shown_source}: the world file must be a YAML mapping, got {type(data).__name__}")
    _check_keys(data, _WORLD_KEYS, shown_source)
    if "map" not in data or not isinstance(data["map"], str):
        raise InputError(f"{shown_source}: map: required path of a PNG/BMP image, got {_brief(data.get('map'))}")
    map_path = Path(data["map"])
    if not map_path.is_absolute():
        map_path = base_dir / map_path
    try:
        walls = load_bitmap(map_path)
    except InputError as error:  # the image's own error, said to be the map field's
        raise InputError(f"{shown_source}: map: {error}") from None
    steps = data.get("steps_limit", math.inf)
    if isinstance(steps, str) and steps.strip().lower() in ("inf", ".inf", "infinity"):
        steps = math.inf
    steps = _number(steps, f"{shown_source}: steps_limit", allow_inf=True, limit=None)
    if not steps > 0:
        raise InputError(f"{shown_source}: steps_limit: must be > 0 (or .inf), got {_brief(data.get('steps_limit'))}")
    if math.isfinite(steps):
        steps = float(max(1, math.floor(steps + 0.5)))  # MATLAB round: halves away from zero
    sensor_model = data.get("sensor_model", "exact")
    if sensor_model not in SENSOR_MODELS:
        raise InputError(
            f"{shown_source}: sensor_model: expected one of {', '.join(SENSOR_MODELS)}, got {_brief(sensor_model)}"
        )
    threads = data.get("threads", 0)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 0:
        raise InputError(f"{shown_source}: threads: expected an integer >= 0 (0 = all cores), got {_brief(threads)}")
    history = data.get("history_steps", 10000)
    if isinstance(history, bool) or not isinstance(history, int) or history <= 0:
        raise InputError(f"{shown_source}: history_steps: must be a positive integer, got {_brief(history)}")
    robots_in = data.get("robots", [])
    if not isinstance(robots_in, list) or not robots_in:
        raise InputError(f"{shown_source}: robots: at least one robot is required")
    robots = tuple(_robot(r, f"{shown_source}: robots[{i}]", base_dir) for i, r in enumerate(robots_in))
    resolution = _number(data.get("resolution", 0.01), f"{shown_source}: resolution", positive=True)
    map_size_m = math.hypot(*walls.shape) * resolution
    for i, r in enumerate(robots):
        reach = max(math.hypot(x, y) for x, y in r.shape) * r.scale
        if not reach <= map_size_m:  # also a size that overflowed to inf
            raise InputError(
                f"{shown_source}: robots[{i}] ({_brief(r.name)}).shape: the robot ({reach:.4g} m from its pivot, "
                f"scale {r.scale:g}) is larger than the map ({map_size_m:.4g} m across)"
            )
    names: dict[str, int] = {}
    for i, r in enumerate(robots):
        if r.name in names:
            first = names[r.name]
            raise InputError(
                f"{shown_source}: robots[{i}].name: duplicate robot name {_brief(r.name)} (also robots[{first}])"
            )
        names[r.name] = i
    return WorldSpec(
        walls=walls,
        resolution=resolution,
        origin=_pair(data.get("origin", [0.0, 0.0]), f"{shown_source}: origin"),
        dt=_number(data.get("dt", 1.0), f"{shown_source}: dt", positive=True),
        steps_limit=steps,
        replay_step_time=_number(data.get("replay_step_time", 0.0), f"{shown_source}: replay_step_time", nonneg=True),
        lockstep=_bool(data.get("lockstep", False), f"{shown_source}: lockstep"),
        lockstep_timeout=_number(data.get("lockstep_timeout", 5.0), f"{shown_source}: lockstep_timeout", positive=True),
        history_steps=history,
        robots=robots,
        sensor_model=sensor_model,
        threads=threads,
        source=source,
        map_path=str(map_path),
    )


def load_world(path: str | Path) -> WorldSpec:
    """Load a SIMROBOT world file.

    World file format (YAML; lengths in metres, angles in degrees, wheel speeds in rad/s)::

        map: demo_map.png        # required; 1-bit or greyscale PNG/BMP, relative to this file.
                                 # Black = obstacle; greyscale pixels darker than 128/255 are
                                 # obstacles; colour images are refused. Image top row = max y.
        resolution: 0.01         # metres per map cell (default 0.01: 1 cell = 1 cm, the original)
        origin: [0.0, 0.0]       # world position (m) of the map's lower-left corner
        dt: 1.0                  # seconds per simulation step (default 1.0, the original)
        steps_limit: 300         # > 0, decimals rounded, or .inf (default); the world stops there
        replay_step_time: 0.1    # least wall seconds a replay shows each step (default 0; the run is not affected)
        lockstep: false          # true: step k+1 waits for a command from every powered,
                                 # non-crashed robot (or lockstep_timeout)
        lockstep_timeout: 5.0    # wall seconds to wait before stepping anyway (with a warning)
        history_steps: 10000     # poses kept per robot (oldest dropped beyond this)
        sensor_model: exact      # exact (default) or original: the original SIMROBOT's sensor
                                 # rules (cell-centre distances, 2-cell-wide Bresenham rays, its fan)
        threads: 0               # threads sensing and moving robots; 0 (default) = all cores.
                                 # Results are the same whatever the number.
        robots:                  # ids are 2, 3, ... in this order (the original's matrix values)
          - name: r1             # required, unique, a ROS name: topics live under /r1/
            position: [0.5, 0.5] # required, pivot position (m)
            heading: 0           # degrees, 0 = +x (east), counter-clockwise
            color: [1, 1, 0]     # RGB 0-1 (the original's default: yellow)
            shape: [[-0.02, 0.03], [0, 0.04], [0.04, 0], [0, -0.04], [-0.02, -0.03]]
                                 # polygon (m) around the pivot at 0,0; default = the original's
            scale: 1.0           # multiplies shape and sensor positions (not ranges)
            power: true          # false: the robot does not move until set_power
            wheel_radius: 0.01   # wheel radius (m); or R, the original's name
            half_track: 0.03     # half the wheel distance (m); or la
            axle_offset: 0.0     # pivot offset from the wheel axle (m); or lb
            controller: avoid    # optional: run this controller in the world's process
            algorithm: alg2.m    # or: the original's algorithm m-file (relative to this file),
                                 # run in GNU Octave once per step (see docs/matlab.md)
            memory: [[1, 2], [3, 4]] # the robot's memory at the start (readmem): a number, a row
                                 # or rows of numbers (default: empty)
            sensors:
              - name: sens1      # topic /r1/sens1 (+ /r1/sens1/obstacle for ultrasonic)
                type: ultrasonic # ultrasonic (nearest ray) or laser (every ray)
                position: [0.05, 0]  # on the robot (m; x forward, y left)
                axis: 0          # degrees from the robot's heading
                beamwidth: 60    # degrees; rays spread evenly from -bw/2 to +bw/2
                range: 0.30      # metres, > 0
                rays: 30         # number of rays, > 0 (or resolution, the original's name)

    Every error names the file, the robot (index and name) and the field.
    """
    path = Path(path)
    return parse_world(load_yaml(path, "world file"), str(path), path.parent)
