"""The Map maker page (the original's MapMakerGUI): draw, select, move, edit, load, save, apply."""

from __future__ import annotations

import warnings

from nicegui import ui

from create_sim.mapfile import parse_map
from sim_runtime.errors import InputError
from studio.create.file_page import FilePage
from studio.create.map_canvas import MapCanvas
from studio.create.mapedit import Beacon, MapDocument, Segment
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, nav
from studio.shell.workspace import MAX_UPLOAD_BYTES, upload_text


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


class MapMakerPage(FilePage, MapCanvas):
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
                self.build_canvas()
            with ui.column().classes("gap-2 w-[430px]"):
                self.build_tools()
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
                    self.uploader = (
                        ui.upload(
                            label="or upload a map file",
                            auto_upload=True,
                            max_file_size=MAX_UPLOAD_BYTES,
                            on_upload=self.upload,
                            on_rejected=lambda: self.refuse_upload(
                                f"upload refused: a map file may be at most {MAX_UPLOAD_BYTES:,} bytes"
                            ),
                        )
                        .props("dense flat")
                        .classes("w-full studio-map-upload")
                    )
                    self.upload_error = ui.label("").classes("text-sm text-red-700 break-all studio-upload-error")
                    self.apply_controls("map")
                self.count_label = ui.label("").classes("text-sm")

    def draft(self) -> object:
        return self.doc.to_map().to_text()

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
            self.refuse_upload(f"error: {err}")
            return
        self.uploader.reset()  # the file is in the editor now, not waiting in the uploader
        self.upload_error.set_text("")
        self.load_text(text, e.file.name)

    def refuse_upload(self, why: str) -> None:
        """A refused upload: the uploader emptied (no thumbnail, no ✓ 100 % beside an error) and
        the reason under it, where the student looks, and on the message line."""
        self.uploader.reset()
        self.upload_error.set_text(why)
        self.say(why, error=True)

    def save(self) -> bool:
        return self.save_text(self.doc.to_map().to_text())

    async def apply_to_world(self) -> None:
        await self.apply_file("map_file", "map")
