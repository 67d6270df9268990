"""Drawing in SVG pixels, for every family's views (no GUI, no ROS here).

A :class:`View` maps world metres (x right, y up) to image pixels (x right, y down). Everything
is drawn in pixels so strokes and text keep their size at any zoom.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np


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


def fmt(v: float) -> str:
    return f"{v:.1f}"


def points(px: np.ndarray, py: np.ndarray) -> str:
    """ "x,y x,y …" with one decimal (a tenth of a pixel is plenty), formatted by numpy in one call."""
    pts = np.column_stack([px, py]).round(1)
    return " ".join(f"{a:g},{b:g}" for a, b in pts.tolist())


def rgb_hex(rgb: Iterable[float]) -> str:
    """``#rrggbb`` of an rgb triple in 0..1."""
    return "#" + "".join(f"{round(min(max(float(c), 0.0), 1.0) * 255):02x}" for c in rgb)


def hex_rgb(colour: str) -> tuple[float, float, float]:
    """rgb triple in 0..1 (3 decimals) of ``#rrggbb``."""
    colour = colour.lstrip("#")
    r, g, b = (round(int(colour[i : i + 2], 16) / 255, 3) for i in (0, 2, 4))
    return r, g, b


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
                    f'<line x1="{fmt(p)}" y1="0" x2="{fmt(p)}" y2="{view.height_px}" '
                    f'stroke="{colour}" stroke-width="{width}"/>'
                )
            else:
                _, p = view.to_px(0.0, v)
                parts.append(
                    f'<line x1="0" y1="{fmt(p)}" x2="{view.width_px}" y2="{fmt(p)}" '
                    f'stroke="{colour}" stroke-width="{width}"/>'
                )
    bar = view.scale  # one metre
    y = view.height_px - 12
    parts.append(
        f'<line x1="10" y1="{y}" x2="{fmt(10 + bar)}" y2="{y}" stroke="#000" stroke-width="3"/>'
        f'<text x="12" y="{y - 5}" font-size="12" fill="#000">1 m</text>'
    )
    return "".join(parts)
