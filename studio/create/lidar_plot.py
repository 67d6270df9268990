"""The Read Sensors LIDAR plot: range against beam angle, as the original's Read Sensors drew the
scan in a figure of its own. Pure SVG (no GUI, no ROS): one polyline of every beam."""

from __future__ import annotations

import math

import numpy as np

from create_sim.model import CreateModel
from studio.shell.svg import points

PLOT_SIZE = (400, 220)
"""Pixels of the plot (it sits beside the Read Sensors table, under the view)."""
MARGIN = (34, 8, 16, 22)  # left, top, right, bottom: room for the tick labels
ANGLE_TICKS_DEG = (-120, -60, 0, 60, 120)
RANGE_TOP_M = CreateModel.LIDAR_RANGE[1] * 1.1  # noisy readings can pass the 4 m limit


def plot_area() -> tuple[float, float, float, float]:
    """The axes' box in pixels: left, top, width, height."""
    left, top, right, bottom = MARGIN
    return left, top, PLOT_SIZE[0] - left - right, PLOT_SIZE[1] - top - bottom


def beam_px(angles_rad: np.ndarray, ranges_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels of beams at these angles (0 ahead, left positive: drawn on the right, as a plot of
    angle rising to the right) and ranges; no return (inf, nan) at the top, as far as it sees."""
    left, top, width, height = plot_area()
    span = math.radians(ANGLE_TICKS_DEG[-1] - ANGLE_TICKS_DEG[0])
    shown = np.where(np.isfinite(ranges_m), np.clip(ranges_m, 0.0, RANGE_TOP_M), RANGE_TOP_M)
    px = left + (angles_rad - math.radians(ANGLE_TICKS_DEG[0])) / span * width
    py = top + height * (1.0 - shown / RANGE_TOP_M)
    return px, py


def lidar_plot_svg(scan: tuple[float, float, np.ndarray] | None, stamp: float = 0.0) -> str:
    """The plot of ``scan`` (angle_min, angle_increment, ranges), or its empty axes while there is none."""
    left, top, width, height = plot_area()
    w, h = PLOT_SIZE
    parts = [f'<rect x="{left}" y="{top}" width="{width}" height="{height}" fill="#fff" stroke="#999"/>']
    for deg in ANGLE_TICKS_DEG:
        x = beam_px(np.array([math.radians(deg)]), np.array([0.0]))[0][0]
        parts.append(f'<line x1="{x:.1f}" y1="{top}" x2="{x:.1f}" y2="{top + height}" stroke="#eee"/>')
        parts.append(f'<text x="{x:.1f}" y="{h - 8}" font-size="10" text-anchor="middle">{deg}°</text>')
    for metres in range(int(RANGE_TOP_M) + 1):
        y = top + height * (1.0 - metres / RANGE_TOP_M)
        parts.append(f'<line x1="{left}" y1="{y:.1f}" x2="{left + width}" y2="{y:.1f}" stroke="#eee"/>')
        parts.append(f'<text x="{left - 4}" y="{y + 3:.1f}" font-size="10" text-anchor="end">{metres} m</text>')
    if scan is not None:
        angle_min, increment, ranges = scan
        angles = angle_min + increment * np.arange(len(ranges))
        px, py = beam_px(angles, ranges)
        parts.append(
            f'<polyline class="lidar-ranges" data-stamp="{stamp:.9f}" points="{points(px, py)}" '
            'fill="none" stroke="#d62728" stroke-width="1"/>'
        )
    body = "".join(parts)
    return f'<svg class="studio-lidar-plot" width="{w}" height="{h}" viewBox="0 0 {w} {h}">{body}</svg>'
