"""``robot_sims studio``: start the web app (pages in sim_page, map_page, config_page)."""

from __future__ import annotations

import argparse
import ipaddress
import os
import socket
import sys
from dataclasses import dataclass, field
from typing import Any

from sim_runtime.errors import InputError
from sim_runtime.run import split_ros_args
from studio.processes import CLOCK, Child, parse_controller, stop_all
from studio.workspace import Workspace

DEFAULT_CONTROLLERS = {"create_bump_turn": "create_bump_turn"}
WHEEL_JS = "(e) => emit({dy: e.deltaY, x: e.offsetX, y: e.offsetY, w: e.target.clientWidth, h: e.target.clientHeight})"
"""A view's wheel events, reduced to what zooming needs (pixel position, scroll direction)."""


@dataclass
class Studio:
    """What every page shares: the workspace, the ROS client and the child processes."""

    workspace: Workspace
    controllers: dict[str, str]
    ros: object = None  # studio.ros_client.StudioRos once the app has started
    worlds: dict[str, Child] = field(default_factory=dict)  # namespace → world the studio started
    running_controllers: dict[str, Child] = field(default_factory=dict)  # namespace → controller
    selected: str | None = None  # the Create last picked or started: every page's default
    recorder: Child | None = None
    arm: dict = field(default_factory=dict)  # the arm page's shared client and mesh cache
    recording_to: str = ""
    recording_status: str = ""  # the Save Data line every tab shows: starting, recording to, saved

    def default_robot(self, names: list[str], current: str | None) -> str | None:
        """What a robot selector shows: its current choice, else the studio's, else the first."""
        for choice in (current, self.selected):
            if choice in names:
                return choice
        return names[0] if names else None

    def world_children(self) -> dict[str, Child]:
        """namespace → running world the studio started, of every kind (Create, arm, SIMROBOT)."""
        simrobot = getattr(self, "simrobot", None)
        started = {**self.worlds, **(simrobot.worlds if simrobot is not None else {})}
        return {key.removeprefix("arm:"): child for key, child in started.items() if child.running}

    def graph_worlds(self) -> list[tuple[str, str]]:
        """``(clock topic, namespace)`` of every world on the domain, started here or not."""
        clocks = getattr(self.ros, "clock_publishers", None)
        return clocks() if clocks is not None else []

    def namespace_refusal(self, ns: str) -> str | None:
        """Why a new world may not start in ``ns`` (None: it may): a world already runs there, or
        in the root where ``/clock`` is taken (a root world cannot move its clock)."""
        where = ns or "/"
        child = self.world_children().get(ns)
        if child is not None:
            return f"{child.label} already runs in {where}: give another namespace or stop it"
        graph = self.graph_worlds()
        if ns in world_namespaces(graph):
            return f"a world already runs in {where} (started elsewhere): give another namespace"
        owner = self.clock_owner(graph)
        if not ns and owner is not None:
            return f"the world in {owner or '/'} publishes /clock: a world in / would publish a second one"
        return None

    def clock_owner(self, graph: list[tuple[str, str]] | None = None) -> str | None:
        """The namespace of the world publishing ``/clock`` (None: nobody does yet)."""
        for ns, child in self.world_children().items():
            if child.clock == CLOCK:
                return ns
        owners = [ns for topic, ns in (self.graph_worlds() if graph is None else graph) if topic == CLOCK]
        return owners[0] if owners else None

    def clock_of(self, ns: str) -> str:
        """The clock topic of the world in ``ns`` (started here or elsewhere; ``/clock`` if unknown):
        what a controller started for it follows."""
        child = self.world_children().get(ns)
        if child is not None:
            return child.clock
        own = [topic for topic, _node_ns in self.graph_worlds() if topic != CLOCK and topic.removesuffix(CLOCK) == ns]
        return own[0] if own else CLOCK

    def free_namespace(self, stem: str) -> str:
        """``/<stem>1``, ``/<stem>2``, …: the first namespace no world uses (a new world's default)."""
        taken = set(self.world_children()) | world_namespaces(self.graph_worlds())
        n = 1
        while f"/{stem}{n}" in taken:
            n += 1
        return f"/{stem}{n}"

    def stop_children(self) -> None:
        """Stop the recorder, controllers and worlds together (Ctrl-C must not wait for each in turn)."""
        simrobot = getattr(self, "simrobot", None)
        children = [
            self.recorder,
            *self.running_controllers.values(),
            *self.worlds.values(),
            *(simrobot.worlds.values() if simrobot is not None else ()),
        ]
        stop_all([child for child in children if child is not None], patient=self.recorder)


def world_namespaces(graph: list[tuple[str, str]]) -> set[str]:
    """The namespaces holding a world, from ``(clock topic, publishing node's namespace)`` pairs: a
    world publishes ``<ns>/clock``, or ``/clock`` from a node in ``ns``."""
    return {ns if topic == CLOCK else topic.removesuffix(CLOCK) for topic, ns in graph}


def recording_clock(graph: list[tuple[str, str]]) -> tuple[str, str]:
    """The recorder's ``--clock`` and what it means, for the worlds on the domain: one world
    publishing ``/clock`` → its sim time; several worlds (each its own sim time, speed and pauses)
    → wall time, the one timeline they share."""
    worlds = sorted(world_namespaces(graph))
    if len(worlds) == 1 and any(topic == CLOCK for topic, _ns in graph):
        return "sim", f"sim time of the world in {worlds[0] or '/'}"
    if not worlds:
        return "auto", "no world running: wall time until one publishes /clock"
    return "wall", f"wall time: {len(worlds)} worlds, each with its own sim time" if len(worlds) > 1 else (
        f"wall time: the world in {worlds[0]} publishes {worlds[0]}/clock"
    )


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="robot_sims studio",
        description="The Create simulator, map maker and config maker in the browser.",
    )
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1, this machine only)"
    )
    parser.add_argument("--port", type=int, default=8080, help="port (default 8080)")
    parser.add_argument(
        "--workspace", default=".", help="the only folder whose files the pages read and write (default: here)"
    )
    parser.add_argument(
        "--controller",
        action="append",
        default=[],
        metavar="NAME=TARGET",
        help="a controller the Start button may run: name=module:function or name=command (repeatable)",
    )
    parser.add_argument("--show", action="store_true", help="open a browser tab")
    return parser.parse_args(argv)


def host_warning(host: str) -> str | None:
    """The warning printed when listening beyond this machine (None for loopback)."""
    try:
        if ipaddress.ip_address(host).is_loopback:
            return None
    except ValueError:
        if host == "localhost":
            return None
    return (
        f"warning: the studio listens on {host}: anyone who can reach this address can drive your robots "
        "and read and write files in the workspace. Use --host 127.0.0.1 unless you mean it."
    )


def main(argv: list[str] | None = None) -> int:
    """Entry point ``studio``."""
    args, _ros_args = split_ros_args(sys.argv if argv is None else ["studio", *argv])
    options = parse_args(args)
    try:
        workspace = Workspace(options.workspace)
        controllers = dict(DEFAULT_CONTROLLERS)
        controllers.update(parse_controller(spec) for spec in options.controller)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    try:  # a taken port or unknown address: one line, not uvicorn's traceback
        with socket.create_server((options.host, options.port)):
            pass
    except OSError as err:
        print(f"error: cannot listen on {options.host}:{options.port}: {err.strerror or err}", file=sys.stderr)
        return 2
    warning = host_warning(options.host)
    if warning:
        print(warning, file=sys.stderr)

    from nicegui import app, ui

    from studio import arm_page, config_page, map_page, replay_page, sim_page, simrobot_editor_page, simrobot_page
    from studio.ros_client import StudioRos

    studio = Studio(workspace=workspace, controllers=controllers)

    def startup() -> None:
        studio.ros = StudioRos()

    def shutdown() -> None:
        if studio.ros is None:
            return  # done already
        print("robot_sims studio: stopping what it started", flush=True)
        studio.stop_children()
        studio.ros.shutdown()
        studio.ros = None

    app.on_startup(startup)
    app.on_shutdown(shutdown)
    sim_page.register(studio)
    map_page.register(studio)
    config_page.register(studio)
    arm_page.register(studio)
    replay_page.register(studio)
    simrobot_page.register(studio)
    simrobot_editor_page.register(studio)
    print(f"robot_sims studio: open http://{options.host}:{options.port}/ (workspace {workspace.root})", flush=True)
    try:
        ui.run(
            host=options.host,
            port=options.port,
            title="robot_sims studio",
            reload=False,
            show=options.show,
            show_welcome_message=False,
            favicon="🤖",
            timeout_graceful_shutdown=1,
        )
    except KeyboardInterrupt:
        # Ctrl-C is how a studio ends: uvicorn has shut down, asyncio re-raises the signal.
        pass
    finally:
        shutdown()  # already done unless the interrupt cut the app's own shutdown short
    print("robot_sims studio: stopped", flush=True)
    # Everything the studio started has stopped (bags finished) and its ROS contexts are shut down;
    # what is left is unloading NiceGUI, numba, rclpy and DDS, which took 2-3 s more on a loaded
    # machine: Ctrl-C must end the studio within a few seconds.
    sys.stderr.flush()
    os._exit(0)


def stop_started_world(worlds: dict, key: str) -> None:
    """Stop the world the studio started under ``key`` in ``worlds``, or say it cannot (a world
    started in another terminal is stopped there)."""
    from nicegui import ui

    child = worlds.pop(key, None)
    if child is None:
        ui.notify("this world was not started by the studio (stop it where it runs)", type="warning")
        return
    child.stop()
    ui.notify(f"{child.label} stopped")


UNSAVED_GUARD = (
    "<script>window.addEventListener('beforeunload', (e) => {"
    " if (window.studioUnsaved) { e.preventDefault(); e.returnValue = ''; } });</script>"
)
"""The browser asks before a reload or a closed tab drops a draft the page has marked unsaved."""


class DraftGuard:
    """A page whose draft (a map, a config, a world) can be unsaved: it says what its draft is
    (:meth:`draft`); :meth:`note_draft` after each edit tells the browser whether leaving the page
    would lose it, :meth:`draft_saved` after a load or save."""

    saved_draft: object = None
    unsaved = False

    def draft(self) -> object:
        raise NotImplementedError

    def guard_drafts(self) -> None:
        """On building the page: the browser's warning, and the draft as it starts (nothing to lose)."""
        from nicegui import ui

        ui.add_body_html(UNSAVED_GUARD)
        self.saved_draft = self.draft()

    def note_draft(self) -> None:
        unsaved = self.draft() != self.saved_draft
        if unsaved != self.unsaved:
            from nicegui import ui

            self.unsaved = unsaved
            ui.run_javascript(f"window.studioUnsaved = {'true' if unsaved else 'false'}")

    def draft_saved(self) -> None:
        self.saved_draft = self.draft()
        self.note_draft()


def checked_number(label: str | None = None, *, minimum: float, **kwargs: Any):
    """A number field that keeps a value below ``minimum`` and marks it (:func:`at_least`); no
    space is kept under it for the message until there is one (fields in a row stay aligned)."""
    from nicegui import ui

    return ui.number(label, validation=at_least(minimum), **kwargs).props("hide-bottom-space")


def at_least(minimum: float) -> dict:
    """A number field's ``validation``: a value below ``minimum`` stays in the field, in red with
    this message, and the page's check refuses it (a ``min`` would silently clamp it, and that
    clamped value would be saved)."""
    return {f"must be ≥ {minimum:g}": lambda value: value is None or value >= minimum}


VIEW_SIZE = (800, 600)
"""Pixels of the simulator's and the map maker's drawing area."""


def view_image(on_mouse, on_wheel, css_class: str, background: str):
    """The pan/zoom SVG drawing area both the simulator and the map maker draw on."""
    from nicegui import ui

    image = (
        ui.interactive_image(
            size=VIEW_SIZE, events=["mousedown", "mousemove", "mouseup"], on_mouse=on_mouse, sanitize=False
        )
        .classes(css_class)
        .style(f"width:{VIEW_SIZE[0]}px;height:{VIEW_SIZE[1]}px;background:{background};outline:1px solid #bbb")
    )
    image.on("wheel.prevent", on_wheel, js_handler=WHEEL_JS, throttle=0.05)
    return image


def wheel_zoom(view, args: dict) -> bool:
    """Zoom ``view`` about the pixel under the mouse for a wheel event from :func:`view_image`
    (its ``args``: the pointer and the image's drawn size); False when the event had no size."""
    if not (args.get("w") and args.get("h")):
        return False
    px, py = args["x"] * VIEW_SIZE[0] / args["w"], args["y"] * VIEW_SIZE[1] / args["h"]
    view.zoom_at(px, py, 1 / 1.2 if args["dy"] > 0 else 1.2)
    return True


class ZoomableView:
    """Zoom buttons, the mouse wheel and layer checkboxes of a page that draws ``view`` on
    :func:`view_image`; the page says how it redraws in :meth:`view_changed`."""

    view: Any
    layers: set[str]

    def view_changed(self) -> None:
        raise NotImplementedError

    def zoom(self, factor: float) -> None:
        self.view.zoom(factor)
        self.view_changed()

    def on_wheel(self, e) -> None:
        if wheel_zoom(self.view, e.args):
            self.view_changed()

    def toggle_layer(self, key: str, on: bool) -> None:
        (self.layers.add if on else self.layers.discard)(key)
        self.view_changed()


def nav(current: str) -> None:
    """The links between the pages (the originals' windows)."""
    from nicegui import ui

    with ui.row().classes("items-center gap-6 w-full bg-slate-100 px-4 py-1"):
        ui.label("robot_sims studio").classes("text-lg font-bold")
        for target, text in (
            ("/", "Simulator"),
            ("/map", "Map maker"),
            ("/config", "Config maker"),
            ("/simrobot", "SIMROBOT"),
            ("/simrobot/editor", "SIMROBOT editor"),
            ("/arm", "Arm"),
            ("/replay", "Replay"),
        ):
            link = ui.link(text, target).classes("text-base")
            if target == current:
                link.classes("font-bold no-underline")
