"""What the map maker and the config maker share: a file in the workspace, a message line, and the
running worlds a saved file can be applied to."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sim_runtime.errors import InputError
from studio.create.family import create_family, create_ros
from studio.shell.app import Studio
from studio.shell.kit import DraftGuard


class FilePage(DraftGuard):
    """Base of a page that edits one workspace file: subclasses set ``message_class``, define
    ``load``, ``save`` and ``apply_to_world`` (usually :meth:`apply_file`), and build their file widgets with
    :meth:`file_controls` and :meth:`apply_controls`."""

    message_class = ""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.own_file = ""  # the workspace file this page last loaded or saved: the one that may be applied

    def load(self) -> None:
        raise NotImplementedError

    def save(self) -> bool:
        raise NotImplementedError

    async def apply_to_world(self) -> None:
        raise NotImplementedError

    def file_controls(self, what: str, default: str, prefix: str, width: str, extra: Callable[[], Any]) -> None:
        """The file name, Load, Save and overwrite (``extra()`` adds widgets to that row); the
        elements' classes ``studio-<prefix>-file``, ``-load``, ``-save``."""
        from nicegui import ui

        self.file_name = ui.input(f"{what} (in the workspace)", value=default).classes(f"{width} studio-{prefix}-file")
        with ui.row().classes("items-center gap-2"):
            ui.button("Load", on_click=self.load).props("dense").classes(f"studio-{prefix}-load")
            ui.button("Save", on_click=self.save).props("dense").classes(f"studio-{prefix}-save")
            self.overwrite = ui.checkbox("overwrite")
            extra()

    def apply_controls(self, prefix: str) -> None:
        """The running-world selector, "Apply to the running world" and the message line
        (``studio-<prefix>-message``), refreshed every second."""
        from nicegui import ui

        with ui.row().classes("items-center gap-2"):
            self.world_select = ui.select([], label="running world").classes("w-40")
            ui.button("Apply to the running world", on_click=self.apply_to_world).props("dense outline")
        self.message = ui.label("").classes(f"text-sm break-all studio-{prefix}-message")
        ui.timer(1.0, self.refresh_worlds)

    def say(self, text: str, error: bool = False) -> None:
        self.message.set_text(text)
        self.message.classes(
            replace=f"text-sm break-all {self.message_class} " + ("text-red-700" if error else "text-green-800")
        )

    def save_text(self, text: str) -> bool:
        """Write ``text`` to the file named in the page (refusing to overwrite unless asked)."""
        name = (self.file_name.value or "").strip()
        try:
            path = self.studio.workspace.write_text(name, text, overwrite=self.overwrite.value)
        except (InputError, OSError) as err:
            self.say(f"error: {err}", error=True)
            return False
        self.own_file = name
        self.draft_saved()
        self.say(f"saved {self.studio.workspace.relative(path)}")
        return True

    async def apply_file(self, parameter: str, what: str) -> None:
        """Save the page's file (it must be the one loaded or saved here) and set the selected
        world's ``parameter`` to it; the world's refusal, with its reason, goes to the message line."""
        ns = self.world_select.value
        if ns is None:
            self.say("no running world to apply to", error=True)
            return
        name = (self.file_name.value or "").strip()
        try:
            path = self.studio.workspace.path(name)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        if name != self.own_file:
            self.say(f"{name} was not loaded or saved here: Save (or Load) it first", error=True)
            return
        self.overwrite.set_value(True)  # the file this page loaded or saved: bring it up to date
        if not self.save():
            return
        ros = create_ros(self.studio)
        if ros is None:
            self.say("the studio's ROS client has not started", error=True)
            return
        try:
            refused = await ros.set_parameters(ns, {parameter: str(path)})
        except TimeoutError as err:
            refused = [str(err)]
        if refused:
            self.say(f"the world refused the {what}: " + "; ".join(refused), error=True)
        else:
            self.say(f"saved {name} and applied it to the world in {ns or '/'}")

    def refresh_worlds(self) -> None:
        ros = create_ros(self.studio)
        names = ros.namespaces() if ros is not None else []
        if names != list(self.world_select.options):
            value = create_family(self.studio).default_robot(names, self.world_select.value)
            self.world_select.set_options({ns: ns or "/" for ns in names}, value=value)
