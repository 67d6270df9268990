"""The Simulator page's runs: start and stop a world (New world), a controller (Autonomous) and
the recorder (Save Data)."""

from __future__ import annotations

import asyncio
import itertools
import os
from collections.abc import Callable

from nicegui import ui

from sim_runtime.errors import InputError
from studio.create.family import create_family
from studio.create.matlab_program import ProgramChoice, program_of
from studio.create.sim_tab import SimTab
from studio.shell.app import Studio, recording_clock
from studio.shell.kit import stop_started_world
from studio.shell.processes import (
    Child,
    clock_topic,
    controller_command,
    executable_command,
    namespace_args,
    world_ros_args,
)

RECORDER_START_S = 30.0
"""How long Record waits for the recorder to subscribe to every topic before saying which it lacks."""
RECORDINGS = itertools.count(1)


def initial_pose(x: float | None, y: float | None, theta: float | None) -> tuple[float, float, float]:
    """The New world pose fields as numbers; InputError naming an empty (or not numeric) one, which
    the browser hands over as None (it used to start the world at 0)."""
    if x is None or y is None or theta is None:
        name = "x" if x is None else "y" if y is None else "θ"
        raise InputError(f"initial pose {name}: a number is needed")
    return float(x), float(y), float(theta)


class WorldPanel:
    """New world: a ``create_world`` started from the page, and the one-line end of any that ended."""

    def __init__(self, tab: SimTab, started: Callable[[str], None]) -> None:
        self.tab = tab
        self.started = started  # the page follows a world it started: ``started(namespace)``
        # Worlds whose end this page has shown. Every open page shows a world's end (a tab left open
        # earlier must not swallow the error of a world started from this one).
        self.endings_shown: set[Child] = set()

    def build(self) -> None:
        ws = self.tab.studio.workspace
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
                self.world_ns = ui.input("namespace", value=self.tab.studio.free_namespace("create")).classes(
                    "w-28 studio-world-ns"
                )
            with ui.row().classes("gap-2"):
                ui.button("Start world", on_click=self.start_world).props("dense").classes("studio-start-world")
                ui.button("Stop world", on_click=self.stop_world).props("dense outline")
            self.world_label = ui.label("").classes("text-sm text-red-700 break-all studio-world-error")

    def show_ending(self, ns: str, world: Child) -> None:
        """A world that ended (bad map, pose in a wall): its one-line error."""
        self.endings_shown.add(world)
        self.world_label.set_text(f"{ns or '/'}: {world.error_line()}")

    def show_endings(self) -> None:
        """The end of every world the studio started that ended since the last look."""
        for ns, world in list(self.tab.worlds.items()):
            if not world.running and world not in self.endings_shown:
                self.show_ending(ns, world)

    def asked(self) -> tuple[str, str, str, tuple[float, float, float]]:
        """The namespace, map file, config file (absolute, '' for none) and pose the fields ask for."""
        ws = self.tab.studio.workspace
        ns = (self.world_ns.value or "").strip().rstrip("/")
        if ns and not ns.startswith("/"):
            ns = "/" + ns
        map_file = str(ws.path(self.world_map.value)) if (self.world_map.value or "").strip() else ""
        config_file = str(ws.path(self.world_config.value)) if (self.world_config.value or "").strip() else ""
        return ns, map_file, config_file, initial_pose(self.world_x.value, self.world_y.value, self.world_theta.value)

    async def start_world(self) -> None:
        studio = self.tab.studio
        self.world_label.set_text("")
        try:
            ns, map_file, config_file, pose = self.asked()
        except InputError as err:
            self.world_label.set_text(f"error: {err}")
            return
        refusal = studio.namespace_refusal(ns) or (
            f"a Create world already runs in {ns or '/'}: give another namespace or stop it"
            if ns in self.tab.ros.robots
            else None
        )
        if refusal:
            self.world_label.set_text(f"error: {refusal}")
            return
        owns_clock = studio.clock_owner() is None
        child = Child(
            f"create_world {ns or '/'}",
            executable_command("create_world", world_ros_args(ns, map_file, config_file, pose, owns_clock)),
            cwd=studio.workspace.root,
            clock=clock_topic(ns, owns_clock),
        )
        self.tab.worlds[ns] = child
        self.world_label.set_text(f"starting a world in {ns or '/'}…")
        if await self.followed(ns, child):
            self.world_label.set_text("")
            self.started(ns)
            self.world_ns.set_value(studio.free_namespace("create"))
            ui.notify(f"world started in {ns or '/'} (its clock: {child.clock})")

    async def followed(self, ns: str, child: Child) -> bool:
        """Whether the studio follows the world ``child`` started in ``ns`` within 10 s; a bad map
        or pose ends the world first, with its one-line error shown."""
        for _ in range(200):
            await asyncio.sleep(0.05)
            if not child.running:
                self.show_ending(ns, child)
                return False
            if ns in self.tab.ros.robots:
                return True
        return False

    async def stop_world(self) -> None:
        await stop_started_world(self.tab.worlds, self.tab.selected or "")


class ControllerPanel:
    """Autonomous: a controller started for the selected robot, following its world's clock."""

    def __init__(self, tab: SimTab, stop_robot: Callable[[], None]) -> None:
        self.tab = tab
        self.stop_robot = stop_robot  # a stopped controller leaves the robot standing

    def build(self) -> None:
        with ui.card().classes("w-full"):
            ui.label("Autonomous").classes("font-bold")
            with ui.row().classes("items-center gap-2"):
                names = list(self.tab.studio.controllers)
                self.controller_select = ui.select(names, value=names[0], label="controller").classes("w-48")
                ui.button("Start", on_click=self.start_controller).props("dense").classes("studio-controller-start")
                ui.button("Stop", on_click=self.stop_controller).props("dense outline").classes(
                    "studio-controller-stop"
                )
            self.programs = ProgramChoice(self.tab.studio, self.controller_select)  # .m files, in Octave
            self.controller_label = ui.label("").classes("text-sm studio-controller-state")

    def show_state(self) -> None:
        ns = self.tab.selected or ""
        stopping = create_family(self.tab.studio).stopping.get(ns)
        child = create_family(self.tab.studio).controllers.get(ns)
        self.controller_label.set_text(
            f"stopping {stopping.label}…"
            if stopping is not None
            else f"{child.label} running"
            if child and child.running
            else (f"{child.label} ended: {child.error_line()}" if child else "manual control")
        )

    async def start_controller(self) -> None:
        studio, ns = self.tab.studio, self.tab.selected
        if ns is None:
            ui.notify("no robot selected", type="warning")
            return
        running = create_family(studio).controllers.get(ns)
        if running and running.running:
            ui.notify(f"{running.label} already runs for {ns or '/'}", type="warning")
            return
        stopping = create_family(studio).stopping.get(ns)
        if stopping is not None:
            ui.notify(f"{stopping.label} is still stopping: start again once it has ended", type="warning")
            return
        name = self.controller_select.value
        program = program_of(name)
        if program is not None:
            await self.programs.start(ns, program)
            return
        target = studio.controllers[name]
        # The controller follows its world's clock (a world that does not own /clock publishes <ns>/clock).
        ros_args = namespace_args(ns, owns_clock=studio.clock_of(ns) == "/clock")
        command = controller_command(target, ros_args)
        create_family(studio).controllers[ns] = Child(name, command, cwd=studio.workspace.root)
        ui.notify(f"{name} started for {ns or '/'}")

    async def stop_controller(self) -> None:
        ns = self.tab.selected or ""
        if ns in create_family(self.tab.studio).stopping:
            return  # pressed again while it stops
        stopping = stop_controller(self.tab.studio, ns, self.stop_robot)
        self.show_state()  # "stopping …" at once, the end when it has ended
        await stopping
        self.show_state()


async def stop_controller(studio: Studio, ns: str, stop_robot: Callable[[], None]) -> Child | None:
    """Stop the controller of the Create in ``ns`` (it is gone from the family's ``controllers`` at
    once: a bridge still starting sees it was stopped) and leave the robot standing. The wait for
    it to end (up to 7 s: SIGINT, then SIGKILL) runs off NiceGUI's event loop, which keeps serving
    every tab meanwhile; the family's ``stopping`` table holds it until it has ended."""
    stop_robot()
    family = create_family(studio)
    child = family.controllers.pop(ns, None)
    if child is None:
        return None
    stopping = family.stopping
    stopping[ns] = child
    print(f"studio: stopping {child.label} for {ns or '/'}", flush=True)
    try:
        await asyncio.to_thread(child.stop)
    finally:
        del stopping[ns]
    print(f"studio: {child.label} for {ns or '/'} has ended", flush=True)
    stop_robot()  # again: a command it sent while stopping must not keep the robot moving
    return child


class RecordPanel:
    """Save Data: one recorder for the whole studio (every tab shows and stops it)."""

    def __init__(self, tab: SimTab) -> None:
        self.tab = tab

    def build(self) -> None:
        with ui.card().classes("w-full"):
            with ui.row().classes("items-center gap-2"):
                ui.label("Save Data").classes("font-bold")
                self.record_button = (
                    ui.button("Record", on_click=self.toggle_recording).props("dense").classes("studio-record")
                )
            self.record_label = ui.label("").classes("text-sm break-all studio-record-label")

    async def toggle_recording(self) -> None:
        studio = self.tab.studio
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
        topics = self.tab.ros.ros.published_topics()  # what "recording" promises to be in the bag
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
        studio = self.tab.studio
        recorder = studio.recorder
        running = recorder is not None and recorder.running
        self.record_button.set_text("Stop recording" if running else "Record")
        if recorder is not None and not running and studio.recording_status.startswith(("starting", "recording")):
            studio.recording_status = f"the recorder ended: {recorder.error_line()}"
        self.record_label.set_text(studio.recording_status)


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
