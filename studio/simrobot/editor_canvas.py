"""The SIMROBOT editor's canvas: the bitmap and robots drawn with their beams; select, move,
rotate and add robots, paint and erase walls, pan and zoom."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from nicegui import ui

from studio.shell.kit import ZoomableView, checked_number, view_image
from studio.simrobot.draw import MIN_ROBOT_PX, beams_svg, map_data_url, map_svg, robot_svg
from studio.simrobot.editor_base import EditorBase

TOOLS = {
    "select": "Select/move",
    "rotate": "Rotate",
    "add": "Add robot",
    "paint": "Paint",
    "erase": "Erase",
    "pan": "Pan",
}


class EditorCanvas(ZoomableView, EditorBase):
    """The drawing area and its mouse tools."""

    tool = "select"
    brush_m = 0.03
    drag: tuple[float, float] | None = None  # where the press was (m), while dragging
    map_url = ""
    pan_from = (0.0, 0.0)  # the view's centre when a pan began

    def build_canvas(self) -> None:
        self.image = view_image(self.on_mouse, self.on_wheel, "simrobot-editor-view", "#fff")
        self.layer = self.image.add_layer()
        with ui.row().classes("items-center gap-2"):
            ui.toggle(TOOLS, value=self.tool, on_change=self.on_tool).props("dense").classes("simrobot-tools")
            checked_number("brush (m)", value=self.brush_m, minimum=0.005, step=0.01, format="%.3f",
                      on_change=self.on_brush).classes("w-24")  # fmt: skip
            ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
            ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
            ui.button("Fit", on_click=self.fit).props("dense flat")
        self.cursor_label = ui.label("").classes("font-mono text-sm")

    # ---------------------------------------------------------------- drawing
    def redraw(self, map_too: bool = False) -> None:
        if map_too or self.map_dirty:
            if self.map_dirty:
                self.map_url = map_data_url(self.doc.walls)
                self.map_dirty = False
            self.image.set_content(
                map_svg(self.view, self.map_url, self.doc.walls.shape, self.doc.resolution, self.doc.origin)
            )
        v = self.view  # the transform, for tests that click at a point in metres
        parts = [
            f'<g class="view" data-centre-x="{v.centre_x!r}" data-centre-y="{v.centre_y!r}" data-scale="{v.scale!r}"/>'
        ]
        for i, robot in enumerate(self.doc.robots):
            pose = (*robot.position, robot.heading)
            for sensor in robot.sensors:
                parts.append(beams_svg(self.view, robot, sensor, pose, rays_drawn=True))
            parts.append(robot_svg(self.view, robot, pose, selected=i == self.selected, label=robot.name))
        self.layer.set_content("".join(parts))
        self.note_draft()

    def fit(self) -> None:
        w, h = self.doc.size_m()
        ox, oy = self.doc.origin
        self.view.fit(np.array([ox, ox + w]), np.array([oy, oy + h]), margin_m=0.05 * max(w, h))
        self.redraw(map_too=True)

    def view_changed(self) -> None:
        self.redraw(map_too=True)

    # ---------------------------------------------------------------- mouse
    def on_tool(self, e) -> None:
        self.tool = e.value

    def on_brush(self, e) -> None:
        if e.value and e.value >= 0.005:  # a smaller brush stays red in its field, unused
            self.brush_m = float(e.value)

    def on_mouse(self, e) -> None:
        x, y = self.view.to_world(e.image_x, e.image_y)
        self.cursor_label.set_text(f"x {x:.3f} m, y {y:.3f} m")
        if e.type == "mousedown":
            self.press(x, y, e.image_x, e.image_y)
        elif e.type == "mousemove" and self.drag is not None:
            self.move(x, y, e.image_x, e.image_y)
        elif e.type == "mouseup":
            if self.drag is not None:
                self.move(x, y, e.image_x, e.image_y)
            self.drag = None

    def press(self, x: float, y: float, px: float, py: float) -> None:
        tool = self.tool
        if tool == "add":
            robot = self.doc.add_robot(x, y)
            self.select(len(self.doc.robots) - 1)
            self.say(f"added {robot.name} at ({x:.3f}, {y:.3f})")
            return
        if tool in ("paint", "erase"):
            self.drag = (x, y)
            self.paint(x, y)
            return
        if tool == "pan":
            self.drag = (px, py)
            self.pan_from = (self.view.centre_x, self.view.centre_y)
            return
        if tool == "rotate" and self.selected is not None:
            self.drag = (x, y)
            self.move(x, y, px, py)
            return
        hit = self.doc.robot_at(x, y, slack_m=4.0 / self.view.scale, least_m=MIN_ROBOT_PX / self.view.scale)
        self.select(hit)
        if hit is not None:
            r = self.doc.robots[hit]
            self.drag = (x - r.position[0], y - r.position[1])  # grab offset

    def move(self, x: float, y: float, px: float, py: float) -> None:
        tool = self.tool
        if tool in ("paint", "erase"):
            self.paint(x, y)
        elif tool == "pan":
            if self.drag is not None:  # the pixel of the press
                self.view.pan(self.pan_from, px - self.drag[0], py - self.drag[1])
                self.redraw(map_too=True)
        elif self.selected is not None:
            r = self.doc.robots[self.selected]
            if tool == "rotate":
                heading = math.atan2(y - r.position[1], x - r.position[0])
                self.set_robot(replace(r, heading=heading))
            elif self.drag is not None:  # the grab offset
                self.set_robot(replace(r, position=(round(x - self.drag[0], 4), round(y - self.drag[1], 4))))

    def paint(self, x: float, y: float) -> None:
        """A brush stroke from the last painted point to here (mouse events come sparse when the
        mouse moves fast: the discs between them fill the gap)."""
        x0, y0 = self.drag if self.drag is not None else (x, y)
        steps = max(1, math.ceil(math.hypot(x - x0, y - y0) / (0.5 * self.brush_m)))
        changed = False
        for k in range(1, steps + 1):
            t = k / steps
            changed |= self.doc.paint(x0 + t * (x - x0), y0 + t * (y - y0), self.brush_m, obstacle=self.tool == "paint")
        self.drag = (x, y)
        if changed:
            self.map_dirty = self.map_unsaved = True
            self.redraw()

    def on_key(self, e) -> None:
        if e.action.keydown and e.key.name in ("Delete", "Backspace"):
            self.delete_robot()
