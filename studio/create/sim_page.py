"""The Simulator page (the original's SimulatorGUI): live view, status, driving, worlds, controllers, recording."""

from __future__ import annotations

import asyncio
import itertools
import math
import os
from html import escape

import numpy as np
from nicegui import events, ui

from create_sim.spec import CLIFF_NAMES, SONAR_NAMES
from create_sim.teleop import ANGULAR_STEP, LINEAR_STEP, MAX_ANGULAR_STEPS, MAX_LINEAR_STEPS
from sim_runtime.errors import InputError
from studio.create import draw
from studio.create.ros_client import CreateRos, RobotState, create_ros
from studio.shell import svg
from studio.shell.app import Studio, recording_clock
from studio.shell.kit import VIEW_SIZE, ZoomableView, nav, stop_started_world, view_image
from studio.shell.processes import (
    Child,
    clock_topic,
    controller_command,
    executable_command,
    namespace_args,
    world_ros_args,
)

FRAME_PERIOD_S = 0.04
"""The view is redrawn at most this often (25 frames/s), and only when a new reading came in."""
LAYERS = {
    "lidar": "LIDAR",
    "sonar": "Sonar",
    "wall": "IR wall",
    "bump": "Bump",
    "cliff": "Cliff",
    "camera": "Camera",
    "track": "Track",
    "fields": "Virtual-wall fields",
    "grid": "Grid",
}
RTF_OPTIONS = {0.25: "0.25×", 0.5: "0.5×", 1.0: "1× (real time)", 2.0: "2×", 4.0: "4×", 0.0: "as fast as possible"}
KEYS = {
    "ArrowUp": (1, 0),
    "w": (1, 0),
    "ArrowDown": (-1, 0),
    "s": (-1, 0),
    "ArrowLeft": (0, 1),
    "a": (0, 1),
    "ArrowRight": (0, -1),
    "d": (0, -1),
    " ": None,
    "Escape": None,
    "Enter": None,
}
"""Key → (linear steps, angular steps) change, None = stop: the keys of ``create_teleop``."""
SET_POSE_MIN_DRAG_PX = 5.0
RECORDER_START_S = 30.0
"""How long Record waits for the recorder to subscribe to every topic before saying which it lacks."""


def command_steps(command: tuple[float, float]) -> list[int]:
    """The teleop steps (linear, angular) nearest to a world's last command (m/s, rad/s): a key
    press changes the speed the world was last given, by whichever tab, teleop or controller."""
    return [round(command[0] / LINEAR_STEP), round(command[1] / ANGULAR_STEP)]


def initial_pose(x: float | None, y: float | None, theta: float | None) -> tuple[float, float, float]:
    """The New world pose fields as numbers; InputError naming an empty (or not numeric) one, which
    the browser hands over as None (it used to start the world at 0)."""
    for name, value in (("x", x), ("y", y), ("θ", theta)):
        if value is None:
            raise InputError(f"initial pose {name}: a number is needed")
    return float(x), float(y), float(theta)  # type: ignore[arg-type]


def fit_due(fitted_map_seq: int | None, map_seq: int) -> bool:
    """Whether the view fits (again): the robot is shown for the first time (``fitted_map_seq``
    None), or it was fitted before its map arrived (a fit to the robot alone is ±1 m around it)."""
    return fitted_map_seq is None or (fitted_map_seq == 0 and map_seq > 0)


def _fmt(value: float | None, digits: int = 3) -> str:
    if value is None:
        return "–"
    return f"{value:.{digits}f}" if math.isfinite(value) else ("+inf" if value > 0 else "-inf" if value < 0 else "nan")


def status_html(ns: str, st: RobotState) -> str:
    """The live Read Sensors table of one robot."""
    rows = [
        ("namespace", escape(ns or "/")),
        ("sim time (s)", _fmt(st.sim_time, 2)),
        ("real-time factor", _fmt(st.rtf, 2)),
    ]
    pose = st.pose or (None, None, None)
    odom = st.odom or (None, None, None)
    rows += [
        ("x (m) truth / odometry", f"{_fmt(pose[0])} / {_fmt(odom[0])}"),
        ("y (m) truth / odometry", f"{_fmt(pose[1])} / {_fmt(odom[1])}"),
        ("θ (rad) truth / odometry", f"{_fmt(pose[2])} / {_fmt(odom[2])}"),
        ("v (m/s), ω (rad/s)", f"{_fmt(st.velocity[0], 2)}, {_fmt(st.velocity[1], 2)}"),
        ("bump left / right", f"{int(st.bumps[0])} / {int(st.bumps[1])}"),
        ("wall / virtual wall", f"{int(st.wall)} / {int(st.virtual_wall)}"),
        (
            "cliff (%) " + " ".join(n.replace("_", "-") for n in CLIFF_NAMES),
            " ".join(_fmt(st.cliffs.get(n), 1) for n in CLIFF_NAMES),
        ),
        ("sonar (m) " + " ".join(SONAR_NAMES), " ".join(_fmt(st.sonar.get(n), 2) for n in SONAR_NAMES)),
    ]
    if st.scan is not None:
        ranges = st.scan[2]
        finite = ranges[np.isfinite(ranges)]
        nearest = _fmt(float(finite.min()), 2) if len(finite) else "none"
        rows.append(("LIDAR beams, nearest (m)", f"{len(ranges)}, {nearest}"))
    sightings = ", ".join(
        f"{escape(i)} at {math.hypot(x, y):.2f} m {math.degrees(math.atan2(y, x)):.0f}°" for x, y, i in st.sightings
    )
    rows.append(("camera beacons", sightings or "none"))
    body = "".join(f"<tr><td class='pr-3 text-gray-600'>{k}</td><td class='font-mono'>{v}</td></tr>" for k, v in rows)
    return f"<table class='studio-status text-sm'>{body}</table>"


def register(studio: Studio) -> None:
    @ui.page("/")
    def simulator_page() -> None:
        SimulatorPage(studio)


class SimulatorPage(ZoomableView):
    """One browser tab's simulator view: its own zoom, layers and selected robot."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.view = svg.View(*VIEW_SIZE, scale=60.0)
        self.selected: str | None = None
        self.layers = set(LAYERS)
        self.centred = False
        self.mouse_mode = "pan"
        self.drawn_seq = -1
        self.drawn_map: tuple[str | None, int] = (None, -1)
        self.view_dirty = True
        self.mouse_down: tuple[float, float] | None = None  # pixel of the mouse press
        self.view_at_press = (0.0, 0.0)
        self.fitted: dict[str, int] = {}  # namespace → its map_seq when the view was fitted to it
        # Worlds whose end this page has shown. Every open page shows a world's end (a tab left open
        # earlier must not swallow the error of a world started from this one).
        self.endings_shown: set[Child] = set()
        self.frames = 0
        self.build()

    # ---------------------------------------------------------------- layout
    def build(self) -> None:
        nav("/")
        # Keys still drive after a click on a button, switch or checkbox: a clicked control gives the
        # focus back at once, so Space stops the robot instead of pressing Record again. Only
        # typing in a text field is left alone.
        ui.add_body_html(
            "<script>document.addEventListener('pointerup', (e) => {"
            " const c = e.target.closest && e.target.closest('button, .q-toggle, .q-checkbox, .q-btn');"
            " if (c) setTimeout(() => document.activeElement && document.activeElement.blur(), 0); });</script>"
        )
        ui.keyboard(on_key=self.on_key, ignore=["input", "select", "textarea"])
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.image = view_image(self.on_mouse, self.on_wheel, "studio-view", "#fafafa")
                self.dynamic = self.image.add_layer()
                self.overlay = self.image.add_layer()
                with ui.row().classes("items-center gap-2"):
                    ui.toggle(
                        {"pan": "Pan", "pose": "Set position"}, value="pan", on_change=self.on_mouse_mode
                    ).classes("studio-mouse-mode")
                    ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
                    ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
                    ui.button("Fit map", on_click=self.fit).props("dense flat")
                    ui.checkbox("Robot-centred", on_change=self.on_centred)
                with ui.row().classes("gap-3"):
                    for key, text in LAYERS.items():
                        ui.checkbox(
                            text, value=key in self.layers, on_change=lambda e, k=key: self.toggle_layer(k, e.value)
                        )
            with ui.column().classes("gap-2 w-[430px]"):
                with ui.row().classes("items-center gap-2 w-full"):
                    self.robot_select = ui.select([], label="Robot (namespace)", on_change=self.on_select).classes(
                        "w-56 studio-robot"
                    )
                    self.no_world = ui.label("no Create world found yet").classes("text-orange-700 text-sm")
                self.build_world_panel()
                self.build_drive_card()
                self.build_controller_card()
                self.build_record_card()
                self.status = ui.html("", sanitize=False).classes("w-full")
        ui.timer(FRAME_PERIOD_S, self.tick)
        ui.timer(0.5, self.slow_tick)

    def build_drive_card(self) -> None:
        """Manual control: arrows, joystick, Play/Advance/Reset, speed, pause and step."""
        with ui.card().classes("w-full"):
            ui.label("Manual control (arrows/WASD, space = stop)").classes("font-bold")
            with ui.row().classes("items-center gap-6"):
                with ui.grid(columns=3).classes("gap-1 w-40"):
                    ui.element()
                    self.drive_button("▲", 1, 0).classes("studio-forward")
                    ui.element()
                    self.drive_button("◀", 0, 1)
                    self.drive_button("■", 0, 0).props("color=red").classes("studio-stop")
                    self.drive_button("▶", 0, -1)
                    ui.element()
                    self.drive_button("▼", -1, 0)
                ui.joystick(on_move=self.on_joystick, on_end=lambda _: self.stop(), color="#1565c0", size=70).classes(
                    "w-28 h-28 bg-slate-100 rounded-full"
                )
            self.command_label = ui.label("v 0.00 m/s, ω 0.00 rad/s").classes("font-mono text-sm")
            with ui.row().classes("items-center gap-2"):
                ui.switch("Play", on_change=lambda e: self.press(0, e.value))
                ui.switch("Advance", on_change=lambda e: self.press(1, e.value))
                ui.button("Reset", on_click=self.reset).props("dense outline")
            with ui.row().classes("items-center gap-2"):
                self.rtf_select = ui.select(
                    RTF_OPTIONS, value=1.0, label="Speed (real_time_factor)", on_change=self.on_rtf
                ).classes("w-48 studio-rtf")
                self.pause_switch = ui.switch("Pause", on_change=self.on_pause).classes("studio-pause")
                ui.button("Step", on_click=self.step_once).props("dense outline").classes("studio-step")

    def build_controller_card(self) -> None:
        """Autonomous: start and stop a controller for the selected robot."""
        with ui.card().classes("w-full"):
            ui.label("Autonomous").classes("font-bold")
            with ui.row().classes("items-center gap-2"):
                names = list(self.studio.controllers)
                self.controller_select = ui.select(names, value=names[0], label="controller").classes("w-48")
                ui.button("Start", on_click=self.start_controller).props("dense").classes("studio-controller-start")
                ui.button("Stop", on_click=self.stop_controller).props("dense outline").classes(
                    "studio-controller-stop"
                )
            self.controller_label = ui.label("").classes("text-sm")

    def build_record_card(self) -> None:
        """Save Data: record every published topic to a bag in the workspace."""
        with ui.card().classes("w-full"):
            with ui.row().classes("items-center gap-2"):
                ui.label("Save Data").classes("font-bold")
                self.record_button = (
                    ui.button("Record", on_click=self.toggle_recording).props("dense").classes("studio-record")
                )
            self.record_label = ui.label("").classes("text-sm break-all studio-record-label")

    def build_world_panel(self) -> None:
        ws = self.studio.workspace
        with ui.expansion("New world", icon="add").classes("w-full border studio-new-world"):
            self.world_map = ui.input("map file (empty = open floor)", autocomplete=ws.files((".map", ".txt"))).classes(
                "w-full studio-world-map"
            )
            self.world_config = ui.input(
                "config file (empty = noise-free)", autocomplete=ws.files((".cfg", ".txt", ".config"))
            ).classes("w-full studio-world-config")
            with ui.row().classes("gap-2 no-wrap"):
                self.world_x = ui.number("x (m)", value=0.0, step=0.1).classes("w-20")
                self.world_y = ui.number("y (m)", value=0.0, step=0.1).classes("w-20")
                self.world_theta = ui.number("θ (rad)", value=0.0, step=0.1).classes("w-20")
                self.world_ns = ui.input("namespace", value=self.studio.free_namespace("create")).classes(
                    "w-28 studio-world-ns"
                )
            with ui.row().classes("gap-2"):
                ui.button("Start world", on_click=self.start_world).props("dense").classes("studio-start-world")
                ui.button("Stop world", on_click=self.stop_world).props("dense outline")
            self.world_label = ui.label("").classes("text-sm text-red-700 break-all studio-world-error")

    # ---------------------------------------------------------------- robots
    @property
    def ros(self) -> CreateRos:
        """The studio's Create client: the app makes it at start-up, before any page is served."""
        ros = create_ros(self.studio)
        if ros is None:
            raise RuntimeError("the studio's ROS client has not started")
        return ros

    def robot(self) -> RobotState | None:
        ros = create_ros(self.studio)
        return None if ros is None or self.selected is None else ros.robots.get(self.selected)

    def picked(self) -> str | None:
        """The selected namespace while its world is followed (None: no robot to command)."""
        return self.selected if self.robot() is not None else None

    async def on_select(self, e) -> None:
        self.selected = e.value
        if e.value is not None:
            self.studio.selected = e.value
        self.view_dirty = True
        if self.robot() is None:
            return
        try:  # show the selected world's speed
            rtf = await self.ros.get_parameter(self.selected, "real_time_factor")
        except TimeoutError:
            return
        if rtf is not None and float(rtf) in RTF_OPTIONS and float(rtf) != self.rtf_select.value:
            self.rtf_select.set_value(float(rtf))

    def show_ending(self, ns: str, world: Child) -> None:
        """A world that ended (bad map, pose in a wall): its one-line error."""
        self.endings_shown.add(world)
        self.world_label.set_text(f"{ns or '/'}: {world.error_line()}")

    def slow_tick(self) -> None:
        ros = create_ros(self.studio)
        if ros is None:
            return
        names = ros.namespaces()
        if names != list(self.robot_select.options):
            value = self.studio.default_robot(names, self.selected)
            self.robot_select.set_options({ns: ns or "/" for ns in names}, value=value)
        self.no_world.set_visibility(not names)
        st = self.robot()
        if st is not None and self.selected is not None:
            self.status.set_content(status_html(self.selected, st))
            self.show_command(st.command)
        for ns, world in list(self.studio.worlds.items()):
            if not world.running and world not in self.endings_shown:
                self.show_ending(ns, world)
        child = self.studio.running_controllers.get(self.selected or "")
        self.controller_label.set_text(
            f"{child.label} running"
            if child and child.running
            else (f"{child.label} ended: {child.error_line()}" if child else "manual control")
        )
        if self.studio.recorder is not None:
            self.show_recording()

    # ---------------------------------------------------------------- drawing
    def tick(self) -> None:
        st, ns = self.robot(), self.selected
        if st is None or st.pose is None or ns is None:
            return
        if fit_due(self.fitted.get(ns), st.map_seq):
            self.fitted[ns] = st.map_seq
            self.fit()
        if self.centred:
            self.view.centre_x, self.view.centre_y = st.pose[0], st.pose[1]
            self.view_dirty = True
        if self.view_dirty or self.drawn_map != (self.selected, st.map_seq):
            self.drawn_map = (self.selected, st.map_seq)
            base = svg.grid_svg(self.view, 0.5) if "grid" in self.layers else ""
            self.image.set_content(base + draw.map_svg(self.view, st.map, fields="fields" in self.layers))
        if self.view_dirty or st.seq != self.drawn_seq:
            self.drawn_seq = st.seq
            self.view_dirty = False
            self.dynamic.set_content(self.dynamic_svg(st, st.pose))
            self.frames += 1

    def dynamic_svg(self, st: RobotState, pose: tuple[float, float, float]) -> str:
        v = self.view  # the transform, for tools and tests that map pixels back to metres
        parts = [
            f'<g class="view" data-centre-x="{float(v.centre_x)!r}" data-centre-y="{float(v.centre_y)!r}" '
            f'data-scale="{float(v.scale)!r}"/>'
        ]
        for ns, other in self.ros.robots.items():
            if ns != self.selected and other.pose is not None:
                parts.append(draw.robot_svg(self.view, other.pose, selected=False, label=ns))
        track = np.array(list(st.track)) if "track" in self.layers else None  # list(): one atomic copy
        readings = draw.readings_of(st, track)
        parts.append(draw.sensors_svg(self.view, readings, self.layers))
        parts.append(draw.robot_svg(self.view, pose, selected=True, label=self.selected or ""))
        return "".join(parts)

    def view_changed(self) -> None:
        self.view_dirty = True

    def fit(self) -> None:
        st = self.robot()
        if st is None:
            return
        w = st.map
        xs = np.concatenate(
            [w.walls[:, 0], w.walls[:, 2], w.lines[:, 0], w.lines[:, 2], w.beacon_xy[:, 0], w.virtwalls[:, 0]]
        )
        ys = np.concatenate(
            [w.walls[:, 1], w.walls[:, 3], w.lines[:, 1], w.lines[:, 3], w.beacon_xy[:, 1], w.virtwalls[:, 1]]
        )
        if st.pose is not None:
            xs, ys = np.append(xs, st.pose[0]), np.append(ys, st.pose[1])
        self.view.fit(xs, ys, margin_m=1.0)
        self.view_dirty = True

    def on_centred(self, e) -> None:
        self.centred = e.value
        self.view_dirty = True

    # ---------------------------------------------------------------- mouse: pan or set position
    def on_mouse_mode(self, e) -> None:
        self.mouse_mode = e.value
        self.overlay.set_content("")

    def on_mouse(self, e) -> None:
        if e.type == "mousedown":
            self.mouse_down = (e.image_x, e.image_y)
            self.view_at_press = (self.view.centre_x, self.view.centre_y)
            return
        if self.mouse_down is None:
            return
        px, py = self.mouse_down
        if self.mouse_mode == "pan":
            self.view.pan(self.view_at_press, e.image_x - px, e.image_y - py)
            self.view_dirty = True
            if e.type == "mouseup":
                self.mouse_down = None
            return
        if e.type == "mousemove":
            self.overlay.set_content(
                f'<circle cx="{px:.1f}" cy="{py:.1f}" r="6" fill="#1565c0"/>'
                f'<line x1="{px:.1f}" y1="{py:.1f}" x2="{e.image_x:.1f}" y2="{e.image_y:.1f}" '
                'stroke="#1565c0" stroke-width="3"/>'
            )
        elif e.type == "mouseup":
            self.mouse_down = None
            self.overlay.set_content("")
            st, ns = self.robot(), self.selected
            if st is None or ns is None:
                return
            x, y = self.view.to_world(px, py)
            if math.hypot(e.image_x - px, e.image_y - py) >= SET_POSE_MIN_DRAG_PX:
                theta = math.atan2(-(e.image_y - py), e.image_x - px)
            else:
                theta = st.pose[2] if st.pose else 0.0
            self.ros.set_pose(ns, x, y, theta)
            st.track.clear()  # no line across the jump
            ui.notify(f"set_pose x={x:.2f} y={y:.2f} θ={theta:.2f}")

    # ---------------------------------------------------------------- driving
    def on_key(self, e) -> None:
        # One step per press: a held key (auto-repeat) does not run the speed up to the limit.
        if not e.action.keydown or e.action.repeat or e.modifiers.ctrl or e.modifiers.alt or e.modifiers.meta:
            return
        name = e.key.name if len(e.key.name) > 1 else e.key.name.lower()
        if name not in KEYS:
            return
        change = KEYS[name]
        if change is None:
            self.stop()
        else:
            self.change(*change)

    def drive_button(self, text: str, linear: int, angular: int) -> ui.button:
        """An arrow button (■ = stop)."""

        def clicked() -> None:
            if linear or angular:
                self.change(linear, angular)
            else:
                self.stop()

        return ui.button(text, on_click=clicked).props("dense")

    def on_joystick(self, e: events.JoystickEventArguments) -> None:
        """Joystick: up/down = forward speed, left/right = turn rate, up to the teleop limits."""
        ns = self.picked()
        if ns is None or e.x is None or e.y is None:
            return
        if self.controller_running():
            return
        v = round(e.y * MAX_LINEAR_STEPS * LINEAR_STEP, 2)
        w = round(-e.x * MAX_ANGULAR_STEPS * ANGULAR_STEP, 2)
        self.ros.drive(ns, v, w)
        self.show_command((v, w))

    def controller_running(self) -> bool:
        child = self.studio.running_controllers.get(self.selected or "")
        return child is not None and child.running

    def change(self, linear: int, angular: int) -> None:
        st = self.robot()
        if self.selected is None or st is None:
            ui.notify("no robot selected", type="warning")
            return
        if self.controller_running():
            ui.notify("a controller is driving: Stop it for manual control", type="warning")
            return
        steps = command_steps(st.command)
        steps[0] = max(-MAX_LINEAR_STEPS, min(MAX_LINEAR_STEPS, steps[0] + linear))
        steps[1] = max(-MAX_ANGULAR_STEPS, min(MAX_ANGULAR_STEPS, steps[1] + angular))
        self.send(steps)

    def stop(self) -> None:
        if self.selected is None or self.robot() is None:
            return
        self.send([0, 0])

    def send(self, steps: list[int]) -> None:
        ns = self.picked()
        if ns is None:
            return
        v, w = steps[0] * LINEAR_STEP, steps[1] * ANGULAR_STEP
        self.ros.drive(ns, v, w)
        self.show_command((v, w))

    def show_command(self, command: tuple[float, float]) -> None:
        self.command_label.set_text(f"v {command[0]:.2f} m/s, ω {command[1]:.2f} rad/s")

    async def press(self, button: int, down: bool) -> None:
        ns = self.picked()
        if ns is None:
            return
        try:
            ui.notify(await self.ros.press(ns, button, down))
        except TimeoutError as err:
            ui.notify(str(err), type="negative")

    async def reset(self) -> None:
        ns = self.picked()
        if ns is None:
            return
        try:
            ui.notify(await self.ros.reset(ns))
        except TimeoutError as err:
            ui.notify(str(err), type="negative")
        st = self.robot()
        if st is not None:
            st.track.clear()
            st.command = (0.0, 0.0)  # the reset world stands still

    async def on_pause(self, e) -> None:
        """Hold or release the selected world (its live ``paused`` parameter)."""
        ns = self.picked()
        if ns is None:
            return
        try:
            refused = await self.ros.set_parameters(ns, {"paused": bool(e.value)})
        except TimeoutError as err:
            refused = [str(err)]
        for reason in refused:
            ui.notify(reason, type="negative")

    async def step_once(self) -> None:
        """One physics step of the paused world (SimulatorGUI's step)."""
        ns = self.picked()
        if ns is None:
            return
        try:
            done, message = await self.ros.step(ns)
        except TimeoutError as err:
            done, message = False, str(err)
        ui.notify(message, type="positive" if done else "negative")

    async def on_rtf(self, e) -> None:
        ns = self.picked()
        if ns is None or e.value is None:
            return
        try:
            refused = await self.ros.set_parameters(ns, {"real_time_factor": float(e.value)})
        except TimeoutError as err:
            refused = [str(err)]
        for reason in refused:
            ui.notify(reason, type="negative")

    # ---------------------------------------------------------------- worlds, controllers, recording
    async def start_world(self) -> None:
        studio, ws = self.studio, self.studio.workspace
        ns = (self.world_ns.value or "").strip().rstrip("/")
        if ns and not ns.startswith("/"):
            ns = "/" + ns
        self.world_label.set_text("")
        try:
            map_file = str(ws.path(self.world_map.value)) if (self.world_map.value or "").strip() else ""
            config_file = str(ws.path(self.world_config.value)) if (self.world_config.value or "").strip() else ""
            pose = initial_pose(self.world_x.value, self.world_y.value, self.world_theta.value)
        except InputError as err:
            self.world_label.set_text(f"error: {err}")
            return
        refusal = studio.namespace_refusal(ns) or (
            f"a Create world already runs in {ns or '/'}: give another namespace or stop it"
            if ns in self.ros.robots
            else None
        )
        if refusal:
            self.world_label.set_text(f"error: {refusal}")
            return
        owns_clock = studio.clock_owner() is None
        child = Child(
            f"create_world {ns or '/'}",
            executable_command("create_world", world_ros_args(ns, map_file, config_file, pose, owns_clock)),
            cwd=ws.root,
            clock=clock_topic(ns, owns_clock),
        )
        studio.worlds[ns] = child
        self.world_label.set_text(f"starting a world in {ns or '/'}…")
        for _ in range(200):  # a bad map or pose ends the world with its one-line error
            await asyncio.sleep(0.05)
            if not child.running:
                self.show_ending(ns, child)
                return
            if ns in self.ros.robots:
                break
        else:
            return
        self.world_label.set_text("")
        self.selected = self.studio.selected = ns
        if ns in self.robot_select.options:
            self.robot_select.set_value(ns)
        self.fitted.pop(ns, None)
        self.view_dirty = True
        self.world_ns.set_value(studio.free_namespace("create"))
        ui.notify(f"world started in {ns or '/'} (its clock: {child.clock})")

    def stop_world(self) -> None:
        stop_started_world(self.studio.worlds, self.selected or "")

    def start_controller(self) -> None:
        ns = self.selected
        if ns is None:
            ui.notify("no robot selected", type="warning")
            return
        running = self.studio.running_controllers.get(ns)
        if running and running.running:
            ui.notify(f"{running.label} already runs for {ns or '/'}", type="warning")
            return
        name = self.controller_select.value
        target = self.studio.controllers[name]
        # The controller follows its world's clock (a world that does not own /clock publishes <ns>/clock).
        ros_args = namespace_args(ns, owns_clock=self.studio.clock_of(ns) == "/clock")
        self.studio.running_controllers[ns] = Child(
            name, controller_command(target, ros_args), cwd=self.studio.workspace.root
        )
        ui.notify(f"{name} started for {ns or '/'}")

    def stop_controller(self) -> None:
        child = self.studio.running_controllers.pop(self.selected or "", None)
        if child is not None:
            child.stop()
        self.stop()

    async def toggle_recording(self) -> None:
        studio = self.studio
        if studio.recorder is not None and studio.recorder.running:
            recorder = studio.recorder
            studio.recording_status = f"finishing {studio.recording_to}…"
            self.show_recording()
            await asyncio.to_thread(recorder.stop, 10.0)  # the page stays live while the bag is finished
            studio.recording_status = f"saved {studio.recording_to}"
            self.show_recording()
            return
        ws = studio.workspace
        name = ws.new_folder_name("studio_data/SimulatorOutputData")
        ws.path(name).parent.mkdir(parents=True, exist_ok=True)
        topics = self.ros.published_topics()  # what "recording" promises to be in the bag
        clock, timeline = recording_clock(studio.graph_worlds())
        node_name = f"studio_record_{os.getpid()}_{next(RECORDINGS)}"
        args = ["-o", str(ws.path(name)), "--clock", clock, "--ros-args", "-r", f"__node:={node_name}"]
        studio.recording_to = name
        studio.recorder = recorder = Child("record", executable_command("record", args), cwd=ws.root)
        studio.recording_status = f"starting the recorder for {name}…"
        self.show_recording()
        status = await recorder_ready(studio, recorder, node_name, topics, name, timeline)
        if studio.recorder is recorder and recorder.running:  # not stopped meanwhile
            studio.recording_status = status
        self.show_recording()

    def show_recording(self) -> None:
        recorder = self.studio.recorder
        running = recorder is not None and recorder.running
        self.record_button.set_text("Stop recording" if running else "Record")
        if recorder is not None and not running and self.studio.recording_status.startswith(("starting", "recording")):
            self.studio.recording_status = f"the recorder ended: {recorder.error_line()}"
        self.record_label.set_text(self.studio.recording_status)


RECORDINGS = itertools.count(1)


async def recorder_ready(
    studio: Studio, recorder: Child, node_name: str, topics: list[str], name: str, timeline: str
) -> str:
    """Wait until ``recorder`` (node ``node_name``) subscribes to every topic of ``topics`` still
    published: only then is the run being recorded (a loaded machine takes seconds to start it).
    Returns the line the page shows."""
    deadline = asyncio.get_running_loop().time() + RECORDER_START_S
    while True:
        if not recorder.running:
            return f"the recorder ended: {recorder.error_line()}"
        if studio.recorder is not recorder:
            return ""
        ros = studio.ros
        waiting = ros.not_subscribed(topics, node_name) if ros is not None else topics
        if not waiting:
            return f"recording to {name} ({timeline})"
        if asyncio.get_running_loop().time() > deadline:
            return f"recording to {name} ({timeline}); not yet recording {', '.join(waiting[:5])}"
        await asyncio.sleep(0.1)
