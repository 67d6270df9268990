"""The Map maker's canvas: the map drawn on a snapping grid, and the drawing tools (walls,
multi-segment walls, rectangles, lines, beacons, virtual walls; select and move)."""

from __future__ import annotations

import math

import numpy as np
from nicegui import ui

from studio.create import draw
from studio.create.mapedit import Beacon, Element, MapDocument, Segment, VirtualWall, moved, polyline, rectangle, snap
from studio.shell import svg
from studio.shell.kit import DraftGuard, ZoomableView, view_image

TOOLS = {
    "select": "Select/move",
    "wall": "Wall",
    "multiwall": "Multi-segment wall",
    "rectangle": "Rectangle",
    "line": "Line",
    "beacon": "Beacon",
    "virtwall": "Virtual wall",
}
GRID_STEPS = {0.0: "off", 0.05: "5 cm", 0.1: "10 cm", 0.25: "25 cm", 0.5: "50 cm", 1.0: "1 m"}
PICK_TOLERANCE_PX = 8.0


class MapCanvas(ZoomableView, DraftGuard):
    """The drawing area, the tool choice and its options; the page edits the selection and files
    (:meth:`show_selection`, :meth:`undo`, :meth:`redo`, :meth:`delete`, :meth:`say` are its)."""

    doc: MapDocument
    view: svg.View
    tool = "wall"
    grid = 0.1
    pending: list[tuple[float, float]]  # clicked points of the element being drawn
    cursor: tuple[float, float] | None = None
    selected: int | None = None  # index into ``doc.elements``
    drag_from: tuple[float, float] | None = None

    def build_canvas(self) -> None:
        """The drawing area and its toolbar."""
        self.image = view_image(self.on_mouse, self.on_wheel, "studio-map-view", "#fff")
        self.preview = self.image.add_layer()
        with ui.row().classes("items-center gap-2"):
            ui.select(GRID_STEPS, value=self.grid, label="snap to grid", on_change=self.on_grid).classes("w-32")
            ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
            ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
            ui.button("Fit", on_click=self.fit).props("dense flat")
            self.cursor_label = ui.label("").classes("font-mono text-sm")

    def build_tools(self) -> None:
        """The tool choice, its hint, and the new beacon's and virtual wall's options."""
        ui.toggle(TOOLS, value=self.tool, on_change=self.on_tool).props("dense").classes("studio-tools flex-wrap")
        self.hint = ui.label("").classes("text-sm text-gray-700")
        with ui.row().classes("items-center gap-2"):
            self.beacon_id = ui.input("beacon id", placeholder="b1").classes("w-24")
            self.beacon_colour = ui.color_input("beacon colour", value="#ff8000").classes("w-36")
            self.vwall_setting = ui.select(
                {1: "1 (short)", 2: "2", 3: "3 (long)"}, value=2, label="virtual-wall range"
            ).classes("w-36")

    count_label: ui.label

    def say(self, text: str, error: bool = False) -> None:
        raise NotImplementedError  # the page's file part

    def show_selection(self) -> None:
        raise NotImplementedError  # the page

    def undo(self) -> None:
        raise NotImplementedError  # the page

    def redo(self) -> None:
        raise NotImplementedError  # the page

    def delete(self) -> None:
        raise NotImplementedError  # the page

    # ---------------------------------------------------------------- drawing
    def redraw(self) -> None:
        world = self.doc.to_map()
        parts = [svg.grid_svg(self.view, self.grid or 0.5), draw.map_svg(self.view, world)]
        if self.selected is not None and self.selected < len(self.doc.elements):
            parts.append(self.highlight(self.doc.elements[self.selected]))
        self.image.set_content("".join(parts))
        n = len(self.doc.elements)
        self.count_label.set_text(
            f"{len(world.walls)} walls, {len(world.lines)} lines, {len(world.beacon_ids)} beacons, "
            f"{len(world.virtwalls)} virtual walls ({n} elements)"
        )
        self.beacon_id.props(f'placeholder="{self.doc.next_beacon_id()}"')
        self.draw_preview()
        self.note_draft()

    def highlight(self, element: Element) -> str:
        if isinstance(element, Segment):
            (x1, x2), (y1, y2) = self.view.to_px(np.array([element.x1, element.x2]), np.array([element.y1, element.y2]))
            return (
                f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" '
                'stroke="#ff9800" stroke-width="9" stroke-opacity="0.5"/>'
            )
        px, py = self.view.to_px(element.x, element.y)
        return f'<circle cx="{px:.1f}" cy="{py:.1f}" r="12" fill="none" stroke="#ff9800" stroke-width="4"/>'

    def draw_preview(self) -> None:
        parts = []
        if self.cursor is not None:
            cx, cy = self.view.to_px(*self.cursor)
            parts.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="3" fill="#1565c0"/>')
            if self.pending:
                pts = [*self.pending, self.cursor]
                if self.tool == "rectangle":
                    (x1, y1), (x2, y2) = pts[0], self.cursor
                    pts = [(x1, y1), (x2, y1), (x2, y2), (x1, y2), (x1, y1)]
                xs, ys = self.view.to_px(np.array([p[0] for p in pts]), np.array([p[1] for p in pts]))
                points = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(xs, ys, strict=True))
                parts.append(
                    f'<polyline points="{points}" fill="none" stroke="#1565c0" '
                    'stroke-width="2" stroke-dasharray="5 3"/>'
                )
        self.preview.set_content("".join(parts))

    def view_changed(self) -> None:
        self.redraw()

    def fit(self) -> None:
        w = self.doc.to_map()
        xs = np.concatenate(
            [w.walls[:, 0], w.walls[:, 2], w.lines[:, 0], w.lines[:, 2], w.beacon_xy[:, 0], w.virtwalls[:, 0]]
        )
        ys = np.concatenate(
            [w.walls[:, 1], w.walls[:, 3], w.lines[:, 1], w.lines[:, 3], w.beacon_xy[:, 1], w.virtwalls[:, 1]]
        )
        self.view.fit(xs, ys)
        self.redraw()

    # ---------------------------------------------------------------- tools
    def on_tool(self, e) -> None:
        self.tool = e.value
        self.pending = []
        self.hint.set_text(
            {
                "select": "click an element to select it; drag it to move it; Delete removes it",
                "wall": "click the two ends of the wall",
                "multiwall": "click each corner; Finish (or Enter) ends the wall",
                "rectangle": "click two opposite corners",
                "line": "click the two ends of the painted line",
                "beacon": "click where the beacon goes (id and colour above)",
                "virtwall": "click the emitter, then the direction it faces",
            }[self.tool]
        )
        self.draw_preview()

    def on_grid(self, e) -> None:
        self.grid = float(e.value)
        self.redraw()

    def world_point(self, e) -> tuple[float, float]:
        x, y = self.view.to_world(e.image_x, e.image_y)
        return snap(x, self.grid), snap(y, self.grid)

    def on_mouse(self, e) -> None:
        p = self.world_point(e)
        self.cursor = p
        self.cursor_label.set_text(f"x {p[0]:.3f}  y {p[1]:.3f}")
        if e.type == "mousemove":
            if self.drag_from is not None and self.selected is not None:
                self.preview_move(p)
            else:
                self.draw_preview()
            return
        if e.type == "mouseup":
            if self.drag_from is not None and self.selected is not None:
                dx, dy = p[0] - self.drag_from[0], p[1] - self.drag_from[1]
                if dx or dy:
                    self.doc.replace(self.selected, moved(self.doc.elements[self.selected], dx, dy))
                    self.show_selection()
                    self.redraw()
            self.drag_from = None
            return
        self.click(p, e)

    def preview_move(self, p: tuple[float, float]) -> None:
        if self.drag_from is None or self.selected is None:
            return  # no drag of a selected element under way
        dx, dy = p[0] - self.drag_from[0], p[1] - self.drag_from[1]
        self.preview.set_content(self.highlight(moved(self.doc.elements[self.selected], dx, dy)))

    def click(self, p: tuple[float, float], e) -> None:
        tool = self.tool
        if tool == "select":
            x, y = self.view.to_world(e.image_x, e.image_y)
            self.selected = self.doc.nearest(x, y, PICK_TOLERANCE_PX / self.view.scale)
            self.drag_from = p if self.selected is not None else None
            self.show_selection()
            self.redraw()
            return
        if tool == "beacon":
            beacon_id = (self.beacon_id.value or "").strip() or self.doc.next_beacon_id()
            if len(beacon_id.split()) != 1 or "%" in beacon_id:
                self.say(f"beacon id {beacon_id!r} must be one word without '%'", error=True)
                return
            self.doc.add(Beacon(p[0], p[1], svg.hex_rgb(self.beacon_colour.value or "#ff8000"), beacon_id))
            self.beacon_id.set_value("")
            self.redraw()
            return
        self.pending.append(p)
        if tool == "multiwall" or len(self.pending) < 2:
            self.draw_preview()
            return
        (x1, y1), (x2, y2) = self.pending
        self.pending = []
        if (x1, y1) == (x2, y2):
            self.say("the two points are the same: nothing drawn", error=True)
        elif tool in ("wall", "line"):
            self.doc.add(Segment(tool, x1, y1, x2, y2))
        elif tool == "rectangle":
            if x1 == x2 or y1 == y2:
                self.say("a rectangle needs two opposite corners", error=True)
            else:
                self.doc.add(*rectangle(x1, y1, x2, y2))
        elif tool == "virtwall":
            theta = round(math.atan2(y2 - y1, x2 - x1), 6)
            self.doc.add(VirtualWall(x1, y1, theta, int(self.vwall_setting.value)))
        self.redraw()

    def finish(self) -> None:
        if self.tool == "multiwall" and len(self.pending) >= 2:
            self.doc.add(*polyline(self.pending))
        self.pending = []
        self.redraw()

    def on_key(self, e) -> None:
        if not e.action.keydown:
            return
        name = e.key.name
        if e.modifiers.ctrl and name.lower() == "z":
            self.undo()
        elif e.modifiers.ctrl and name.lower() == "y":
            self.redo()
        elif name in ("Enter", "Escape"):
            self.finish()
        elif name in ("Delete", "Backspace"):
            self.delete()
