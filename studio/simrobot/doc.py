"""The SIMROBOT editor's world in memory (no GUI, no ROS): the obstacle bitmap, the robots as
``simrobot_sim.world_file`` specs, and the conversions to and from the world file and the image.

Robots and sensors are the loader's own frozen :class:`RobotSpec` / :class:`SensorSpec` (edited
with ``dataclasses.replace``), so their defaults and meaning live once, in ``world_file``. What the
editor saves is checked by ``parse_world`` and placed by ``SimrobotWorld`` exactly as
``simrobot_world`` does, so a world that validates here starts there, and errors read the same.
"""

from __future__ import annotations

import io
import math
import os
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from PIL import Image

from sim_runtime.errors import InputError
from simrobot_sim.world_file import (
    DEFAULT_SHAPE,
    MAX_ROBOTS_UINT8,
    RobotSpec,
    SensorSpec,
    WorldSpec,
    load_bitmap,
    parse_world,
)

#: A new blank map: 3 m x 2 m at 1 cm per cell with a wall round the edge.
BLANK_SIZE_M = (3.0, 2.0)
BLANK_RESOLUTION = 0.01
ROBOT_COLOURS = ((1.0, 1.0, 0.0), (0.0, 0.6, 1.0), (1.0, 0.3, 0.3), (0.2, 0.8, 0.2), (0.8, 0.4, 1.0), (1.0, 0.6, 0.0))
"""Colours given to new robots in turn (the first is the original's yellow)."""


def blank_walls(width_m: float, height_m: float, resolution: float) -> np.ndarray:
    """A free map of this size (cells ``walls[x, y]``) with a one-cell wall round its edge."""
    nx, ny = round(width_m / resolution), round(height_m / resolution)
    if not (3 <= nx <= 5000 and 3 <= ny <= 5000):
        raise InputError(f"map of {nx} x {ny} cells: give 3 to 5000 cells a side (size / resolution)")
    walls = np.zeros((nx, ny), dtype=bool)
    walls[[0, -1], :] = True
    walls[:, [0, -1]] = True
    return walls


def map_image(walls: np.ndarray) -> Image.Image:
    """The 1-bit image ``load_bitmap`` reads back as ``walls`` (black = obstacle, top row = highest y)."""
    pixels = np.where(walls[:, ::-1].T, 0, 255).astype(np.uint8)
    return Image.fromarray(pixels, mode="L").convert("1", dither=Image.Dither.NONE)


def png_bytes(walls: np.ndarray) -> bytes:
    out = io.BytesIO()
    map_image(walls).save(out, format="PNG")
    return out.getvalue()


def paint_disc(walls: np.ndarray, cx: float, cy: float, radius_cells: float, obstacle: bool) -> bool:
    """Set (``obstacle``) or clear every cell whose centre is within ``radius_cells`` of cell
    coordinates (cx, cy); whether any cell changed."""
    nx, ny = walls.shape
    r = max(float(radius_cells), 0.5)
    x0, x1 = max(int(math.floor(cx - r)), 0), min(int(math.ceil(cx + r)) + 1, nx)
    y0, y1 = max(int(math.floor(cy - r)), 0), min(int(math.ceil(cy + r)) + 1, ny)
    if x0 >= x1 or y0 >= y1:
        return False
    xs = np.arange(x0, x1)[:, None] + 0.5
    ys = np.arange(y0, y1)[None, :] + 0.5
    inside = (xs - cx) ** 2 + (ys - cy) ** 2 <= r * r
    window = walls[x0:x1, y0:y1]
    changed = bool(np.any(window[inside] != obstacle))
    window[inside] = obstacle
    return changed


def sensor_entry(s: SensorSpec) -> dict[str, Any]:
    """A sensor as the world file writes it (degrees)."""
    return {
        "name": s.name,
        "type": s.kind,
        "position": [float(s.position[0]), float(s.position[1])],
        "axis": math.degrees(s.axis),
        "beamwidth": math.degrees(s.beamwidth),
        "range": float(s.range),
        "resolution": int(s.rays),
    }


def robot_entry(r: RobotSpec, world_dir: Path | None = None) -> dict[str, Any]:
    """A robot as the world file in ``world_dir`` writes it (degrees, the readable wheel keys; its
    algorithm m-file relative to that folder)."""
    entry: dict[str, Any] = {
        "name": r.name,
        "position": [float(r.position[0]), float(r.position[1])],
        "heading": math.degrees(r.heading),
        "color": [float(c) for c in r.color],
        "shape": [[float(x), float(y)] for x, y in r.shape],
        "scale": float(r.scale),
        "power": bool(r.power),
        "wheel_radius": float(r.R),
        "half_track": float(r.la),
        "axle_offset": float(r.lb),
        "sensors": [sensor_entry(s) for s in r.sensors],
    }
    if r.controller:
        entry["controller"] = r.controller
    if r.algorithm:  # an m-file (absolute in the spec): relative to the world file's folder when known
        entry["algorithm"] = r.algorithm if world_dir is None else os.path.relpath(r.algorithm, world_dir)
    if r.memory is not None:
        entry["memory"] = [[float(x) for x in row] for row in r.memory]
    return entry


def new_sensor(name: str, kind: str = "ultrasonic") -> SensorSpec:
    """A sensor with the manual's defaults (front, 60 degrees, 30 rays, 0.30 m)."""
    return SensorSpec(name=name, kind=kind)


#: World file keys the editor shows no field for but writes back as the opened file had them.
KEPT_WORLD_KEYS = ("lockstep_timeout", "history_steps", "sensor_model", "threads")


@dataclass
class WorldDraft:
    """What the editor holds: the bitmap, its geometry and the robots (file order = ids)."""

    walls: np.ndarray = field(default_factory=lambda: blank_walls(*BLANK_SIZE_M, BLANK_RESOLUTION))
    resolution: float = BLANK_RESOLUTION
    origin: tuple[float, float] = (0.0, 0.0)
    dt: float = 0.1
    steps_limit: float = math.inf  # the original's Steps limit (inf: none)
    replay_step_time: float = 0.0  # the original's Step time: least wall seconds per replayed step
    lockstep: bool = False
    robots: list[RobotSpec] = field(default_factory=list)
    # world keys the editor has no fields for (threads, sensor_model, ...), kept from the file opened
    kept: dict[str, Any] = field(default_factory=dict)

    # -- geometry ---------------------------------------------------------------------------
    def size_m(self) -> tuple[float, float]:
        return self.walls.shape[0] * self.resolution, self.walls.shape[1] * self.resolution

    def to_cell(self, x: float, y: float) -> tuple[float, float]:
        """Cell coordinates (continuous) of a world point."""
        return (x - self.origin[0]) / self.resolution, (y - self.origin[1]) / self.resolution

    def paint(self, x: float, y: float, radius_m: float, obstacle: bool) -> bool:
        cx, cy = self.to_cell(x, y)
        return paint_disc(self.walls, cx, cy, radius_m / self.resolution, obstacle)

    # -- robots -----------------------------------------------------------------------------
    def unused_name(self, stem: str, taken: set[str]) -> str:
        n = 1
        while f"{stem}{n}" in taken:
            n += 1
        return f"{stem}{n}"

    def add_robot(self, x: float, y: float) -> RobotSpec:
        name = self.unused_name("r", {r.name for r in self.robots})
        robot = RobotSpec(name=name, position=(x, y), color=ROBOT_COLOURS[len(self.robots) % len(ROBOT_COLOURS)])
        self.robots.append(robot)
        return robot

    def robot_at(self, x: float, y: float, slack_m: float = 0.0, least_m: float = 0.0) -> int | None:
        """Index of the robot nearest (x, y) within its reach (at least ``least_m``) + slack."""
        best, best_d = None, math.inf
        for i, r in enumerate(self.robots):
            reach = max(max(math.hypot(px, py) for px, py in r.shape) * r.scale, least_m)
            d = math.hypot(x - r.position[0], y - r.position[1])
            if d <= reach + slack_m and d < best_d:
                best, best_d = i, d
        return best

    # -- files ------------------------------------------------------------------------------
    def world_data(self, map_ref: str, world_dir: Path | None = None) -> dict[str, Any]:
        """The world file's mapping, with ``map_ref`` as its ``map`` entry (``world_dir``: the
        world file's folder, which algorithm m-files are written relative to)."""
        return {
            "map": map_ref,
            "resolution": float(self.resolution),
            "origin": [float(self.origin[0]), float(self.origin[1])],
            "dt": float(self.dt),
            # the defaults (no limit, no least step time) stay out of the file, as the loader assumes them
            **({"steps_limit": int(self.steps_limit)} if math.isfinite(self.steps_limit) else {}),
            **({"replay_step_time": float(self.replay_step_time)} if self.replay_step_time else {}),
            "lockstep": bool(self.lockstep),
            **self.kept,
            "robots": [robot_entry(r, world_dir) for r in self.robots],
        }

    def world_yaml(self, map_ref: str, world_dir: Path | None = None) -> str:
        return yaml.safe_dump(self.world_data(map_ref, world_dir), sort_keys=False, default_flow_style=None)

    def check(self, source: str) -> WorldSpec:
        """The world as ``simrobot_world`` would load and place it; InputError with its message.

        ``source`` names the world file in the messages (as the command line does)."""
        from simrobot_sim.model import SimrobotWorld

        with tempfile.TemporaryDirectory(prefix="simrobot_check_") as tmp:
            map_path = Path(tmp) / "map.png"
            map_image(self.walls).save(map_path)
            spec = parse_world(self.world_data(str(map_path)), source, Path(tmp))
        if len(spec.robots) > MAX_ROBOTS_UINT8:
            raise InputError(f"{source}: robots: {len(spec.robots)} robots, at most {MAX_ROBOTS_UINT8}")
        SimrobotWorld(spec)  # places every robot: on an obstacle, overlapping, outside the map
        return spec

    @classmethod
    def from_spec(cls, spec: WorldSpec) -> WorldDraft:
        return cls(
            walls=np.array(spec.walls, dtype=bool),
            resolution=float(spec.resolution),
            origin=(float(spec.origin[0]), float(spec.origin[1])),
            dt=float(spec.dt),
            steps_limit=float(spec.steps_limit),
            replay_step_time=float(spec.replay_step_time),
            lockstep=bool(spec.lockstep),
            robots=list(spec.robots),
            kept={
                key: getattr(spec, key)
                for key in KEPT_WORLD_KEYS
                if getattr(spec, key) != getattr(WorldSpec, key)  # only what the file changed
            },
        )

    @classmethod
    def from_image(cls, path: Path, resolution: float = BLANK_RESOLUTION) -> WorldDraft:
        """A draft on the bitmap at ``path``, read by ``simrobot_world``'s loader (same errors)."""
        return cls(walls=load_bitmap(path), resolution=resolution)


def default_shape() -> tuple[tuple[float, float], ...]:
    return DEFAULT_SHAPE


def parse_vertices(text: str) -> tuple[tuple[float, float], ...]:
    """Polygon vertices from ``x, y`` lines (metres); InputError naming the bad line."""
    points = []
    for n, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        parts = line.replace(",", " ").split()
        try:
            if len(parts) != 2:
                raise ValueError
            x, y = float(parts[0]), float(parts[1])
        except ValueError:
            raise InputError(f"shape line {n}: expected 'x, y' in metres, got {line.strip()!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError(f"shape line {n}: {line.strip()!r} is not finite")
        points.append((x, y))
    if len(points) < 3:
        raise InputError(f"shape: at least 3 vertices are needed, got {len(points)}")
    return tuple(points)


def vertices_text(shape: tuple[tuple[float, float], ...]) -> str:
    return "\n".join(f"{x:g}, {y:g}" for x, y in shape)


def rename_sensor(robot: RobotSpec, index: int, name: str) -> RobotSpec:
    sensors = list(robot.sensors)
    sensors[index] = replace(sensors[index], name=name)
    return replace(robot, sensors=tuple(sensors))
