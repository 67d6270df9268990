"""The SIMROBOT editor's Robot and Sensors forms: the picked robot's name, colour, pose, wheels,
controller and shape, and its sensors (with a live beam preview on the canvas)."""

from __future__ import annotations

import math
from dataclasses import replace

from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.world_file import CONTROLLERS, DEFAULT_SHAPE, SENSOR_TYPES, RobotSpec, SensorSpec
from studio.shell import svg
from studio.simrobot import fields
from studio.simrobot.doc import new_sensor, parse_vertices, vertices_text
from studio.simrobot.editor_algorithms import (
    ALGORITHM_PREFIX,
    AlgorithmChoice,
    AlgorithmEditor,
    editable_algorithm,
    new_algorithm,
)
from studio.simrobot.editor_base import EditorBase, quantity_field
from studio.simrobot.memory import load_memory, memory_info, save_memory

NO_CONTROLLER = "(none: topics)"


class EditorForm(EditorBase):
    """The robot and sensor forms, filled from the selection and written back on each edit."""

    def build_robot(self) -> None:
        with ui.expansion("Robot", value=True).classes("w-full border"):
            with ui.row().classes("items-center gap-2"):
                self.robot_select = ui.select({}, label="robot", on_change=self.on_pick).classes("w-32 simrobot-robot")
                ui.button("Add", on_click=self.add_robot_centre).props("dense outline")
                ui.button("Delete", on_click=self.delete_robot).props("dense outline color=red")
            with ui.column().classes("gap-1 w-full") as self.robot_form:
                with ui.row().classes("items-center gap-2"):
                    self.f_name = ui.input("name", on_change=self.on_robot_field).classes("w-24 simrobot-robot-name")
                    self.f_colour = ui.color_input("colour", on_change=self.on_robot_field).classes(
                        "w-32 simrobot-colour"
                    )
                    self.f_power = ui.checkbox("power", on_change=self.on_robot_field).classes("simrobot-power")
                with ui.row().classes("items-center gap-2"):
                    self.f_x = quantity_field(fields.X, "simrobot-x", self.on_robot_field)
                    self.f_y = quantity_field(fields.Y, "simrobot-y", self.on_robot_field)
                    self.f_heading = quantity_field(fields.HEADING, "simrobot-heading", self.on_robot_field)
                    self.f_scale = quantity_field(fields.SCALE, "simrobot-scale", self.on_robot_field)
                with ui.row().classes("items-center gap-2"):
                    self.f_R = quantity_field(fields.WHEEL_RADIUS, "simrobot-R", self.on_robot_field)
                    self.f_la = quantity_field(fields.HALF_TRACK, "simrobot-la", self.on_robot_field)
                    self.f_lb = quantity_field(fields.AXLE_OFFSET, "simrobot-lb", self.on_robot_field)
                with ui.row().classes("items-center gap-2"):
                    self.f_controller = ui.select(
                        [NO_CONTROLLER, *CONTROLLERS],
                        value=NO_CONTROLLER,
                        label="controller",
                        on_change=self.on_robot_field,
                    ).classes("w-56 simrobot-controller")
                    ui.button("Edit", on_click=self.edit_algorithm).props("dense outline").classes(
                        "simrobot-algorithm-edit"
                    )
                with ui.row().classes("items-center gap-2"):
                    self.f_new_algorithm = ui.input("new algorithm file", placeholder="alg_r1.m").classes(
                        "w-44 simrobot-algorithm-name"
                    )
                    ui.button("New", on_click=self.new_algorithm).props("dense outline").classes(
                        "simrobot-algorithm-new"
                    )
                self.algorithms = AlgorithmChoice(self.f_controller, self.studio.workspace, NO_CONTROLLER)
                self.algorithm_editor = AlgorithmEditor(self.studio.workspace, self.say)
                with ui.row().classes("items-center gap-2"):  # the original's Memory menu
                    self.memory_label = ui.label("memory: empty").classes("text-sm simrobot-memory-info")
                    self.f_memory_file = ui.input("memory file (.mat or text)", placeholder="mem_r1.txt").classes(
                        "w-52 simrobot-memory-file"
                    )
                with ui.row().classes("items-center gap-2"):
                    ui.button("Load memory", on_click=self.load_memory).props("dense outline")
                    ui.button("Save memory", on_click=self.save_memory).props("dense outline")
                    ui.button("Clear memory", on_click=self.clear_memory).props("dense outline color=red")
                with ui.row().classes("items-end gap-2"):
                    self.f_shape = (
                        ui.textarea("shape: x, y per vertex (m)")
                        .props("rows=5")
                        .classes("w-56 font-mono simrobot-shape")
                    )
                    with ui.column().classes("gap-1"):
                        ui.button("Apply shape", on_click=self.apply_shape).props("dense outline")
                        ui.button("Default shape", on_click=self.default_shape).props("dense outline")

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
                self.s_x = quantity_field(fields.SENSOR_X, "simrobot-sx", self.on_sensor_field)
                self.s_y = quantity_field(fields.SENSOR_Y, "simrobot-sy", self.on_sensor_field)
                self.s_axis = quantity_field(fields.AXIS, "simrobot-axis", self.on_sensor_field)
            with ui.row().classes("items-center gap-2"):
                self.s_beam = quantity_field(fields.BEAMWIDTH, "simrobot-beamwidth", self.on_sensor_field)
                self.s_range = quantity_field(fields.RANGE, "simrobot-range", self.on_sensor_field)
                self.s_rays = quantity_field(fields.RAYS, "simrobot-rays", self.on_sensor_field)

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
                self.algorithms.show(r)  # its controller, or its algorithm m-file
                self.f_shape.set_value(vertices_text(r.shape))
                self.memory_label.set_text(memory_info(r.memory))
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

    def on_robot_field(self, _e: object = None) -> None:
        if self.filling or self.selected is None:
            return
        try:
            self.robot_fields()
        except InputError:
            return  # the field shows it in red; Validate and Save refuse it with its sentence
        self.redraw()

    def robot_fields(self) -> None:
        """The shown robot's fields into the draft; InputError naming the first refused field."""
        if self.selected is None:
            return
        r = self.doc.robots[self.selected]
        name = (self.f_name.value or "").strip()
        if not name:
            raise InputError("name: empty: type the robot's name (letters, digits and _)")
        colour = self.f_colour.value or ""
        r = replace(
            r,
            name=name,
            color=svg.hex_rgb(colour) if colour.startswith("#") and len(colour) == 7 else r.color,
            power=bool(self.f_power.value),
            position=(fields.X.read(self.f_x.value), fields.Y.read(self.f_y.value)),
            heading=math.radians(fields.HEADING.read(self.f_heading.value)),
            scale=fields.SCALE.read(self.f_scale.value),
            R=fields.WHEEL_RADIUS.read(self.f_R.value),
            la=fields.HALF_TRACK.read(self.f_la.value),
            lb=fields.AXLE_OFFSET.read(self.f_lb.value),
            **self.algorithms.chosen(),  # controller=…, algorithm=…
        )
        self.doc.robots[self.selected] = r
        options = self.robot_select.options  # index → name (fill_form sets a dict)
        if isinstance(options, dict) and options.get(self.selected) != r.name:
            options[self.selected] = r.name
            self.robot_select.update()

    def form_fields(self) -> None:
        """The shown robot and sensor into the draft, as the fields show them (Validate, Save)."""
        self.robot_fields()
        self.sensor_fields()

    # ---------------------------------------------------------------- algorithm files
    def edit_algorithm(self) -> None:
        """The original's Algorithm > Edit: the chosen m-file's text, saved back to the workspace."""
        ws = self.studio.workspace
        try:
            name = editable_algorithm(self.f_controller.value, ws)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        path = str(ws.path(name))
        others = [r.name for i, r in enumerate(self.doc.robots) if r.algorithm == path and i != self.selected]
        self.algorithm_editor.open(name, f" (also run by {', '.join(others)})" if others else "")

    def new_algorithm(self) -> None:
        """The original's Algorithm > New: a file from its template, chosen for this robot and opened."""
        if self.selected is None:
            self.say("select a robot first", error=True)
            return
        try:
            name = new_algorithm(self.studio.workspace, self.f_new_algorithm.value or "")
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.f_new_algorithm.set_value("")
        self.algorithms.set(ALGORITHM_PREFIX + name)  # its on_change writes it to the robot
        self.on_robot_field()
        self.say(f"made {name} from the template: it now drives {self.doc.robots[self.selected].name}")
        self.algorithm_editor.open(name)

    # ---------------------------------------------------------------- memory
    def memory_name(self) -> str:
        name = (self.f_memory_file.value or "").strip()
        if not name:
            raise InputError("type the memory file's name first (a .mat file with mem, or a text file of numbers)")
        return name

    def load_memory(self) -> None:
        """The original's Memory > Load from disk: the file's matrix becomes the robot's memory."""
        if self.selected is None:
            self.say("select a robot first", error=True)
            return
        try:
            name = self.memory_name()
            memory = load_memory(self.studio.workspace, name)
        except InputError as err:
            self.say(f"error: {err}", error=True)
            return
        self.set_robot(replace(self.doc.robots[self.selected], memory=memory))
        self.say(f"loaded {name} into {self.doc.robots[self.selected].name}'s {memory_info(memory)}")

    def save_memory(self) -> None:
        """The original's Memory > Save to disk."""
        r = self.robot()
        if r is None:
            self.say("select a robot first", error=True)
            return
        try:
            name = self.memory_name()
            save_memory(self.studio.workspace, name, r.memory, overwrite=bool(self.overwrite.value))
        except (InputError, OSError) as err:
            self.say(f"error: {err}", error=True)
            return
        self.say(f"saved {r.name}'s memory to {name}")

    def clear_memory(self) -> None:
        r = self.robot()
        if r is not None:
            self.set_robot(replace(r, memory=None))
            self.say(f"cleared {r.name}'s memory")

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
        if self.filling:
            return
        try:
            self.sensor_fields()
        except InputError:
            return  # the field shows it in red; Validate and Save refuse it with its sentence
        self.redraw()

    def sensor_fields(self) -> None:
        """The shown sensor's fields into the draft; InputError naming the first refused field."""
        r, index = self.robot(), self.selected
        if r is None or index is None or self.sensor is None:
            return
        sensors = list(r.sensors)
        sensors[self.sensor] = replace(
            sensors[self.sensor],
            kind=self.s_kind.value,
            position=(fields.SENSOR_X.read(self.s_x.value), fields.SENSOR_Y.read(self.s_y.value)),
            axis=math.radians(fields.AXIS.read(self.s_axis.value)),
            beamwidth=math.radians(fields.BEAMWIDTH.read(self.s_beam.value)),
            range=fields.RANGE.read(self.s_range.value),
            rays=int(fields.RAYS.read(self.s_rays.value)),
        )
        self.doc.robots[index] = replace(r, sensors=tuple(sensors))
