"""SVG drawing of the Create's maps, robot and sensor readings in image pixels, on a
:class:`studio.shell.svg.View` (no GUI, no ROS here): a 681-beam scan is one polyline (one element
for the browser to lay out, not 681).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from html import escape

import numpy as np

from create_sim.mapfile import CreateMap
from create_sim.model import CreateModel
from create_sim.spec import (
    CLIFF_NAMES,
    LINE_RGB,
    RADIUS_M,
    SENSOR_MOUNTS,
    SONAR_NAMES,
    VIRTUAL_WALL_RGBA,
    VWALL_HALO_M,
    WALL_RGB,
    cliff_active,
    hex_colour,
    virtual_wall_field,
)
from studio.shell.svg import View, fmt, points, rgb_hex

# The map in the colours of its ROS markers and Rerun view.
WALL_COLOUR = hex_colour(WALL_RGB)
LINE_COLOUR = hex_colour(LINE_RGB)
VWALL_COLOUR = hex_colour(VIRTUAL_WALL_RGBA)
# The robots and the selected one's sensor layers (the live view draws them in the browser with
# the same values: :func:`live_style`).
ROBOT_SELECTED = "#f0c419"
ROBOT_OTHER = "#d9d9d9"
OUTLINE = "#000"
TRACK_COLOUR = "#8e44ad"
CAMERA_COLOUR = "#f39c12"
LIDAR_COLOUR = "#ff1a1a"
SONAR_COLOUR = "#27ae60"
WALL_IR_COLOUR = "#ff0000"
BUMP_COLOUR = "#ff4fd8"
CLIFF_COLOUR = "#0050ff"


def _segments(view: View, segments: np.ndarray, colour: str, width: float, extra: str = "") -> str:
    if len(segments) == 0:
        return ""
    x1, y1 = view.to_px(segments[:, 0], segments[:, 1])
    x2, y2 = view.to_px(segments[:, 2], segments[:, 3])
    d = " ".join(f"M{a:.1f} {b:.1f}L{c:.1f} {e:.1f}" for a, b, c, e in zip(x1, y1, x2, y2, strict=True))
    return f'<path d="{d}" stroke="{colour}" stroke-width="{width}" stroke-linecap="round" fill="none" {extra}/>'


def virtual_wall_shapes(x: float, y: float, theta: float, setting: int) -> tuple[float, np.ndarray]:
    """Halo radius and field triangle (3, 2) of an emitter, from the Create's spec."""
    return VWALL_HALO_M, virtual_wall_field(x, y, theta, setting)


def map_svg(view: View, world: CreateMap, *, fields: bool = True) -> str:
    """Walls, painted lines, beacons with ids and colours, virtual-wall emitters with halo and field."""
    parts = [
        _segments(view, world.lines, LINE_COLOUR, 3),
        _segments(view, world.walls, WALL_COLOUR, 4),
    ]
    for (bx, by), rgb, beacon_id in zip(world.beacon_xy, world.beacon_rgb, world.beacon_ids, strict=True):
        px, py = view.to_px(bx, by)
        r = max(0.05 * view.scale, 3)
        parts.append(
            f'<circle cx="{fmt(px)}" cy="{fmt(py)}" r="{fmt(r)}" fill="{rgb_hex(rgb)}" stroke="#000" stroke-width="1"/>'
            f'<text x="{fmt(px + r + 2)}" y="{fmt(py - r)}" font-size="12" fill="#000">{escape(beacon_id)}</text>'
        )
    for vx, vy, theta, setting in world.virtwalls:
        halo, tri = virtual_wall_shapes(vx, vy, theta, int(setting))
        px, py = view.to_px(vx, vy)
        parts.append(
            f'<text x="{fmt(px)}" y="{fmt(py + 6)}" font-size="18" text-anchor="middle" fill="{VWALL_COLOUR}">*</text>'
        )
        if fields:
            tx, ty = view.to_px(tri[:, 0], tri[:, 1])
            parts.append(
                f'<circle cx="{fmt(px)}" cy="{fmt(py)}" r="{fmt(halo * view.scale)}" fill="none" '
                f'stroke="{VWALL_COLOUR}" stroke-dasharray="4 3"/>'
                f'<polygon points="{points(tx, ty)}" fill="{VWALL_COLOUR}" fill-opacity="0.06" '
                f'stroke="{VWALL_COLOUR}" stroke-dasharray="4 3"/>'
            )
    return "".join(parts)


def _mount_world(pose: tuple[float, float, float], name: str) -> tuple[float, float, float]:
    """World pose (x, y, yaw) of a sensor mount on a robot at ``pose``."""
    x, y, theta = pose
    m = SENSOR_MOUNTS[name]
    c, s = math.cos(theta), math.sin(theta)
    return x + c * m.x_m - s * m.y_m, y + s * m.x_m + c * m.y_m, theta + m.yaw_rad


def _ray(view: View, start: tuple[float, float, float], length: float, colour: str, width: float = 2) -> str:
    x, y, yaw = start
    ax, ay = view.to_px(x, y)
    bx, by = view.to_px(x + length * math.cos(yaw), y + length * math.sin(yaw))
    return (
        f'<line x1="{fmt(ax)}" y1="{fmt(ay)}" x2="{fmt(bx)}" y2="{fmt(by)}" stroke="{colour}" stroke-width="{width}"/>'
    )


def robot_svg(view: View, pose: tuple[float, float, float], *, selected: bool, label: str = "") -> str:
    """The Create: a disc with a heading line (the selected one filled stronger)."""
    x, y, theta = pose
    px, py = view.to_px(x, y)
    hx, hy = view.to_px(x + RADIUS_M * math.cos(theta), y + RADIUS_M * math.sin(theta))
    fill = ROBOT_SELECTED if selected else ROBOT_OTHER
    text = (
        f'<text x="{fmt(px)}" y="{fmt(py - RADIUS_M * view.scale - 4)}" font-size="12" text-anchor="middle">'
        f"{escape(label)}</text>"
        if label
        else ""
    )
    return (
        f'<circle cx="{fmt(px)}" cy="{fmt(py)}" r="{fmt(RADIUS_M * view.scale)}" fill="{fill}" fill-opacity="0.85" '
        f'stroke="{OUTLINE}" stroke-width="1.5"/>'
        f'<line x1="{fmt(px)}" y1="{fmt(py)}" x2="{fmt(hx)}" y2="{fmt(hy)}" stroke="{OUTLINE}" stroke-width="2"/>{text}'
    )


@dataclass
class Readings:
    """What the view draws for the selected robot (None = not received yet)."""

    pose: tuple[float, float, float]
    scan: tuple[float, float, np.ndarray] | None = None  # angle_min, angle_increment, ranges
    scan_stamp: float = 0.0
    sonar: dict[str, float] | None = None
    wall: bool | None = None
    bumps: tuple[bool, bool] | None = None
    cliffs: dict[str, float] | None = None
    sightings: list[tuple[float, float, str]] | None = None  # camera-frame x, y, id
    track: np.ndarray | None = None  # (n, 2)


def readings_of(robot: object, track: np.ndarray | None) -> Readings:
    """The Readings of anything that keeps a Create's latest readings under the same names (the
    live client's robot state, a replay frame's robot), with ``track`` as the track to draw."""
    names = [f.name for f in fields(Readings) if f.name != "track"]
    return Readings(**{name: getattr(robot, name) for name in names}, track=track)


def sensors_svg(view: View, r: Readings, layers: set[str]) -> str:
    """The selected robot's sensor layers: 'track', 'lidar', 'sonar', 'wall', 'bump', 'cliff', 'camera'."""
    parts = []
    if "track" in layers and r.track is not None and len(r.track) > 1:
        tx, ty = view.to_px(r.track[:, 0], r.track[:, 1])
        parts.append(f'<polyline points="{points(tx, ty)}" fill="none" stroke="{TRACK_COLOUR}" stroke-width="1.5"/>')
    if "camera" in layers:
        cx, cy, cyaw = _mount_world(r.pose, "camera")
        rng, half = CreateModel.CAMERA_RANGE, CreateModel.CAMERA_HALF_FOV
        fx, fy = view.to_px(
            [cx, cx + rng * math.cos(cyaw + half), cx + rng * math.cos(cyaw - half)],
            [cy, cy + rng * math.sin(cyaw + half), cy + rng * math.sin(cyaw - half)],
        )
        parts.append(
            f'<polygon points="{points(fx, fy)}" fill="{CAMERA_COLOUR}" fill-opacity="0.06" '
            f'stroke="{CAMERA_COLOUR}" stroke-opacity="0.5"/>'
        )
        for sx, sy, _id in r.sightings or []:
            wx = cx + sx * math.cos(cyaw) - sy * math.sin(cyaw)
            wy = cy + sx * math.sin(cyaw) + sy * math.cos(cyaw)
            px, py = view.to_px(wx, wy)
            parts.append(
                f'<circle cx="{fmt(px)}" cy="{fmt(py)}" r="{fmt(max(0.12 * view.scale, 6))}" '
                f'fill="none" stroke="{CAMERA_COLOUR}" stroke-width="3"/>'
            )
    if "lidar" in layers and r.scan is not None:
        angle_min, increment, ranges = r.scan
        lx, ly, lyaw = _mount_world(r.pose, "laser")
        angles = lyaw + angle_min + increment * np.arange(len(ranges))
        finite = np.isfinite(ranges)
        d = np.where(finite, ranges, CreateModel.LIDAR_RANGE[1])
        px, py = view.to_px(lx + d * np.cos(angles), ly + d * np.sin(angles))
        parts.append(
            f'<polyline class="lidar" data-stamp="{r.scan_stamp:.9f}" points="{points(px, py)}" fill="none" '
            f'stroke="{LIDAR_COLOUR}" stroke-width="2" stroke-opacity="0.9"/>'
        )
    if "sonar" in layers and r.sonar:
        for name in SONAR_NAMES:
            value = r.sonar.get(name)
            if value is not None:
                length = value if math.isfinite(value) else CreateModel.SONAR_RANGE[1]
                parts.append(_ray(view, _mount_world(r.pose, f"sonar_{name}"), length, SONAR_COLOUR))
    if "wall" in layers and r.wall:
        parts.append(_ray(view, _mount_world(r.pose, "wall_ir"), CreateModel.IR_RANGE, WALL_IR_COLOUR, 4))
    if "bump" in layers and r.bumps:
        for pressed, side in zip(r.bumps, ("left", "right"), strict=True):
            if pressed:
                parts.append(_arc(view, r.pose, SENSOR_MOUNTS[f"bump_{side}"].yaw_rad, BUMP_COLOUR))
    if "cliff" in layers and r.cliffs:
        for name in CLIFF_NAMES:
            signal = r.cliffs.get(name)
            if signal is not None and cliff_active(signal):
                x, y, _ = _mount_world(r.pose, f"cliff_{name}")
                px, py = view.to_px(x, y)
                parts.append(
                    f'<text x="{fmt(px)}" y="{fmt(py + 7)}" font-size="20" text-anchor="middle" '
                    f'fill="{CLIFF_COLOUR}">*</text>'
                )
    return "".join(parts)


def _arc(view: View, pose: tuple[float, float, float], bearing: float, colour: str) -> str:
    """A thick arc on the body's edge, a quarter circle centred on ``bearing`` (a pressed bumper)."""
    x, y, theta = pose
    a = theta + bearing + np.linspace(-math.pi / 4, math.pi / 4, 9)
    r = RADIUS_M * 1.08
    px, py = view.to_px(x + r * np.cos(a), y + r * np.sin(a))
    return f'<polyline class="bump" points="{points(px, py)}" fill="none" stroke="{colour}" stroke-width="5"/>'


# ---------------------------------------------------------------- the live view, drawn in the browser
LIVE_MOUNTS = (
    "camera",
    "laser",
    "wall_ir",
    "bump_left",
    "bump_right",
    *(f"sonar_{name}" for name in SONAR_NAMES),
    *(f"cliff_{name}" for name in CLIFF_NAMES),
)


def live_style(size: tuple[int, int], track_points: int) -> dict:
    """What ``static/sim_view.js`` draws with: the colours and sizes above and the Create's facts
    (radius, sensor mounts and ranges), sent to the page once."""
    return {
        "size": list(size),
        "track_points": track_points,
        "radius": RADIUS_M,
        "mounts": {n: [SENSOR_MOUNTS[n].x_m, SENSOR_MOUNTS[n].y_m, SENSOR_MOUNTS[n].yaw_rad] for n in LIVE_MOUNTS},
        "camera_range": CreateModel.CAMERA_RANGE,
        "camera_half_fov": CreateModel.CAMERA_HALF_FOV,
        "lidar_max": CreateModel.LIDAR_RANGE[1],
        "sonar_max": CreateModel.SONAR_RANGE[1],
        "ir_range": CreateModel.IR_RANGE,
        "sonar_names": list(SONAR_NAMES),
        "cliff_names": list(CLIFF_NAMES),
        "robot_selected": ROBOT_SELECTED,
        "robot_other": ROBOT_OTHER,
        "outline": OUTLINE,
        "track": TRACK_COLOUR,
        "camera": CAMERA_COLOUR,
        "lidar": LIDAR_COLOUR,
        "sonar": SONAR_COLOUR,
        "wall": WALL_IR_COLOUR,
        "bump": BUMP_COLOUR,
        "cliff": CLIFF_COLOUR,
    }


def live_scan(scan: tuple[float, float, np.ndarray], stamp: float) -> list:
    """A scan as the page draws it: [angle_min, increment, ranges in whole mm (-1: nothing in
    range, drawn at the LIDAR's limit), stamp] (a millimetre is a tenth of a pixel at 100 px/m)."""
    angle_min, increment, ranges = scan
    r = np.asarray(ranges, dtype=float)
    mm = np.where(np.isfinite(r), np.round(r * 1000.0), -1.0).astype(np.int64)
    return [float(angle_min), float(increment), mm.tolist(), f"{stamp:.9f}"]


def live_readings(r: Readings) -> dict:
    """The selected robot's readings as the page draws them (no track: it is sent point by point)."""
    return {
        "pose": [float(v) for v in r.pose],
        "sonar": [
            None if (v := (r.sonar or {}).get(n)) is None else (float(v) if math.isfinite(v) else -1.0)
            for n in SONAR_NAMES
        ]
        if r.sonar
        else None,
        "wall": bool(r.wall),
        "bumps": [bool(b) for b in r.bumps] if r.bumps else None,
        "cliffs": [bool(v is not None and cliff_active(v)) for v in (r.cliffs.get(n) for n in CLIFF_NAMES)]
        if r.cliffs
        else None,
        "sightings": [[float(x), float(y)] for x, y, _id in r.sightings or []],
    }
