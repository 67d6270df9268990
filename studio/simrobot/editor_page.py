"""The SIMROBOT editor page (the original's Editor window): bitmap, robots, sensors, world file, run.

The world in memory is a :class:`studio.simrobot.doc.WorldDraft`; validation and "Run it" go
through ``simrobot_world``'s own loader and placement, so the page says what the command line says.
The page is made of its canvas, forms and files parts (:mod:`studio.simrobot.editor_base`).
"""

from __future__ import annotations

from nicegui import ui

from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, nav
from studio.simrobot.doc import WorldDraft
from studio.simrobot.editor_canvas import EditorCanvas
from studio.simrobot.editor_files import EditorFiles
from studio.simrobot.editor_form import EditorForm
from studio.simrobot.family import side


def register(studio: Studio) -> None:
    @ui.page("/simrobot/editor")
    def simrobot_editor_page() -> None:
        EditorPage(studio)


class EditorPage(EditorCanvas, EditorForm, EditorFiles):
    """One tab's editor: its own draft world, view, tool and selection."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.side = side(studio)
        self.doc = WorldDraft()
        self.view = svg.View(*VIEW_SIZE, scale=200.0)
        self.tool = "select"
        self.brush_m = 0.03
        self.selected: int | None = None
        self.sensor: int | None = None
        self.drag: tuple[float, float] | None = None  # where the press was (m), while dragging
        self.map_dirty = True  # the bitmap changed since it was last encoded
        self.map_url = ""
        self.map_unsaved = False
        self.filling = False  # while the form is being filled from the selection (no edits)
        self.own_world = ""  # the world file this tab opened or saved: Run it may save over it
        self.build()
        self.guard_drafts()
        self.fit()

    # ---------------------------------------------------------------- layout
    def build(self) -> None:
        nav("/simrobot/editor")
        ui.keyboard(on_key=self.on_key, ignore=["input", "select", "textarea"])
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.build_canvas()
                self.message = ui.label("").classes("simrobot-editor-message text-sm break-all w-[800px]")
            with ui.column().classes("gap-2 w-[460px]"):
                self.build_files()
                self.build_robot()
                self.build_sensors()

    def draft(self) -> object:
        """The world as its file says it, and whether its bitmap has unsaved paint."""
        self.on_world()
        return self.doc.world_yaml("map"), self.map_unsaved
