"""The SIMROBOT editor page (the seed's Editor window): bitmap, robots, sensors, world file, run.

The world in memory is a :class:`studio.simrobot.doc.WorldDraft`; validation and "Run it" go
through ``simrobot_world``'s own loader and placement, so the page says what the command line says.
"""

from __future__ import annotations

import asyncio
import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.world_file import CONTROLLERS, DEFAULT_SHAPE, SENSOR_TYPES, RobotSpec, SensorSpec, load_world
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, DraftGuard, ZoomableView, checked_number, nav, view_image
from studio.shell.processes import Child, clock_topic, executable_command, namespace_args, yaml_string
from studio.simrobot.doc import WorldDraft, blank_walls, new_sensor, parse_vertices, png_bytes, vertices_text
from studio.simrobot.draw import beams_svg, map_data_url, map_svg, robot_svg
from studio.simrobot.ros_client import side

TOOLS = {
    "select": "Select/move",
    "rotate": "Rotate",
    "add": "Add robot",
    "paint": "Paint",
    "erase": "Erase",
    "pan": "Pan",
}
NO_CONTROLLER = "(none: topics)"


def register(studio: Studio) -> None:
    @ui.page("/simrobot/editor")
    def simrobot_editor_page() -> None:
        EditorPage(studio)


class EditorPage(ZoomableView, DraftGuard):
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
                self.message = ui.label("").classes("simrobot-editor-message text-sm break-all w-[800px]")
            with ui.column().classes("gap-2 w-[460px]"):
                self.build_files()
                self.build_robot()
                self.build_sensors()

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

    def build_robot(self) -> None:
        with ui.expansion("Robot", value=True).classes("w-full border"):
            with ui.row().classes("items-center gap-2"):
                self.robot_select = ui.select({}, label="robot", on_change=self.on_pick).classes("w-32 simrobot-robot")
                ui.button("Add", on_click=self.add_robot_centre).props("dense outline")
                ui.button("Delete", on_click=self.delete_robot).props("dense outline color=red")
            with ui.column().classes("gap-1 w-full") as self.robot_form:
                with ui.row().classes("items-center gap-2"):
                    self.f_name = ui.input("name", on_change=self.on_robot_field).classes("w-24 simrobot-robot-name")
                    self.f_colour = ui.color_input("colour", on_change=self.on_robot_field).classes("w-32")
                    self.f_power = ui.checkbox("power", on_change=self.on_robot_field)
                with ui.row().classes("items-center gap-2"):
                    self.f_x = self.number("x (m)", "simrobot-x")
                    self.f_y = self.number("y (m)", "simrobot-y")
                    self.f_heading = self.number("heading (°)", "simrobot-heading")
                    self.f_scale = self.number("scale", "simrobot-scale")
                with ui.row().classes("items-center gap-2"):
                    self.f_R = self.number("wheel radius (m)", "simrobot-R")
                    self.f_la = self.number("half track (m)", "simrobot-la")
                    self.f_lb = self.number("axle offset (m)", "simrobot-lb")
                self.f_controller = ui.select(
                    [NO_CONTROLLER, *CONTROLLERS],
                    value=NO_CONTROLLER,
                    label="controller",
                    on_change=self.on_robot_field,
                ).classes("w-40")
                with ui.row().classes("items-end gap-2"):
                    self.f_shape = (
                        ui.textarea("shape: x, y per vertex (m)")
                        .props("rows=5")
                        .classes("w-48 font-mono simrobot-shape")
                    )
                    with ui.column().classes("gap-1"):
                        ui.button("Apply shape", on_click=self.apply_shape).props("dense outline")
                        ui.button("Default shape", on_click=self.default_shape).props("dense outline")

    def number(self, label: str, css: str) -> ui.number:
        return ui.number(label, format="%g", on_change=self.on_robot_field).classes(f"w-24 {css}")

    def build_sensors(self) -> None:
        with ui.expansion("Sensors (live beam preview)", value=True).classes("w-full border"):
            with ui.row().classes("items-center gap-2"):
                self.sensor_select = ui.select({}, label="sensor", on_change=self.on_pick_sensor).classes(
                    "w-32 simrobot-sensor"
                )
                self.sensor_new = ui.input("name", value="").classes("w-24 simrobot-sensor-new")
                ui.button("Add sensor", on_click=self.add_sensor).props("dense outline")
                ui.button("Rename", on_click=self.rename_sensor).props("dense outline")
                ui.button("Delete", on_click=self.delete_sensor).props("dense outline color=red")
            with ui.row().classes("items-center gap-2"):
                self.s_kind = ui.select(list(SENSOR_TYPES), label="type", on_change=self.on_sensor_field).classes(
                    "w-28 simrobot-sensor-type"
                )
                self.s_x = self.sensor_number("x (m)", "simrobot-sx")
                self.s_y = self.sensor_number("y (m)", "simrobot-sy")
                self.s_axis = self.sensor_number("axis (°)", "simrobot-axis")
            with ui.row().classes("items-center gap-2"):
                self.s_beam = self.sensor_number("beamwidth (°)", "simrobot-beamwidth")
                self.s_range = self.sensor_number("range (m)", "simrobot-range")
                self.s_rays = self.sensor_number("rays", "simrobot-rays")

    def sensor_number(self, label: str, css: str) -> ui.number:
        return ui.number(label, format="%g", on_change=self.on_sensor_field).classes(f"w-24 {css}")

    # ---------------------------------------------------------------- messages
    def say(self, text: str, error: bool = False) -> None:
        self.message.set_text(text)
        self.message.classes(replace="simrobot-editor-message text-sm break-all w-[800px] " + (
            "text-red-700" if error else "text-green-800"))  # fmt: skip

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

    def draft(self) -> object:
        """The world as its file says it, and whether its bitmap has unsaved paint."""
        self.on_world()
        return self.doc.world_yaml("map"), self.map_unsaved

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
        hit = self.doc.robot_at(x, y, slack_m=4.0 / self.view.scale)
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

    # ---------------------------------------------------------------- robots
    def select(self, index: int | None) -> None:
        self.selected = index
        self.sensor = 0 if index is not None and self.doc.robots[index].sensors else None
        self.fill_form()
        self.redraw()

    def add_robot_centre(self) -> None:
        robot = self.doc.add_robot(round(self.view.centre_x, 3), round(self.view.centre_y, 3))
        self.select(len(self.doc.robots) - 1)
        self.say(f"added {robot.name}: drag it where it starts")

    def delete_robot(self) -> None:
        if self.selected is None:
            return
        robot = self.doc.robots.pop(self.selected)
        self.select(None)
        self.say(f"deleted {robot.name}")

    def set_robot(self, robot: RobotSpec) -> None:
        if self.selected is None:
            return
        self.doc.robots[self.selected] = robot
        self.fill_form()
        self.redraw()

    def fill_form(self) -> None:
        """Show the selected robot and sensor in the form (without treating it as edits)."""
        self.filling = True
        try:
            names = {i: r.name for i, r in enumerate(self.doc.robots)}
            self.robot_select.set_options(names, value=self.selected)
            r = self.doc.robots[self.selected] if self.selected is not None else None
            self.robot_form.set_visibility(r is not None)
            if r is not None:
                self.f_name.set_value(r.name)
                self.f_colour.set_value(svg.rgb_hex(r.color))
                self.f_power.set_value(r.power)
                self.f_x.set_value(r.position[0])
                self.f_y.set_value(r.position[1])
                self.f_heading.set_value(round(math.degrees(r.heading), 3))
                self.f_scale.set_value(r.scale)
                self.f_R.set_value(r.R)
                self.f_la.set_value(r.la)
                self.f_lb.set_value(r.lb)
                self.f_controller.set_value(r.controller or NO_CONTROLLER)
                self.f_shape.set_value(vertices_text(r.shape))
            sensors = {k: s.name for k, s in enumerate(r.sensors)} if r is not None else {}
            self.sensor_select.set_options(sensors, value=self.sensor)
            s = r.sensors[self.sensor] if r is not None and self.sensor is not None else None
            for widget in (self.s_kind, self.s_x, self.s_y, self.s_axis, self.s_beam, self.s_range, self.s_rays):
                widget.set_enabled(s is not None)
            if s is not None:
                self.s_kind.set_value(s.kind)
                self.s_x.set_value(s.position[0])
                self.s_y.set_value(s.position[1])
                self.s_axis.set_value(round(math.degrees(s.axis), 3))
                self.s_beam.set_value(round(math.degrees(s.beamwidth), 3))
                self.s_range.set_value(s.range)
                self.s_rays.set_value(s.rays)
        finally:
            self.filling = False

    def on_pick(self, e) -> None:
        if not self.filling and e.value != self.selected:
            self.select(e.value)

    def on_robot_field(self, _e=None) -> None:
        if self.filling or self.selected is None:
            return
        r = self.doc.robots[self.selected]
        try:
            name = (self.f_name.value or "").strip()
            values = [self.f_x.value, self.f_y.value, self.f_heading.value, self.f_scale.value]
            values += [self.f_R.value, self.f_la.value, self.f_lb.value]
            if any(v is None for v in values) or not name:
                return  # a field being typed into
            r = replace(
                r,
                name=name,
                color=svg.hex_rgb(self.f_colour.value) if (self.f_colour.value or "").startswith("#") else r.color,
                power=bool(self.f_power.value),
                position=(float(self.f_x.value), float(self.f_y.value)),
                heading=math.radians(float(self.f_heading.value)),
                scale=float(self.f_scale.value),
                R=float(self.f_R.value),
                la=float(self.f_la.value),
                lb=float(self.f_lb.value),
                controller=None if self.f_controller.value == NO_CONTROLLER else self.f_controller.value,
            )
        except (TypeError, ValueError) as err:
            self.say(f"error: {err}", error=True)
            return
        self.doc.robots[self.selected] = r
        self.robot_select.options[self.selected] = r.name
        self.robot_select.update()
        self.redraw()

    def apply_shape(self) -> None:
        if self.selected is None:
            return
        try:
            shape = parse_vertices(self.f_shape.value or "")
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.set_robot(replace(self.doc.robots[self.selected], shape=shape))
        self.say("shape applied")

    def default_shape(self) -> None:
        if self.selected is not None:
            self.set_robot(replace(self.doc.robots[self.selected], shape=DEFAULT_SHAPE))

    # ---------------------------------------------------------------- sensors
    def robot(self) -> RobotSpec | None:
        return self.doc.robots[self.selected] if self.selected is not None else None

    def set_sensors(self, sensors: list[SensorSpec], index: int | None) -> None:
        r = self.robot()
        if r is None:
            return
        self.sensor = index
        self.set_robot(replace(r, sensors=tuple(sensors)))

    def add_sensor(self) -> None:
        r = self.robot()
        if r is None:
            self.say("select a robot first", error=True)
            return
        taken = {s.name for s in r.sensors}
        name = (self.sensor_new.value or "").strip() or self.doc.unused_name("sens", taken)
        if name in taken:
            self.say(f"error: {r.name} already has a sensor {name!r}", error=True)
            return
        self.set_sensors([*r.sensors, new_sensor(name)], len(r.sensors))
        self.sensor_new.set_value("")
        self.say(f"added sensor {name} to {r.name}")

    def rename_sensor(self) -> None:
        r, name = self.robot(), (self.sensor_new.value or "").strip()
        if r is None or self.sensor is None or not name:
            self.say("select a sensor and type its new name", error=True)
            return
        sensors = list(r.sensors)
        sensors[self.sensor] = replace(sensors[self.sensor], name=name)
        self.set_sensors(sensors, self.sensor)
        self.sensor_new.set_value("")

    def delete_sensor(self) -> None:
        r = self.robot()
        if r is None or self.sensor is None:
            return
        sensors = [s for k, s in enumerate(r.sensors) if k != self.sensor]
        self.set_sensors(sensors, 0 if sensors else None)

    def on_pick_sensor(self, e) -> None:
        if not self.filling:
            self.sensor = e.value
            self.fill_form()

    def on_sensor_field(self, _e: object = None) -> None:
        r, index = self.robot(), self.selected
        if self.filling or r is None or index is None or self.sensor is None:
            return
        values = [self.s_x.value, self.s_y.value, self.s_axis.value, self.s_beam.value, self.s_range.value]
        if any(v is None for v in values) or self.s_rays.value is None:
            return
        sensors = list(r.sensors)
        sensors[self.sensor] = replace(
            sensors[self.sensor],
            kind=self.s_kind.value,
            position=(float(self.s_x.value), float(self.s_y.value)),
            axis=math.radians(float(self.s_axis.value)),
            beamwidth=math.radians(min(max(float(self.s_beam.value), 0.0), 360.0)),
            range=max(float(self.s_range.value), 1e-6),
            rays=max(int(self.s_rays.value), 1),
        )
        self.doc.robots[index] = replace(r, sensors=tuple(sensors))
        self.redraw()

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
            text = self.doc.world_yaml(self.map_ref())
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
