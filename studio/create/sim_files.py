"""The Simulator page's Load Map and Load Config: a workspace file given to the selected running
world (the original's buttons of those names), which swaps it in or says why it refuses."""

from __future__ import annotations

from nicegui import ui

from sim_runtime.errors import InputError
from studio.create.sim_tab import SimTab

FILES = {"map_file": "map", "config_file": "config"}
"""The world's file parameters, and what each file is."""
SUFFIXES = {"map_file": (".map", ".txt"), "config_file": (".cfg", ".txt", ".config")}


class WorldFilesPanel:
    """Load Map and Load Config for the tab's robot."""

    def __init__(self, tab: SimTab) -> None:
        self.tab = tab
        self.fields: dict[str, ui.input] = {}

    def build(self) -> None:
        ws = self.tab.studio.workspace
        with ui.expansion("Load Map / Load Config", icon="folder_open").classes("w-full border studio-world-files"):
            for parameter, what in FILES.items():
                with ui.row().classes("items-center gap-2 no-wrap w-full"):
                    self.fields[parameter] = ui.input(
                        f"{what} file (in the workspace)", autocomplete=ws.files(SUFFIXES[parameter])
                    ).classes(f"grow studio-load-{what}-file")
                    ui.button(f"Load {what.capitalize()}", on_click=lambda p=parameter: self.load(p)).props(
                        "dense"
                    ).classes(f"studio-load-{what}")
            self.message = ui.label("").classes("text-sm break-all studio-world-files-message")

    def say(self, text: str, error: bool = False) -> None:
        self.message.set_text(text)
        self.message.classes(
            replace="text-sm break-all studio-world-files-message " + ("text-red-700" if error else "text-green-800")
        )

    async def load(self, parameter: str) -> None:
        """Give the world the file named in the field: the world checks it (a bad row, a robot
        inside a new wall) and keeps what it had if it refuses."""
        what = FILES[parameter]
        ns = self.tab.picked()
        if ns is None:
            self.say(f"no robot selected: pick one (or start a world) to load a {what} into", error=True)
            return
        name = (self.fields[parameter].value or "").strip()
        try:
            if not name:
                raise InputError(
                    f"type the name of a {what} file in the workspace, then press Load {what.capitalize()}"
                )
            _text, path = self.tab.studio.workspace.read_text(name, what)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.say(f"loading {name} into the world in {ns or '/'}…")
        try:
            refused = await self.tab.ros.set_parameters(ns, {parameter: str(path)})
        except TimeoutError as err:
            refused = [str(err)]
        if refused:
            self.say(f"the world in {ns or '/'} kept its {what}: " + "; ".join(refused), error=True)
        else:
            self.say(f"loaded {name} into the world in {ns or '/'}")
