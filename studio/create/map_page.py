"""The Map maker page (the original's MapMakerGUI): draw, select, move, edit, load, save, apply."""

from __future__ import annotations

import math
import warnings

import numpy as np
from nicegui import ui

from create_sim.mapfile import parse_map
from sim_runtime.errors import InputError
from studio.create import draw
from studio.create.file_page import FilePage
from studio.create.mapedit import Beacon, MapDocument, Segment, VirtualWall, moved, polyline, rectangle, snap
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, ZoomableView, nav, view_image
from studio.shell.workspace import MAX_UPLOAD_BYTES, upload_text

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


def register(studio: Studio) -> None:
    @ui.page("/map")
    def map_maker_page() -> None:
        MapMakerPage(studio)


def element_label(element) -> str:
    if isinstance(element, Segment):
        return f"{element.kind} ({element.x1:g}, {element.y1:g}) – ({element.x2:g}, {element.y2:g})"
    if isinstance(element, Beacon):
        return f"beacon {element.id} at ({element.x:g}, {element.y:g})"
    return f"virtwall at ({element.x:g}, {element.y:g}) θ {element.theta:.3f} setting {element.setting}"


class MapMakerPage(FilePage, ZoomableView):
    message_class = "studio-map-message"

    def __init__(self, studio: Studio) -> None:
        super().__init__(studio)
        self.doc = MapDocument()
        self.view = svg.View(*VIEW_SIZE, scale=60.0)
        self.tool = "wall"
        self.grid = 0.1
        self.pending: list[tuple[float, float]] = []  # clicked points of the element being drawn
        self.cursor: tuple[float, float] | None = None
        self.selected: int | None = None
        self.drag_from: tuple[float, float] | None = None
        self.build()
        self.guard_drafts()
        self.redraw()

    # ---------------------------------------------------------------- layout
    def build(self) -> None:
        nav("/map")
        ui.keyboard(on_key=self.on_key)
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.image = view_image(self.on_mouse, self.on_wheel, "studio-map-view", "#fff")
                self.preview = self.image.add_layer()
                with ui.row().classes("items-center gap-2"):
                    ui.select(GRID_STEPS, value=self.grid, label="snap to grid", on_change=self.on_grid).classes("w-32")
                    ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
                    ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
                    ui.button("Fit", on_click=self.fit).props("dense flat")
                    self.cursor_label = ui.label("").classes("font-mono text-sm")
            with ui.column().classes("gap-2 w-[430px]"):
                ui.toggle(TOOLS, value=self.tool, on_change=self.on_tool).props("dense").classes(
                    "studio-tools flex-wrap"
                )
                self.hint = ui.label("").classes("text-sm text-gray-700")
                with ui.row().classes("items-center gap-2"):
                    self.beacon_id = ui.input("beacon id", placeholder="b1").classes("w-24")
                    self.beacon_colour = ui.color_input("beacon colour", value="#ff8000").classes("w-36")
                    self.vwall_setting = ui.select(
                        {1: "1 (short)", 2: "2", 3: "3 (long)"}, value=2, label="virtual-wall range"
                    ).classes("w-36")
                with ui.row().classes("gap-1"):
                    ui.button("Undo", on_click=self.undo).props("dense outline").classes("studio-undo")
                    ui.button("Redo", on_click=self.redo).props("dense outline").classes("studio-redo")
                    ui.button("Delete", on_click=self.delete).props("dense outline")
                    ui.button("Clear", on_click=self.clear).props("dense outline color=red")
                    ui.button("Finish", on_click=self.finish).props("dense outline")
                with ui.card().classes("w-full"):
                    ui.label("Selected element").classes("font-bold")
                    self.selection_label = ui.label("none").classes("text-sm")
                    self.edit_fields = ui.input("values (space-separated)").classes("w-full")
                    ui.button("Apply edit", on_click=self.apply_edit).props("dense")
                with ui.card().classes("w-full"):
                    ui.label("File").classes("font-bold")
                    self.file_controls("map file", "my.map", "map", "w-full", lambda: None)
                    ui.upload(
                        label="or upload a map file",
                        auto_upload=True,
                        max_file_size=MAX_UPLOAD_BYTES,
                        on_upload=self.upload,
                        on_rejected=lambda: self.say(
                            f"upload refused: a map file may be at most {MAX_UPLOAD_BYTES:,} bytes", error=True
                        ),
                    ).props("dense flat").classes("w-full")
                    self.apply_controls("map")
                self.count_label = ui.label("").classes("text-sm")

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

    def draft(self) -> object:
        return self.doc.to_map().to_text()

    def highlight(self, element) -> str:
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

    # ---------------------------------------------------------------- editing
    def show_selection(self) -> None:
        if self.selected is None:
            self.selection_label.set_text("none")
            self.edit_fields.set_value("")
            return
        element = self.doc.elements[self.selected]
        self.selection_label.set_text(element_label(element))
        values: tuple[float | int | str, ...]
        if isinstance(element, Segment):
            values = element[1:]
        elif isinstance(element, Beacon):
            values = (element.x, element.y, *element.rgb, element.id)
        else:
            values = tuple(element)
        self.edit_fields.set_value(" ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in values))

    def apply_edit(self) -> None:
        if self.selected is None:
            return
        element = self.doc.elements[self.selected]
        kind = element.kind if isinstance(element, Segment) else "beacon" if isinstance(element, Beacon) else "virtwall"
        values = (self.edit_fields.value or "").split()
        if kind == "beacon" and len(values) == 6:
            row = f"beacon {values[0]} {values[1]} [{' '.join(values[2:5])}] {values[5]}"
        else:
            row = f"{kind} {' '.join(values)}"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                parsed = parse_map(row, "edit")
        except (InputError, UserWarning) as err:
            self.say(str(err), error=True)
            return
        from studio.create.mapedit import elements_from_map

        (new,) = elements_from_map(parsed)
        self.doc.replace(self.selected, new)
        self.show_selection()
        self.redraw()

    def undo(self) -> None:
        self.doc.undo()
        self.selected = None
        self.show_selection()
        self.redraw()

    def redo(self) -> None:
        self.doc.redo()
        self.selected = None
        self.show_selection()
        self.redraw()

    def delete(self) -> None:
        if self.selected is not None:
            self.doc.remove(self.selected)
            self.selected = None
            self.show_selection()
            self.redraw()

    def clear(self) -> None:
        self.doc.clear()
        self.selected = None
        self.show_selection()
        self.redraw()

    # ---------------------------------------------------------------- files
    def load_text(self, text: str, source: str) -> None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                world = parse_map(text, source)
            except InputError as err:
                self.say(f"error: {err}", error=True)
                return
        self.doc.load(world)
        self.selected = None
        self.show_selection()
        self.draft_saved()  # before the redraw: a loaded file is nothing to lose
        self.fit()
        notes = "; ".join(str(w.message) for w in caught)
        self.say(f"loaded {source}" + (f" (warnings: {notes})" if notes else ""), error=bool(notes))

    def load(self) -> None:
        try:
            text, _path = self.studio.workspace.read_text(self.file_name.value or "", "map")
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.load_text(text, self.file_name.value.strip())
        self.own_file = self.file_name.value.strip()

    async def upload(self, e) -> None:
        try:
            text = upload_text(e.file.name, await e.file.read(), "map")
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.load_text(text, e.file.name)

    def save(self) -> bool:
        return self.save_text(self.doc.to_map().to_text())

    async def apply_to_world(self) -> None:
        await self.apply_file("map_file", "map")
