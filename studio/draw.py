"""SVG drawing of maps, robots and sensor readings in image pixels (no GUI, no ROS here).

A :class:`View` maps world metres (x right, y up) to image pixels (x right, y down). Everything
is drawn in pixels so strokes and text keep their size at any zoom; a 681-beam scan is one
polyline (one element for the browser to lay out, not 681).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, fields
from html import escape

import numpy as np

from create_sim.mapfile import CreateMap
from create_sim.model import CreateModel
from create_sim.spec import CLIFF_NAMES, RADIUS_M, SENSOR_MOUNTS, SONAR_NAMES

WALL_COLOUR = "#222"
LINE_COLOUR = "#2a4fd8"
VWALL_COLOUR = "#12a012"
CLIFF_ACTIVE_BELOW = 0.5 * (CreateModel.CLIFF_FLOOR + CreateModel.CLIFF_LINE)
"""A cliff signal under this (%, halfway between floor and line) means the sensor sees a line."""


@dataclass
class View:
    """World → pixel transform: ``centre`` (m) is drawn at the image centre, ``scale`` px per metre."""

    width_px: int = 800
    height_px: int = 600
    centre_x: float = 0.0
    centre_y: float = 0.0
    scale: float = 80.0

    def to_px(self, x, y):
        """Pixel coordinates of world points (scalars or arrays)."""
        return (
            (np.asarray(x) - self.centre_x) * self.scale + self.width_px / 2,
            self.height_px / 2 - (np.asarray(y) - self.centre_y) * self.scale,
        )

    def to_world(self, px: float, py: float) -> tuple[float, float]:
        """World coordinates of an image pixel."""
        return (
            self.centre_x + (px - self.width_px / 2) / self.scale,
            self.centre_y - (py - self.height_px / 2) / self.scale,
        )

    def zoom(self, factor: float) -> None:
        """Zoom about the image centre, within 5..2000 px/m."""
        self.scale = min(max(self.scale * factor, 5.0), 2000.0)

    def zoom_at(self, px: float, py: float, factor: float) -> None:
        """Zoom keeping the world point under pixel (px, py) where it is (the mouse wheel)."""
        x, y = self.to_world(px, py)
        self.zoom(factor)
        self.centre_x = x - (px - self.width_px / 2) / self.scale
        self.centre_y = y + (py - self.height_px / 2) / self.scale

    def pan(self, centre_at_press: tuple[float, float], dx_px: float, dy_px: float) -> None:
        """Follow a drag of (dx_px, dy_px) pixels begun with the view centred on ``centre_at_press``:
        the world moves with the mouse (image y grows downwards, world y upwards)."""
        self.centre_x = centre_at_press[0] - dx_px / self.scale
        self.centre_y = centre_at_press[1] + dy_px / self.scale

    def fit(self, xs: np.ndarray, ys: np.ndarray, margin_m: float = 0.5) -> None:
        """Centre and scale so that the points (plus a margin) fill the image."""
        if len(xs) == 0:
            return
        lo_x, hi_x, lo_y, hi_y = xs.min() - margin_m, xs.max() + margin_m, ys.min() - margin_m, ys.max() + margin_m
        self.centre_x, self.centre_y = float(lo_x + hi_x) / 2, float(lo_y + hi_y) / 2
        self.scale = float(min(max(min(self.width_px / (hi_x - lo_x), self.height_px / (hi_y - lo_y)), 5.0), 2000.0))


def _f(v: float) -> str:
    return f"{v:.1f}"


def _points(px: np.ndarray, py: np.ndarray) -> str:
    """ "x,y x,y …" with one decimal (a tenth of a pixel is plenty), formatted by numpy in one call."""
    pts = np.column_stack([px, py]).round(1)
    return " ".join(f"{a:g},{b:g}" for a, b in pts.tolist())


def _segments(view: View, segments: np.ndarray, colour: str, width: float, extra: str = "") -> str:
    if len(segments) == 0:
        return ""
    x1, y1 = view.to_px(segments[:, 0], segments[:, 1])
    x2, y2 = view.to_px(segments[:, 2], segments[:, 3])
    d = " ".join(f"M{a:.1f} {b:.1f}L{c:.1f} {e:.1f}" for a, b, c, e in zip(x1, y1, x2, y2, strict=True))
    return f'<path d="{d}" stroke="{colour}" stroke-width="{width}" stroke-linecap="round" fill="none" {extra}/>'


def rgb_hex(rgb: Iterable[float]) -> str:
    """``#rrggbb`` of an rgb triple in 0..1."""
    return "#" + "".join(f"{round(min(max(float(c), 0.0), 1.0) * 255):02x}" for c in rgb)


def hex_rgb(colour: str) -> tuple[float, float, float]:
    """rgb triple in 0..1 (3 decimals) of ``#rrggbb``."""
    colour = colour.lstrip("#")
    return tuple(round(int(colour[i : i + 2], 16) / 255, 3) for i in (0, 2, 4))


def virtual_wall_shapes(x: float, y: float, theta: float, setting: int) -> tuple[float, np.ndarray]:
    """Halo radius and field triangle (3, 2) of an emitter, from the model's constants."""
    length, angle = CreateModel.VWALL_FIELDS[int(setting)]
    tri = [(x, y)] + [
        (x + length * math.cos(theta + s * angle / 2), y + length * math.sin(theta + s * angle / 2)) for s in (1, -1)
    ]
    return CreateModel.VWALL_HALO, np.array(tri)


def grid_svg(view: View, step_m: float) -> str:
    """Light grid lines every ``step_m`` metres, a darker line every metre, and a scale bar."""
    if step_m <= 0 or step_m * view.scale < 4:
        step_m = 1.0
    x0, y1 = view.to_world(0, 0)
    x1, y0 = view.to_world(view.width_px, view.height_px)
    parts = []
    for lo, hi, vertical in ((x0, x1, True), (y0, y1, False)):
        first = math.ceil(lo / step_m)
        for k in range(first, first + int((hi - lo) / step_m) + 1):
            v = k * step_m
            major = abs(v - round(v)) < 1e-9
            colour, width = ("#c8c8c8", 1) if major else ("#ececec", 0.7)
            if vertical:
                p, _ = view.to_px(v, 0.0)
                parts.append(
                    f'<line x1="{_f(p)}" y1="0" x2="{_f(p)}" y2="{view.height_px}" '
                    f'stroke="{colour}" stroke-width="{width}"/>'
                )
            else:
                _, p = view.to_px(0.0, v)
                parts.append(
                    f'<line x1="0" y1="{_f(p)}" x2="{view.width_px}" y2="{_f(p)}" '
                    f'stroke="{colour}" stroke-width="{width}"/>'
                )
    bar = view.scale  # one metre
    y = view.height_px - 12
    parts.append(
        f'<line x1="10" y1="{y}" x2="{_f(10 + bar)}" y2="{y}" stroke="#000" stroke-width="3"/>'
        f'<text x="12" y="{y - 5}" font-size="12" fill="#000">1 m</text>'
    )
    return "".join(parts)


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
            f'<circle cx="{_f(px)}" cy="{_f(py)}" r="{_f(r)}" fill="{rgb_hex(rgb)}" stroke="#000" stroke-width="1"/>'
            f'<text x="{_f(px + r + 2)}" y="{_f(py - r)}" font-size="12" fill="#000">{escape(beacon_id)}</text>'
        )
    for vx, vy, theta, setting in world.virtwalls:
        halo, tri = virtual_wall_shapes(vx, vy, theta, int(setting))
        px, py = view.to_px(vx, vy)
        parts.append(
            f'<text x="{_f(px)}" y="{_f(py + 6)}" font-size="18" text-anchor="middle" fill="{VWALL_COLOUR}">*</text>'
        )
        if fields:
            tx, ty = view.to_px(tri[:, 0], tri[:, 1])
            parts.append(
                f'<circle cx="{_f(px)}" cy="{_f(py)}" r="{_f(halo * view.scale)}" fill="none" '
                f'stroke="{VWALL_COLOUR}" stroke-dasharray="4 3"/>'
                f'<polygon points="{_points(tx, ty)}" fill="{VWALL_COLOUR}" fill-opacity="0.06" '
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
    return f'<line x1="{_f(ax)}" y1="{_f(ay)}" x2="{_f(bx)}" y2="{_f(by)}" stroke="{colour}" stroke-width="{width}"/>'


def robot_svg(view: View, pose: tuple[float, float, float], *, selected: bool, label: str = "") -> str:
    """The Create: a disc with a heading line (the selected one filled stronger)."""
    x, y, theta = pose
    px, py = view.to_px(x, y)
    hx, hy = view.to_px(x + RADIUS_M * math.cos(theta), y + RADIUS_M * math.sin(theta))
    fill = "#f0c419" if selected else "#d9d9d9"
    text = (
        f'<text x="{_f(px)}" y="{_f(py - RADIUS_M * view.scale - 4)}" font-size="12" text-anchor="middle">'
        f"{escape(label)}</text>"
        if label
        else ""
    )
    return (
        f'<circle cx="{_f(px)}" cy="{_f(py)}" r="{_f(RADIUS_M * view.scale)}" fill="{fill}" fill-opacity="0.85" '
        f'stroke="#000" stroke-width="1.5"/>'
        f'<line x1="{_f(px)}" y1="{_f(py)}" x2="{_f(hx)}" y2="{_f(hy)}" stroke="#000" stroke-width="2"/>{text}'
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
        parts.append(f'<polyline points="{_points(tx, ty)}" fill="none" stroke="#8e44ad" stroke-width="1.5"/>')
    if "camera" in layers:
        cx, cy, cyaw = _mount_world(r.pose, "camera")
        rng, half = CreateModel.CAMERA_RANGE, CreateModel.CAMERA_HALF_FOV
        fx, fy = view.to_px(
            [cx, cx + rng * math.cos(cyaw + half), cx + rng * math.cos(cyaw - half)],
            [cy, cy + rng * math.sin(cyaw + half), cy + rng * math.sin(cyaw - half)],
        )
        parts.append(
            f'<polygon points="{_points(fx, fy)}" fill="#f39c12" fill-opacity="0.06" '
            'stroke="#f39c12" stroke-opacity="0.5"/>'
        )
        for sx, sy, _id in r.sightings or []:
            wx = cx + sx * math.cos(cyaw) - sy * math.sin(cyaw)
            wy = cy + sx * math.sin(cyaw) + sy * math.cos(cyaw)
            px, py = view.to_px(wx, wy)
            parts.append(
                f'<circle cx="{_f(px)}" cy="{_f(py)}" r="{_f(max(0.12 * view.scale, 6))}" '
                'fill="none" stroke="#f39c12" stroke-width="3"/>'
            )
    if "lidar" in layers and r.scan is not None:
        angle_min, increment, ranges = r.scan
        lx, ly, lyaw = _mount_world(r.pose, "laser")
        angles = lyaw + angle_min + increment * np.arange(len(ranges))
        finite = np.isfinite(ranges)
        d = np.where(finite, ranges, CreateModel.LIDAR_RANGE[1])
        px, py = view.to_px(lx + d * np.cos(angles), ly + d * np.sin(angles))
        parts.append(
            f'<polyline class="lidar" data-stamp="{r.scan_stamp:.9f}" points="{_points(px, py)}" fill="none" '
            'stroke="#ff1a1a" stroke-width="2" stroke-opacity="0.9"/>'
        )
    if "sonar" in layers and r.sonar:
        for name in SONAR_NAMES:
            value = r.sonar.get(name)
            if value is not None:
                length = value if math.isfinite(value) else CreateModel.SONAR_RANGE[1]
                parts.append(_ray(view, _mount_world(r.pose, f"sonar_{name}"), length, "#27ae60"))
    if "wall" in layers and r.wall:
        parts.append(_ray(view, _mount_world(r.pose, "wall_ir"), CreateModel.IR_RANGE, "#ff0000", 4))
    if "bump" in layers and r.bumps:
        for pressed, side in zip(r.bumps, ("left", "right"), strict=True):
            if pressed:
                parts.append(_arc(view, r.pose, SENSOR_MOUNTS[f"bump_{side}"].yaw_rad, "#ff4fd8"))
    if "cliff" in layers and r.cliffs:
        for name in CLIFF_NAMES:
            signal = r.cliffs.get(name)
            if signal is not None and signal < CLIFF_ACTIVE_BELOW:
                x, y, _ = _mount_world(r.pose, f"cliff_{name}")
                px, py = view.to_px(x, y)
                parts.append(
                    f'<text x="{_f(px)}" y="{_f(py + 7)}" font-size="20" text-anchor="middle" fill="#0050ff">*</text>'
                )
    return "".join(parts)


def _arc(view: View, pose: tuple[float, float, float], bearing: float, colour: str) -> str:
    """A thick arc on the body's edge, a quarter circle centred on ``bearing`` (a pressed bumper)."""
    x, y, theta = pose
    a = theta + bearing + np.linspace(-math.pi / 4, math.pi / 4, 9)
    r = RADIUS_M * 1.08
    px, py = view.to_px(x + r * np.cos(a), y + r * np.sin(a))
    return f'<polyline class="bump" points="{_points(px, py)}" fill="none" stroke="{colour}" stroke-width="5"/>'
