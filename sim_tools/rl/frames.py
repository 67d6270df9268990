"""The learning envs' frames: a top view drawn with Pillow in a few milliseconds (the track
pictures' matplotlib took ~90 ms a frame), and a window to show them in (``render_mode="human"``).

:class:`TopView` draws onto a background made once (the floor, walls, painted lines): the track,
the goal region, sensor rays, then each robot as its body with a heading line, its bumpers red
while pressed and its body red on a collision. :class:`FrameWindow` shows frames in a Tk window
(tkinter, in the standard library) at the env's ``render_fps``; it needs a display.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sim_runtime.errors import InputError

RGB = tuple[int, int, int]
FLOOR: RGB = (255, 255, 255)
WALL: RGB = (20, 20, 20)
PAINT: RGB = (190, 190, 190)
TRACK: RGB = (25, 100, 230)
GOAL_FILL: RGB = (200, 240, 200)
GOAL_EDGE: RGB = (30, 160, 50)
RAY: RGB = (255, 150, 40)
RAY_NONE: RGB = (255, 225, 190)  # a beam with no return, drawn to its range
BODY: RGB = (235, 235, 235)
BODY_HIT: RGB = (255, 120, 120)
EDGE: RGB = (0, 0, 0)
BUMPER: RGB = (220, 0, 0)
#: The frame's longer side (pixels) for a map of any size.
FRAME_PX = 640
MARGIN_PX = 12


def has_display() -> bool:
    """Whether a window can open here (X11 or Wayland)."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def check_render_mode(render_mode: str | None, modes: Sequence[str]) -> str | None:
    """``render_mode`` if the env offers it (InputError naming the choices otherwise); ``"human"``
    needs a display."""
    if render_mode not in (None, *modes):
        raise InputError(f"render_mode {render_mode!r}: None or one of {list(modes)}")
    if render_mode == "human" and not has_display():
        raise InputError("render_mode 'human' needs a display (DISPLAY or WAYLAND_DISPLAY unset): use 'rgb_array'")
    return render_mode


@dataclass
class Robot:
    """One robot as a frame draws it: pose (m, rad), body radius (m), bumpers (left, right) pressed,
    and whether it is colliding."""

    x: float
    y: float
    theta: float
    radius: float
    bumps: tuple[bool, bool] = (False, False)
    hit: bool = False
    #: Rays: (origin x, y, end x, y, returned) in metres.
    rays: list[tuple[float, float, float, float, bool]] = field(default_factory=list)
    #: The body as a polygon ((vertices, 2) m) instead of a circle of ``radius``.
    outline: np.ndarray | None = None
    fill: RGB = BODY


class TopView:
    """Frames of one map: ``segments`` (N, 4) walls and ``lines`` (M, 4) painted lines (m), or an
    occupancy ``image`` (bool, rows along y from the lowest) of ``resolution`` m/cell at ``origin``."""

    def __init__(
        self,
        segments: np.ndarray | None = None,
        lines: np.ndarray | None = None,
        *,
        image: np.ndarray | None = None,
        resolution: float = 0.05,
        origin: Sequence[float] = (0.0, 0.0),
        bounds: tuple[float, float, float, float] | None = None,
    ) -> None:
        segs = np.zeros((0, 4)) if segments is None else np.asarray(segments, dtype=float).reshape(-1, 4)
        paint = np.zeros((0, 4)) if lines is None else np.asarray(lines, dtype=float).reshape(-1, 4)
        if bounds is None:
            bounds = _bounds(segs, paint, image, resolution, origin)
        x0, y0, x1, y1 = bounds
        span = max(x1 - x0, y1 - y0, 1e-3)
        self.ppm = (FRAME_PX - 2 * MARGIN_PX) / span  # pixels per metre
        self.x0, self.y1 = x0, y1
        self.size = (int(round((x1 - x0) * self.ppm)) + 2 * MARGIN_PX, int(round((y1 - y0) * self.ppm)) + 2 * MARGIN_PX)
        self.background = Image.new("RGB", self.size, FLOOR)
        self._font = ImageFont.load_default()
        draw = ImageDraw.Draw(self.background)
        if image is not None:
            self._paste_occupancy(np.asarray(image, dtype=bool), resolution, origin)
        for row in paint:
            draw.line([self.px(row[0], row[1]), self.px(row[2], row[3])], fill=PAINT, width=3)
        for row in segs:
            draw.line([self.px(row[0], row[1]), self.px(row[2], row[3])], fill=WALL, width=3)

    def px(self, x: float, y: float) -> tuple[float, float]:
        """Metres → pixels (y up)."""
        return (MARGIN_PX + (x - self.x0) * self.ppm, MARGIN_PX + (self.y1 - y) * self.ppm)

    def _paste_occupancy(self, occupied: np.ndarray, resolution: float, origin: Sequence[float]) -> None:
        h, w = occupied.shape
        shade = np.where(occupied[::-1], 20, 255).astype(np.uint8)  # image rows top-down
        tile = Image.fromarray(shade, "L").convert("RGB")
        size = (max(1, int(round(w * resolution * self.ppm))), max(1, int(round(h * resolution * self.ppm))))
        left, top = self.px(float(origin[0]), float(origin[1]) + h * resolution)
        self.background.paste(tile.resize(size, Image.Resampling.NEAREST), (int(round(left)), int(round(top))))

    def frame(
        self,
        robots: Sequence[Robot],
        tracks: Sequence[np.ndarray | Sequence[tuple[float, float]]] = (),
        goal: tuple[float, float, float] | None = None,
        text: str = "",
    ) -> np.ndarray:
        """The frame: (height, width, 3) uint8. ``goal``: (x, y, radius) m."""
        image = self.background.copy()
        draw = ImageDraw.Draw(image)
        if goal is not None:
            gx, gy, gr = goal
            (ax, ay), (bx, by) = self.px(gx - gr, gy + gr), self.px(gx + gr, gy - gr)
            draw.ellipse([ax, ay, bx, by], fill=GOAL_FILL, outline=GOAL_EDGE, width=2)
        for track in tracks:
            xy = np.asarray(track, dtype=float).reshape(-1, 2)
            if len(xy) > 1:
                cols = MARGIN_PX + (xy[:, 0] - self.x0) * self.ppm
                rows = MARGIN_PX + (self.y1 - xy[:, 1]) * self.ppm
                draw.line(np.column_stack([cols, rows]).ravel().tolist(), fill=TRACK, width=2)
        for robot in robots:
            self._robot(draw, robot)
        if text:
            draw.text((MARGIN_PX + 2, 1), text, fill=EDGE, font=self._font)
        return np.asarray(image)

    def _robot(self, draw: ImageDraw.ImageDraw, robot: Robot) -> None:
        for ox, oy, ex, ey, returned in robot.rays:
            draw.line([self.px(ox, oy), self.px(ex, ey)], fill=RAY if returned else RAY_NONE, width=1)
        r = robot.radius
        fill = BODY_HIT if robot.hit else robot.fill
        c, s = math.cos(robot.theta), math.sin(robot.theta)
        if robot.outline is not None:
            draw.polygon([self.px(float(x), float(y)) for x, y in robot.outline], fill=fill, outline=EDGE, width=1)
            draw.line([self.px(robot.x, robot.y), self.px(robot.x + r * c, robot.y + r * s)], fill=EDGE, width=2)
            return
        (ax, ay), (bx, by) = self.px(robot.x - r, robot.y + r), self.px(robot.x + r, robot.y - r)
        box = [ax, ay, bx, by]
        draw.ellipse(box, fill=fill, outline=EDGE, width=2)
        # the bumpers: the front half of the rim, left and right of the heading (screen angles run clockwise)
        heading = -math.degrees(robot.theta)
        left, right = robot.bumps
        for pressed, start, end in ((left, heading - 90.0, heading), (right, heading, heading + 90.0)):
            if pressed:
                draw.arc(box, start, end, fill=BUMPER, width=4)
        draw.line([self.px(robot.x, robot.y), self.px(robot.x + r * c, robot.y + r * s)], fill=EDGE, width=2)


def _bounds(
    segs: np.ndarray, paint: np.ndarray, image: np.ndarray | None, resolution: float, origin: Sequence[float]
) -> tuple[float, float, float, float]:
    xs = np.concatenate([segs[:, [0, 2]].ravel(), paint[:, [0, 2]].ravel()])
    ys = np.concatenate([segs[:, [1, 3]].ravel(), paint[:, [1, 3]].ravel()])
    if image is not None:
        h, w = np.asarray(image).shape
        xs = np.concatenate([xs, [origin[0], origin[0] + w * resolution]])
        ys = np.concatenate([ys, [origin[1], origin[1] + h * resolution]])
    if xs.size == 0:
        return (-1.0, -1.0, 1.0, 1.0)
    return (float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max()))


class FrameWindow:
    """A Tk window showing frames, at most ``fps`` a second (a frame waits for its turn, as
    Gymnasium's human rendering does); opened at the first frame, closed by :meth:`close`."""

    def __init__(self, title: str, fps: float) -> None:
        self.title, self.period_s = title, 1.0 / fps if fps > 0 else 0.0
        self._root: Any = None  # tkinter.Tk, imported at the first frame
        self._label: Any = None
        self._photo: Any = None
        self._last = -math.inf

    def show(self, frame: np.ndarray) -> None:
        import tkinter

        from PIL import ImageTk

        if self._root is None:
            self._root = tkinter.Tk()
            self._root.title(self.title)
            self._label = tkinter.Label(self._root)
            self._label.pack()
        wait = self._last + self.period_s - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        self._photo = ImageTk.PhotoImage(Image.fromarray(frame))
        self._label.configure(image=self._photo)
        self._root.update()
        self._last = time.monotonic()

    def close(self) -> None:
        if self._root is not None:
            self._root.destroy()
            self._root = self._label = self._photo = None
