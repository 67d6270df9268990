"""The SIMROBOT editor's Map and world file panel: a bitmap (new, imported, saved), the world
file (opened, validated by ``simrobot_world``'s own loader, saved) and "Run it"."""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.world_file import load_world
from studio.shell.kit import checked_number
from studio.shell.processes import Child, clock_topic, executable_command, namespace_args, yaml_string
from studio.simrobot.doc import WorldDraft, blank_walls, png_bytes
from studio.simrobot.editor_base import EditorBase


class EditorFiles(EditorBase):
    """The files and the world run from them."""

    def build_files(self) -> None:
        with ui.expansion("Map and world file", value=True).classes("w-full border"):
            with ui.row().classes("items-center gap-2"):
                self.map_name = ui.input("bitmap (PNG/BMP)", value="simrobot_map.png").classes("w-48 simrobot-map-name")
                self.resolution = checked_number(
                    "m per cell", value=self.doc.resolution, minimum=0.0001, format="%g"
                ).classes("w-24 simrobot-resolution")
                ui.button("Import", on_click=self.import_map).props("dense outline")
                ui.button("Save bitmap", on_click=self.save_map).props("dense outline")
            with ui.row().classes("items-center gap-2"):
                self.blank_w = checked_number("width (m)", value=3.0, minimum=0.05, format="%g").classes("w-20")
                self.blank_h = checked_number("height (m)", value=2.0, minimum=0.05, format="%g").classes("w-20")
                ui.button("New blank map", on_click=self.new_map).props("dense outline")
            with ui.row().classes("items-center gap-2"):
                self.world_name = ui.input("world file (YAML)", value="simrobot_world.yaml").classes(
                    "w-48 simrobot-world-name"
                )
                ui.button("Open", on_click=self.open_world).props("dense outline")
                self.overwrite = ui.checkbox("overwrite", value=False).classes("simrobot-overwrite")
            with ui.row().classes("items-center gap-2"):
                self.dt = checked_number(
                    "dt (s)", value=self.doc.dt, minimum=0.001, format="%g", on_change=self.on_world
                ).classes("w-20")
                self.lockstep = ui.checkbox("lockstep", value=False, on_change=self.on_world)
                self.ns = ui.input("namespace", value=self.studio.free_namespace("simrobot")).classes(
                    "w-28 simrobot-ns"
                )
            with ui.row().classes("items-center gap-2"):
                ui.button("Validate", on_click=self.validate).props("dense outline")
                ui.button("Save world", on_click=self.save_world).props("dense color=primary")
                ui.button("Run it", on_click=self.run_world).props("dense color=green")

    # ---------------------------------------------------------------- world
    def on_world(self, _e=None) -> None:
        if self.dt.value is not None:  # a bad dt is the world check's to refuse, with its reason
            self.doc.dt = float(self.dt.value)
        self.doc.lockstep = bool(self.lockstep.value)

    def set_doc(self, doc: WorldDraft) -> None:
        self.doc = doc
        self.map_dirty = True
        self.resolution.set_value(doc.resolution)
        self.dt.set_value(doc.dt)
        self.lockstep.set_value(doc.lockstep)
        self.select(None)
        self.fit()

    def new_map(self) -> None:
        try:
            res = float(self.resolution.value or 0.01)
            walls = blank_walls(float(self.blank_w.value or 0), float(self.blank_h.value or 0), res)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.doc.walls, self.doc.resolution = walls, res
        self.map_dirty = self.map_unsaved = True
        self.fit()
        self.say(f"new blank map {walls.shape[0]} x {walls.shape[1]} cells")

    def import_map(self) -> None:
        ws = self.studio.workspace
        try:
            doc = WorldDraft.from_image(ws.path(self.map_name.value or ""), float(self.resolution.value or 0.01))
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.doc.walls, self.doc.resolution = doc.walls, doc.resolution
        self.map_dirty, self.map_unsaved = True, False
        self.fit()
        self.say(f"imported {self.map_name.value}: {doc.walls.shape[0]} x {doc.walls.shape[1]} cells")

    def save_map(self) -> bool:
        ws = self.studio.workspace
        name = (self.map_name.value or "").strip()
        try:
            path = ws.path(name)
            if path.suffix.lower() != ".png":
                raise InputError(f"{name!r}: the editor saves PNG (name it .png)")
            if path.exists() and not self.overwrite.value:
                raise InputError.at(name, None, "file exists (tick 'overwrite' to replace it)")
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(png_bytes(self.doc.walls))
        except (InputError, OSError) as err:
            self.say(f"error: {err}", error=True)
            return False
        self.map_unsaved = False
        self.say(f"saved {name}")
        return True

    def open_world(self) -> None:
        ws = self.studio.workspace
        name = (self.world_name.value or "").strip()
        try:
            spec = load_world(ws.path(name))
            map_name = ws.relative(Path(spec.map_path))
        except (InputError, ValueError) as err:
            self.say(f"error: {err}", error=True)
            return
        self.map_name.set_value(map_name)
        self.set_doc(WorldDraft.from_spec(spec))
        self.map_unsaved = False
        self.own_world = name
        self.draft_saved()
        self.say(f"opened {name}: {len(spec.robots)} robots")

    def map_ref(self) -> str:
        """The bitmap as the world file names it: relative to the world file's folder."""
        ws = self.studio.workspace
        world_dir = ws.path(self.world_name.value or "").parent
        return os.path.relpath(ws.path(self.map_name.value or ""), world_dir)

    def validate(self) -> bool:
        self.on_world()
        name = (self.world_name.value or "").strip() or "world.yaml"
        try:
            spec = self.doc.check(name)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return False
        sensors = sum(len(r.sensors) for r in spec.robots)
        self.say(f"{name}: valid ({len(spec.robots)} robots, {sensors} sensors)")
        return True

    def save_world(self) -> bool:
        if not self.validate():
            return False
        ws = self.studio.workspace
        name = (self.world_name.value or "").strip()
        try:
            map_missing = not ws.path(self.map_name.value or "").exists()
            if (self.map_unsaved or map_missing) and not self.save_map():
                return False
            text = self.doc.world_yaml(self.map_ref(), ws.path(name).parent)
            ws.write_text(name, text, overwrite=self.overwrite.value)
        except (InputError, OSError) as err:
            self.say(f"error: {err}", error=True)
            return False
        self.own_world = name
        self.draft_saved()
        self.say(f"saved {name} (map {self.map_ref()})")
        return True

    async def run_world(self) -> None:
        ws, simrobot = self.studio.workspace, self.side
        ns = (self.ns.value or "").strip().rstrip("/")
        if ns and not ns.startswith("/"):
            ns = "/" + ns
        running = simrobot.worlds.get(ns)
        rerun = running if running is not None and running.running else None  # "Run it" again: the edited world
        refusal = None if rerun is not None else self.studio.namespace_refusal(ns)
        if refusal:
            self.say(f"error: {refusal}", error=True)
            return
        if (self.world_name.value or "").strip() == self.own_world:
            self.overwrite.set_value(True)  # the file this tab opened or saved: bring it up to date
        if not self.save_world():
            return
        # A re-run keeps the clock its world had; a new world owns /clock if nobody does.
        owns_clock = rerun.clock == "/clock" if rerun is not None else self.studio.clock_owner() is None
        if rerun is not None:
            rerun.stop()
        old = simrobot.ros.worlds.get(ns) if simrobot.ros is not None else None
        if simrobot.ros is not None:
            simrobot.ros.forget(ns)
        path = ws.path(self.world_name.value or "")
        args = ["--ros-args", "-p", f"world_file:={yaml_string(str(path))}"]
        args += namespace_args(ns, owns_clock)
        child = Child(
            f"simrobot_world {ns or '/'}",
            executable_command("simrobot_world", args),
            cwd=ws.root,
            clock=clock_topic(ns, owns_clock),
        )
        simrobot.worlds[ns] = child
        simrobot.selected = ns
        self.say(f"starting simrobot_world on {self.world_name.value} in {ns or '/'}…")
        for _ in range(600):  # compiling kernels the first time takes a while; a bad file ends it
            await asyncio.sleep(0.1)
            if not child.running:
                self.say(f"{child.label}: {child.error_line()}", error=True)
                return
            ros = simrobot.ros
            st = ros.worlds.get(ns) if ros is not None else None
            if st is not None and st is not old and st.spec is not None:
                break
        else:
            self.say(f"{child.label} started but was not seen on ROS yet", error=True)
            return
        ui.navigate.to("/simrobot")
