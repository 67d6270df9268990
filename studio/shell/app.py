"""The studio's shell: what every page shares (:class:`Studio`), the one shape of a family of
pages (:class:`Family`) and the web app that serves the families the entry point
(:mod:`studio.main`) lists. It imports no family: it knows each only as a :class:`Family`."""

from __future__ import annotations

import argparse
import ipaddress
import os
import re
import signal
import socket
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Generic, Protocol, TypeVar

from sim_runtime.errors import InputError
from sim_runtime.run import split_ros_args
from studio.shell.kit import pages_help
from studio.shell.processes import CLOCK, Child, parse_controller, stop_all
from studio.shell.workspace import Workspace

if TYPE_CHECKING:  # rclpy loads once the arguments are checked (a mistyped option answers at once)
    from studio.shell.ros import StudioRos

Register = Callable[["Studio"], None]
"""A page's ``register(studio)``: its routes and start-up hooks."""


class FamilyClient(Protocol):
    """A family's ROS client: entities on the studio's one node, callbacks on its executor (no
    family has a context, node or thread of its own)."""

    @property
    def ros(self) -> StudioRos:
        """The studio's node and executor the client was made on."""
        ...


ClientT = TypeVar("ClientT", bound=FamilyClient)


class Family(ABC, Generic[ClientT]):
    """One family of pages, the shape the Create's, SIMROBOT's, the arm's and Replay's share: its
    name, its pages, its client on the studio's node and the worlds it started (namespace →
    :class:`Child`), which the namespace checks, Ctrl-C and SIGHUP see.

    The client exists while the app runs (:meth:`start` at start-up, :meth:`stop` once the
    studio's node has stopped spinning: destroying entities under a spinning executor could crash
    the process); the pages read it as ``studio.family(Kind).client`` (None before start-up)."""

    name: ClassVar[str]
    """What the family is called (``create``, ``simrobot``, ``arm``, ``replay``)."""

    def __init__(self, pages: Sequence[Register] = ()) -> None:
        self.pages = list(pages)  # each page's register(studio), given by the entry point
        self.client: ClientT | None = None
        self.worlds: dict[str, Child] = {}  # namespace → world the studio started for this family

    @abstractmethod
    def make_client(self, ros: StudioRos) -> ClientT | None:
        """The family's client on the studio's node (None: the family talks to no world)."""

    def children(self) -> list[Child]:
        """Every process of the family that Ctrl-C must stop: its worlds."""
        return list(self.worlds.values())

    def start(self, ros: StudioRos) -> None:
        self.client = self.make_client(ros)

    def stop(self) -> None:
        self.client = None  # its entities go with the studio's node


FamilyT = TypeVar("FamilyT", bound="Family[Any]")

DEFAULT_CONTROLLERS = {"create_bump_turn": "create_bump_turn"}


@dataclass
class Studio:
    """What every page shares: the workspace, the families, the studio's node and the child processes."""

    workspace: Workspace
    controllers: dict[str, str]
    families: tuple[Family[Any], ...] = ()  # what the entry point lists, each in its one shape
    ros: StudioRos | None = None  # the studio's one node, shared by every family, once the app has started
    running_controllers: dict[str, Child] = field(default_factory=dict)  # namespace → controller
    selected: str | None = None  # the Create last picked or started: every page's default
    recorder: Child | None = None
    recording_to: str = ""
    recording_status: str = ""  # the Save Data line every tab shows: starting, recording to, saved

    def default_robot(self, names: list[str], current: str | None) -> str | None:
        """What a robot selector shows: its current choice, else the studio's, else the first."""
        for choice in (current, self.selected):
            if choice in names:
                return choice
        return names[0] if names else None

    def family(self, kind: type[FamilyT]) -> FamilyT:
        """The studio's family of class ``kind`` (how a page finds its client and its worlds)."""
        for family in self.families:
            if isinstance(family, kind):
                return family
        raise LookupError(f"the studio has no {kind.__name__}: studio.main lists the families")

    def world_children(self) -> dict[str, Child]:
        """namespace → running world the studio started, of every family (Create, arm, SIMROBOT)."""
        started = {ns: child for family in self.families for ns, child in family.worlds.items()}
        return {ns: child for ns, child in started.items() if child.running}

    def graph_worlds(self) -> list[tuple[str, str]]:
        """``(clock topic, namespace)`` of every world on the domain, started here or not."""
        return self.ros.clock_publishers() if self.ros is not None else []

    def namespace_refusal(self, ns: str) -> str | None:
        """Why a new world may not start in ``ns`` (None: it may): a world already runs there, or
        in the root where ``/clock`` is taken (a root world cannot move its clock)."""
        problem = namespace_problem(ns)
        if problem:
            return problem
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
        children = [
            self.recorder,
            *self.running_controllers.values(),
            *(child for family in self.families for child in family.children()),
        ]
        stop_all([child for child in children if child is not None], patient=self.recorder)

    def start(self) -> None:
        """The studio's node, every family's client on it, then its executor spinning (the app's
        start-up: the clients' entities are made before any callback can run)."""
        from studio.shell.ros import StudioRos

        self.ros = StudioRos()
        for family in self.families:
            family.start(self.ros)
        self.ros.spin()

    def shutdown(self) -> None:
        """Stop what the studio started, then its node (once; again is a no-op)."""
        if self.ros is None:
            return
        print("robot_sims studio: stopping what it started", flush=True)
        self.stop_children()
        self.ros.shutdown()
        for family in self.families:
            family.stop()
        self.ros = None


NAMESPACE_PART = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
"""One part of a ROS namespace between slashes (rcl's rule): a world given another would end
with rcl's own message, which quotes a C source file."""


def namespace_problem(ns: str) -> str | None:
    """Why ``ns`` (``/a/b`` or '' for the root) is not a ROS namespace, as a sentence saying what
    to type instead (None: it is one)."""
    if not ns:
        return None
    bad = next((part for part in ns.removeprefix("/").split("/") if not NAMESPACE_PART.fullmatch(part)), None)
    if bad is None:
        return None
    if not bad:
        what = "it has an empty part (//)"
    elif bad[0].isdigit():
        what = f"its part {bad!r} starts with a digit"
    else:
        what = "it holds " + ", ".join(
            sorted({repr(c) for c in bad if not (c.isascii() and (c.isalnum() or c == "_"))})
        )
    return (
        f"namespace {ns!r} is not a ROS name ({what}): type letters, digits and _ between slashes, "
        "each part starting with a letter or _ (for example /create2)"
    )


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
        description="The simulators' windows in the browser: the Create's, SIMROBOT's, the arm's and Replay.",
        epilog=pages_help(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
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


def prepare(argv: list[str] | None) -> tuple[argparse.Namespace, Studio] | int:
    """The options and the studio they describe, or the exit status after a one-line error (a bad
    workspace or controller, a taken port or unknown address: not uvicorn's traceback)."""
    args, _ros_args = split_ros_args(sys.argv if argv is None else ["studio", *argv])
    options = parse_args(args)
    try:
        workspace = Workspace(options.workspace)
        controllers = dict(DEFAULT_CONTROLLERS)
        controllers.update(parse_controller(spec) for spec in options.controller)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    try:
        with socket.create_server((options.host, options.port)):
            pass
    except OSError as err:
        print(f"error: cannot listen on {options.host}:{options.port}: {err.strerror or err}", file=sys.stderr)
        return 2
    warning = host_warning(options.host)
    if warning:
        print(warning, file=sys.stderr)
    return options, Studio(workspace=workspace, controllers=controllers)


def hang_up(_signum: int, _frame: object) -> None:
    """SIGHUP (the terminal closed: an SSH drop, ``tmux kill-session``) ends the studio as Ctrl-C
    does: every world, controller and recorder stops and the bag is finished. The worlds run in
    sessions of their own, so nothing else would stop them. A closed terminal takes the studio's
    output with it: the lines still to come go nowhere instead of failing the shutdown."""
    for fd in (1, 2):
        if os.isatty(fd):
            os.dup2(os.open(os.devnull, os.O_WRONLY), fd)
    os.kill(os.getpid(), signal.SIGINT)  # uvicorn's own Ctrl-C: the app's shutdown, then ours


def run(argv: list[str] | None, load_families: Callable[[], Sequence[Family[Any]]]) -> int:
    """Serve the pages of the families ``load_families()`` returns (loaded once the options are
    checked) until Ctrl-C."""
    prepared = prepare(argv)
    if isinstance(prepared, int):
        return prepared
    options, studio = prepared
    from nicegui import app, ui

    studio.families = tuple(load_families())
    shutdown = studio.shutdown
    app.on_startup(studio.start)
    app.on_shutdown(shutdown)
    signal.signal(signal.SIGHUP, hang_up)
    for family in studio.families:
        for register in family.pages:
            register(studio)
    where = f"http://{options.host}:{options.port}/ (workspace {studio.workspace.root})"
    print(f"robot_sims studio: open {where}", flush=True)
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
