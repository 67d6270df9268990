"""What the SIMROBOT editor's parts share: one tab's draft world, its view, tool and selection.

The editor page (:mod:`studio.simrobot.editor_page`) is made of the canvas
(:mod:`~studio.simrobot.editor_canvas`), the robot and sensor forms
(:mod:`~studio.simrobot.editor_form`) and the files and run (:mod:`~studio.simrobot.editor_files`),
each a part of the one page object over this base.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from nicegui import ui

from simrobot_sim.world_file import RobotSpec
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import DraftGuard
from studio.simrobot.doc import WorldDraft
from studio.simrobot.family import SimrobotFamily
from studio.simrobot.fields import Quantity


def field_width(label: str) -> str:
    """A field's width that shows its whole label (a cut "wheel radiu…" says nothing)."""
    return f"width:{max(5.0, 0.55 * len(label) + 1.5):.1f}rem"


def quantity_field(
    q: Quantity, css: str = "", on_change: Callable[..., Any] | None = None, value: float | None = None
) -> ui.number:
    """A number field for ``q``: its label and unit, and a value outside its limits shown in red
    with the sentence saying what to type (the value stays as typed: the check refuses it)."""
    return (
        ui.number(q.label, value=value, format="%g", validation=q.problem, on_change=on_change)
        .props("hide-bottom-space")
        .classes(css)
        .style(field_width(q.label))
    )


class EditorBase(DraftGuard):
    """The state the parts share and the calls they make on one another."""

    studio: Studio
    side: SimrobotFamily
    doc: WorldDraft
    view: svg.View
    selected: int | None  # the robot picked, an index into ``doc.robots``
    sensor: int | None  # the sensor picked, an index into the robot's sensors
    map_dirty: bool  # the bitmap changed since it was last encoded
    map_unsaved: bool
    own_world: str  # the world file this tab opened or saved: Run it may save over it
    message: ui.label
    overwrite: ui.checkbox  # the files' "overwrite": every save of this page obeys it
    filling = False  # while fields are filled from the draft (a selection, a file opened): not edits

    def say(self, text: str, error: bool = False) -> None:
        self.message.set_text(text)
        self.message.classes(replace="simrobot-editor-message text-sm break-all w-[800px] " + (
            "text-red-700" if error else "text-green-800"))  # fmt: skip

    def redraw(self, map_too: bool = False) -> None:
        raise NotImplementedError  # the canvas

    def fit(self) -> None:
        raise NotImplementedError  # the canvas

    def select(self, index: int | None) -> None:
        raise NotImplementedError  # the robot form

    def set_robot(self, robot: RobotSpec) -> None:
        raise NotImplementedError  # the robot form

    def delete_robot(self) -> None:
        raise NotImplementedError  # the robot form

    def form_fields(self) -> None:
        raise NotImplementedError  # the robot form: the shown robot and sensor into the draft, or InputError

    def on_world(self, _e: object = None) -> None:
        raise NotImplementedError  # the files
