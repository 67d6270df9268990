"""The SIMROBOT editor's Robot and Sensors forms: the picked robot's name, colour, pose, wheels,
controller and shape, and its sensors (with a live beam preview on the canvas)."""

from __future__ import annotations

import math
from dataclasses import replace

from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.world_file import CONTROLLERS, DEFAULT_SHAPE, SENSOR_TYPES, RobotSpec, SensorSpec
from studio.shell import svg
from studio.simrobot.doc import new_sensor, parse_vertices, vertices_text
from studio.simrobot.editor_algorithms import AlgorithmChoice
from studio.simrobot.editor_base import EditorBase

NO_CONTROLLER = "(none: topics)"


class EditorForm(EditorBase):
    """The robot and sensor forms, filled from the selection and written back on each edit."""

    filling = False  # while the form is being filled from the selection (no edits)

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
                ).classes("w-56 simrobot-controller")
                self.algorithms = AlgorithmChoice(self.f_controller, self.studio.workspace, NO_CONTROLLER)
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
                **self.algorithms.chosen(),  # controller=…, algorithm=…
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
