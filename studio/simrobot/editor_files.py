"""The SIMROBOT editor's Map and world file panel: a bitmap (new, imported, saved), the world
file (opened, validated by ``simrobot_world``'s own loader, saved) and "Run it"."""

from __future__ import annotations

import asyncio
import contextlib
import os
from pathlib import Path

from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.world_file import load_world
from studio.shell.processes import Child, clock_topic, executable_command, namespace_args, yaml_string
from studio.simrobot import fields
from studio.simrobot.doc import WorldDraft, blank_walls, png_bytes
from studio.simrobot.editor_base import EditorBase, field_width, quantity_field

START_WAIT_TICKS = 6000
"""Tenths of a second "Run it" waits for the world it started to be seen on ROS (10 min)."""


class EditorFiles(EditorBase):
    """The files and the world run from them."""

    def build_files(self) -> None:
        with ui.expansion("Map and world file", value=True).classes("w-full border"):
            with ui.row().classes("items-center gap-2"):
                self.map_name = ui.input("bitmap (PNG/BMP)", value="simrobot_map.png").classes("w-48 simrobot-map-name")
                self.resolution = quantity_field(fields.RESOLUTION, "simrobot-resolution", self.on_world,
                                                 self.doc.resolution)  # fmt: skip
                ui.button("Import", on_click=self.import_map).props("dense outline")
                ui.button("Save bitmap", on_click=self.save_map).props("dense outline")
            with ui.row().classes("items-center gap-2"):
                self.blank_w = quantity_field(fields.BLANK_WIDTH, "simrobot-blank-w", value=3.0)
                self.blank_h = quantity_field(fields.BLANK_HEIGHT, "simrobot-blank-h", value=2.0)
                ui.button("New blank map", on_click=self.new_map).props("dense outline")
            with ui.row().classes("items-center gap-2"):
                self.world_name = ui.input("world file (YAML)", value="simrobot_world.yaml").classes(
                    "w-48 simrobot-world-name"
                )
                ui.button("Open", on_click=self.open_world).props("dense outline")
                self.overwrite = ui.checkbox("overwrite", value=False).classes("simrobot-overwrite")
            with ui.row().classes("items-center gap-2"):
                self.dt = quantity_field(fields.DT, "simrobot-dt", self.on_world, self.doc.dt)
                self.steps_limit = (
                    ui.input(fields.STEPS_LIMIT.label, value=fields.steps_text(self.doc.steps_limit),
                             placeholder="inf", validation=fields.STEPS_LIMIT.problem, on_change=self.on_world)
                    .props("hide-bottom-space").classes("simrobot-steps-limit")
                    .style(field_width(fields.STEPS_LIMIT.label))
                )  # fmt: skip
                self.step_time = quantity_field(fields.STEP_TIME, "simrobot-step-time", self.on_world,
                                                self.doc.replay_step_time)  # fmt: skip
                self.lockstep = ui.checkbox("lockstep", value=False, on_change=self.on_world).classes(
                    "simrobot-lockstep"
                )
            with ui.row().classes("items-center gap-2"):
                self.ns = ui.input("namespace", value=self.studio.free_namespace("simrobot")).classes(
                    "w-32 simrobot-ns"
                )
                ui.button("Validate", on_click=self.validate).props("dense outline")
                ui.button("Save world", on_click=self.save_world).props("dense color=primary")
                ui.button("Run it", on_click=self.run_world).props("dense color=green")

    # ---------------------------------------------------------------- world
    def world_fields(self) -> None:
        """The world's fields into the draft; InputError naming the first field whose value is
        refused (the draft keeps its last good value of it)."""
        self.doc.lockstep = bool(self.lockstep.value)
        self.doc.dt = fields.DT.read(self.dt.value)
        self.doc.steps_limit = fields.STEPS_LIMIT.read(self.steps_limit.value)
        self.doc.replay_step_time = fields.STEP_TIME.read(self.step_time.value)
        resolution = fields.RESOLUTION.read(self.resolution.value)
        if resolution != self.doc.resolution:  # the cells stay, each of the new size: the map grows or shrinks
            self.doc.resolution = resolution
            self.map_dirty = True
            self.fit()

    def on_world(self, _e: object = None) -> None:
        if self.filling:  # the fields being filled from a file opened: its values, not edits
            return
        with contextlib.suppress(InputError):  # the field shows it in red; Validate and Save refuse it
            self.world_fields()

    def set_doc(self, doc: WorldDraft) -> None:
        self.doc = doc
        self.map_dirty = True
        self.filling = True
        try:
            self.resolution.set_value(doc.resolution)
            self.dt.set_value(doc.dt)
            self.steps_limit.set_value(fields.steps_text(doc.steps_limit))
            self.step_time.set_value(doc.replay_step_time)
            self.lockstep.set_value(doc.lockstep)
        finally:
            self.filling = False
        self.select(None)
        self.fit()

    def new_map(self) -> None:
        try:
            res = fields.RESOLUTION.read(self.resolution.value)
            width, height = fields.BLANK_WIDTH.read(self.blank_w.value), fields.BLANK_HEIGHT.read(self.blank_h.value)
            walls = blank_walls(width, height, res)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.doc.walls, self.doc.resolution = walls, res
        self.map_dirty = self.map_unsaved = True
        self.fit()
        self.say(f"new blank map {walls.shape[0]} x {walls.shape[1]} cells")

    def import_map(self) -> None:
        try:
            resolution = fields.RESOLUTION.read(self.resolution.value)
            doc = WorldDraft.from_image(self.existing(self.map_name.value or "", "bitmap"), resolution)
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
        name = (self.world_name.value or "").strip()
        try:
            spec = load_world(self.existing(name, "world"))
            map_name = self.map_in_workspace(name, Path(spec.map_path))
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.map_name.set_value(map_name)
        self.set_doc(WorldDraft.from_spec(spec))
        self.map_unsaved = False
        self.own_world = name
        self.draft_saved()
        self.say(f"opened {name}: {len(spec.robots)} robots")

    def existing(self, name: str, kind: str) -> Path:
        """The workspace file ``name`` to read; InputError saying what to do when it is a link
        leading out of the workspace or to nothing (then the reader says what else is wrong)."""
        path = self.studio.workspace.path(name)  # refuses a link out of the workspace
        given = self.studio.workspace.root / name.strip()
        if given.is_symlink() and not path.exists():
            raise InputError(
                f"{name.strip()}: the link leads to {os.readlink(given)!r}, which does not exist: "
                f"point the link at a {kind} file or type another name"
            )
        return path

    def map_in_workspace(self, world: str, map_path: Path) -> str:
        """The world's bitmap as a workspace name; InputError saying what to do when it is outside."""
        ws = self.studio.workspace
        try:
            return ws.relative(map_path)
        except ValueError:
            raise InputError(
                f"{world}: its map {str(map_path)!r} is outside the workspace {ws.root}: "
                "copy the bitmap into the workspace and name it in the world file's map:"
            ) from None

    def map_ref(self) -> str:
        """The bitmap as the world file names it: relative to the world file's folder."""
        ws = self.studio.workspace
        world_dir = ws.path(self.world_name.value or "").parent
        return os.path.relpath(ws.path(self.map_name.value or ""), world_dir)

    def validate(self) -> bool:
        name = (self.world_name.value or "").strip() or "world.yaml"
        try:
            self.world_fields()
            self.form_fields()  # the robot and sensor shown: saved as they show
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
        old = simrobot.client.worlds.get(ns) if simrobot.client is not None else None
        if simrobot.client is not None:
            simrobot.client.forget(ns)
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
        # Compiling kernels the first time takes minutes on a busy machine: wait while the world
        # runs (a bad file ends it at once), saying so after a while.
        for tick in range(START_WAIT_TICKS):
            await asyncio.sleep(0.1)
            if tick == 100:
                self.say(
                    f"{child.label} is still starting (a first start compiles kernels: minutes on a busy machine)…"
                )
            if not child.running:
                self.say(f"{child.label}: {child.error_line()}", error=True)
                return
            ros = simrobot.client
            st = ros.worlds.get(ns) if ros is not None else None
            if st is not None and st is not old and st.spec is not None:
                break
        else:
            self.say(f"{child.label} was not seen on ROS in 10 min: see its lines on the Output page", True)
            return
        ui.navigate.to("/simrobot")
