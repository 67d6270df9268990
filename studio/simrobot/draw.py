"""SVG of SIMROBOT worlds in image pixels (no GUI, no ROS): the bitmap, robots, beams, tracks.

Shared by the editor and the simulator page. The bitmap is one embedded PNG (one element however
large the map); each robot is one polygon and each sensor one path, so hundreds of robots stay a
few hundred elements for the browser.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Sequence

import numpy as np

from simrobot_sim.model import ray_offsets
from simrobot_sim.spec import sensor_mount
from simrobot_sim.world_file import RobotSpec, SensorSpec
from studio.shell.svg import View, rgb_hex
from studio.simrobot.doc import png_bytes

BEAM_COLOUR = "#16a34a"
HIT_COLOUR = "#dc2626"
MAX_DRAWN_RAYS = 60
"""A sensor with more rays is drawn with this many (its fan's shape is the same)."""
MAX_TRACK_POINTS = 200
"""A longer track is thinned to this many points for drawing (whole pixels)."""
MIN_ROBOT_PX = 16.0
"""Least radius (pixels) a robot takes clicks in, and is ringed to when drawn smaller: the
original's 8 cm robot is ~15 pixels across on a fitted 3 m map, too small to hit with a mouse."""


def _int_points(px: np.ndarray, py: np.ndarray) -> str:
    """``x,y,x,y,…`` rounded to whole pixels: one str() per number, fast for long lines."""
    xy = np.rint(np.column_stack([px, py])).astype(np.int64)
    return ",".join(map(str, xy.ravel().tolist()))


def map_data_url(walls: np.ndarray) -> str:
    return "data:image/png;base64," + base64.b64encode(png_bytes(walls)).decode()


def map_svg(view: View, data_url: str, shape: tuple[int, int], resolution: float, origin: Sequence[float]) -> str:
    """The bitmap (a PNG data URL of ``shape`` cells) in its place, with its outline."""
    nx, ny = shape
    x0, y1 = view.to_px(origin[0], origin[1] + ny * resolution)
    w, h = nx * resolution * view.scale, ny * resolution * view.scale
    return (
        f'<image href="{data_url}" x="{float(x0):.1f}" y="{float(y1):.1f}" width="{w:.1f}" height="{h:.1f}" '
        'preserveAspectRatio="none" style="image-rendering:pixelated"/>'
        f'<rect x="{float(x0):.1f}" y="{float(y1):.1f}" width="{w:.1f}" height="{h:.1f}" fill="none" '
        'stroke="#94a3b8" stroke-width="1"/>'
    )


def outline(robot: RobotSpec, pose: Sequence[float]) -> np.ndarray:
    """The robot's polygon (m) at ``pose`` (x, y, heading)."""
    v = np.asarray(robot.shape, dtype=float) * robot.scale
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack([pose[0] + c * v[:, 0] - s * v[:, 1], pose[1] + s * v[:, 0] + c * v[:, 1]])


def reach_m(robot: RobotSpec) -> float:
    """How far the robot's outline reaches from its pivot (m)."""
    return max(math.hypot(x, y) for x, y in robot.shape) * robot.scale


def hit_radius_m(view: View, robot: RobotSpec) -> float:
    """How far from its pivot (m) a click picks the robot: its outline, at least MIN_ROBOT_PX."""
    return max(reach_m(robot), MIN_ROBOT_PX / view.scale)


def robot_svg(
    view: View,
    robot: RobotSpec,
    pose: Sequence[float],
    *,
    selected: bool = False,
    crashed: bool = False,
    label: str = "",
) -> str:
    """One robot: its polygon in its colour, a heading line, a crash cross, its name."""
    poly = outline(robot, pose)
    px, py = view.to_px(poly[:, 0], poly[:, 1])
    points = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(px.tolist(), py.tolist(), strict=True))
    cx, cy = (float(v) for v in view.to_px(pose[0], pose[1]))
    reach = max(float(np.hypot(*(np.asarray(robot.shape) * robot.scale).T).max()) * view.scale, 4.0)
    hx, hy = cx + reach * math.cos(pose[2]), cy - reach * math.sin(pose[2])
    stroke = "#1d4ed8" if selected else "#111"
    parts = []
    if reach < MIN_ROBOT_PX:  # drawn smaller than a click can hit: a ring shows where to click
        parts.append(
            f'<circle class="robot-ring" cx="{cx:.1f}" cy="{cy:.1f}" r="{MIN_ROBOT_PX:.0f}" '
            f'fill="{rgb_hex(robot.color)}" fill-opacity="0.25" stroke="{stroke}" stroke-opacity="0.6" '
            f'stroke-width="{2 if selected else 1}"/>'
        )
    parts += [
        f'<polygon class="robot" data-name="{robot.name}" data-x="{float(pose[0])!r}" data-y="{float(pose[1])!r}" '
        f'points="{points}" fill="{rgb_hex(robot.color)}" '
        f'stroke="{stroke}" stroke-width="{2.5 if selected else 1}"/>',
        f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{hx:.1f}" y2="{hy:.1f}" stroke="#111" stroke-width="1.5"/>',
    ]
    if crashed:
        r = reach * 0.8
        parts.append(
            f'<path class="crash" d="M{cx - r:.1f} {cy - r:.1f}L{cx + r:.1f} {cy + r:.1f}M{cx - r:.1f} {cy + r:.1f}'
            f'L{cx + r:.1f} {cy - r:.1f}" stroke="#dc2626" stroke-width="3"/>'
        )
    if label:
        parts.append(
            f'<text x="{cx + reach + 2:.1f}" y="{cy - reach:.1f}" font-size="11" fill="#334155">{label}</text>'
        )
    return "".join(parts)


def _drawn_offsets(sensor: SensorSpec, sensor_model: str) -> np.ndarray:
    offsets = ray_offsets(sensor.beamwidth, sensor.rays, sensor_model)
    if len(offsets) > MAX_DRAWN_RAYS:
        offsets = offsets[np.linspace(0, len(offsets) - 1, MAX_DRAWN_RAYS).round().astype(int)]
    return offsets


def beams_svg(
    view: View,
    robot: RobotSpec,
    sensor: SensorSpec,
    pose: Sequence[float],
    *,
    ranges: np.ndarray | None = None,
    nearest: float | None = None,
    sensor_model: str = "exact",
    rays_drawn: bool = False,
) -> str:
    """One sensor's rays from its mount on the robot at ``pose``.

    Without readings (the editor's preview) every ray is drawn to the sensor's range. A laser's
    ``ranges`` end each ray at its hit (a red dot); an ultrasonic is drawn as its cone (every ray
    with ``rays_drawn``), its ``nearest`` as a red arc where the nearest ray hit."""
    sx, sy, axis = sensor_mount(robot, sensor)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    ox, oy = pose[0] + c * sx - s * sy, pose[1] + s * sx + c * sy
    all_offsets = ray_offsets(sensor.beamwidth, sensor.rays, sensor_model)
    kind = sensor.kind
    if ranges is not None and len(ranges) == len(all_offsets):
        pick = np.linspace(0, len(all_offsets) - 1, min(len(all_offsets), MAX_DRAWN_RAYS)).round().astype(int)
        offsets, lengths = all_offsets[pick], np.asarray(ranges, dtype=float)[pick]
        hit = np.isfinite(lengths)
        lengths = np.where(hit, lengths, sensor.range)
    else:
        offsets = _drawn_offsets(sensor, sensor_model)
        lengths = np.full(len(offsets), sensor.range)
        hit = np.zeros(len(offsets), dtype=bool)
    angles = pose[2] + axis + offsets
    opx, opy = (float(v) for v in view.to_px(ox, oy))
    if kind == "ultrasonic" and not rays_drawn:
        # a sonar's cone: one wedge (two edges and the arc at its range), not every ray
        lo, hi = float(angles.min()), float(angles.max())
        r_px = sensor.range * view.scale
        ax, ay = opx + r_px * math.cos(lo), opy - r_px * math.sin(lo)
        bx, by = opx + r_px * math.cos(hi), opy - r_px * math.sin(hi)
        large = 1 if hi - lo > math.pi else 0
        d = f"M{opx:.0f} {opy:.0f}L{ax:.0f} {ay:.0f}A{r_px:.0f} {r_px:.0f} 0 {large} 0 {bx:.0f} {by:.0f}Z"
        parts = [
            f'<path class="beam {kind}" data-sensor="{robot.name}/{sensor.name}" d="{d}" stroke="{BEAM_COLOUR}" '
            'stroke-width="0.8" stroke-opacity="0.6" fill="#16a34a" fill-opacity="0.08"/>'
        ]
    else:
        ex, ey = ox + lengths * np.cos(angles), oy + lengths * np.sin(angles)
        epx, epy = view.to_px(ex, ey)
        ends = np.rint(np.column_stack([epx, epy])).astype(np.int64).tolist()
        d = "".join(f"M{opx:.0f} {opy:.0f}L{a} {b}" for a, b in ends)
        parts = [
            f'<path class="beam {kind}" data-sensor="{robot.name}/{sensor.name}" d="{d}" stroke="{BEAM_COLOUR}" '
            'stroke-width="0.8" stroke-opacity="0.6" fill="none"/>'
        ]
    if hit.any():
        epx, epy = view.to_px(ox + lengths * np.cos(angles), oy + lengths * np.sin(angles))
        dots = "".join(f"M{a:.1f} {b:.1f}h0.1" for a, b in zip(epx[hit].tolist(), epy[hit].tolist(), strict=True))
        parts.append(
            f'<path class="hit" d="{dots}" stroke="{HIT_COLOUR}" stroke-width="4" stroke-linecap="round" fill="none"/>'
        )
    if nearest is not None and math.isfinite(nearest) and ranges is None:
        lo, hi = angles.min(), angles.max()
        arc = np.linspace(lo, hi, 12)
        apx, apy = view.to_px(ox + nearest * np.cos(arc), oy + nearest * np.sin(arc))
        points = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(apx.tolist(), apy.tolist(), strict=True))
        parts.append(f'<polyline class="hit" points="{points}" stroke="{HIT_COLOUR}" stroke-width="2.5" fill="none"/>')
    return "".join(parts)


def track_svg(view: View, points: np.ndarray, colour: Sequence[float]) -> str:
    if len(points) < 2:
        return ""
    if len(points) > MAX_TRACK_POINTS:  # the newest points all, older ones thinned
        step = math.ceil(len(points) / MAX_TRACK_POINTS)
        points = np.vstack([points[:-1:step], points[-1:]])
    coords = _int_points(*view.to_px(points[:, 0], points[:, 1]))
    return (
        f'<polyline class="track" points="{coords}" stroke="{rgb_hex(colour)}" stroke-width="1.5" '
        'stroke-opacity="0.8" fill="none"/>'
    )
