"""Autonomous with an m-file: a MATLAB-style control program (``function prog(serPort)``) from the
workspace, run in GNU Octave against the selected Create through the toolbox bridge.

Start launches ``robot_sims matlab_bridge`` for the robot's namespace (any free loopback port),
waits for it to listen, then ``octave-cli`` with the Create toolbox on its path (``robot_sims
matlab_path``) calling the program with the connected handle, as a student would in a terminal.
Both are child processes of the studio; the program's output (``disp``, Octave's ``error: …``)
is shown like a Python controller's. Stop kills Octave at once (a program may be blocked in a
toolbox call); the bridge sees its program gone and stops the robot, and then ends.

Each run has a fresh key, in the bridge's and Octave's environment (never their arguments, which
any local user sees in ``ps``): the bridge serves only the connection that sends it, so on a
shared host no other user can drive the robot through the bridge's loopback port.

Only ``.m`` files already in the workspace are offered (the user's own files): the studio never
runs a file that came from the browser.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import re
import shutil
import signal
import threading
import time
from pathlib import Path

from nicegui import ui

from sim_runtime.errors import InputError
from sim_tools.matlab.bridge import KEY_ENV, LISTENING, new_key
from sim_tools.matlab.octave import OCTAVE, OCTAVE_NOISE, octave_string, program_name_problem
from sim_tools.matlab.paths import matlab_dir
from studio.create.family import create_family
from studio.shell.app import Studio
from studio.shell.processes import Child, executable_command
from studio.shell.workspace import Workspace

PROGRAM_PREFIX = "m:"
"""The controller choice of an m-file program is ``m:<workspace path>`` (a registered controller's
name is never that: names come from ``--controller NAME=…`` and the defaults)."""
NO_OCTAVE = f"m-file programs need GNU Octave: {OCTAVE} not found (apt install octave octave-instrument-control)"
BRIDGE_START_S = 30.0
"""How long Start waits for the bridge to listen (it imports rclpy: seconds on a loaded machine)."""
BRIDGE_STOP_S = 5.0
"""The bridge's grace after SIGINT: it stops the robot (confirmed by odometry, at most 1 s) first."""


def octave_missing() -> str | None:
    """The one line saying Octave is not installed (None: it is)."""
    return None if shutil.which(OCTAVE) else NO_OCTAVE


def program_choices(workspace: Workspace) -> dict[str, str]:
    """The Autonomous choices of the workspace's ``.m`` files: value → what the list shows."""
    return {PROGRAM_PREFIX + name: f"{name} (Octave)" for name in workspace.files((".m",))}


def program_of(choice: str | None) -> str | None:
    """The workspace path an Autonomous choice names, or None for a Python controller."""
    return choice.removeprefix(PROGRAM_PREFIX) if choice and choice.startswith(PROGRAM_PREFIX) else None


def function_name(program: Path) -> str:
    """The function a program file defines, as MATLAB calls it: its file name without ``.m``."""
    problem = program_name_problem(program)
    if problem:
        raise InputError.at(program.name, None, problem)
    return program.stem


def octave_command(program: Path, port: int, toolbox: Path | None = None) -> list[str]:
    """argv of Octave running ``program`` (``function prog(serPort)``) against the bridge on ``port``:
    the toolbox and the program's folder on the path, ``serPort = CreateRobot(port)``, ``prog(serPort)``,
    and ``clear serPort`` (the session ends: the bridge stops the robot)."""
    toolbox = matlab_dir() if toolbox is None else toolbox
    script = (
        f"more off; addpath({octave_string(str(toolbox))}); addpath({octave_string(str(program.parent))}); "
        f"serPort = CreateRobot({port}); {function_name(program)}(serPort); clear serPort;"
    )
    return [OCTAVE, "--no-gui", "--quiet", "--eval", script]


def bridge_command(ns: str) -> list[str]:
    """argv of the bridge serving the Create in ``ns`` on any free loopback port."""
    return executable_command("matlab_bridge", ["--namespace", ns or "/", "--port", "0"])


def bridge_port(bridge: Child) -> int | None:
    """The port the bridge said it listens on (None: not yet)."""
    for line in list(bridge.output):
        match = LISTENING.search(line)
        if match:
            return int(match.group(2))
    return None


async def bridge_ready(bridge: Child, timeout: float = BRIDGE_START_S) -> int:
    """The bridge's port once it listens; InputError with its last line if it ends or is slow."""
    deadline = asyncio.get_running_loop().time() + timeout
    while (port := bridge_port(bridge)) is None:
        if not bridge.running:
            raise InputError(f"the MATLAB bridge ended: {bridge.error_line()}")
        if asyncio.get_running_loop().time() > deadline:
            raise InputError(f"the MATLAB bridge did not listen within {timeout:g} s")
        await asyncio.sleep(0.05)
    return port


class MatlabRun(Child):
    """Octave running one program, and the bridge serving it: one controller to the page (its
    ``running`` and output are Octave's), stopped together. When Octave ends by itself (the
    program returned or failed) the bridge, which has stopped the robot, is ended too."""

    def __init__(
        self, label: str, argv: list[str], cwd: Path, bridge: Child, env: dict[str, str] | None = None
    ) -> None:
        self.bridge = bridge  # before the reader thread starts: it ends the bridge at Octave's end
        self._bridge_told = threading.Lock()  # held once the bridge has had its one SIGINT
        super().__init__(label, argv, cwd=cwd, env=env)

    def _read(self) -> None:
        super()._read()  # until Octave closes its output: it has ended
        self.end_bridge()

    def end_bridge(self) -> None:
        """One SIGINT to the bridge, ever: it stops the robot, then ends (a second SIGINT would
        interrupt that)."""
        if self._bridge_told.acquire(blocking=False):
            self.bridge.interrupt()

    def error_line(self) -> str:
        """Octave's error message (not its ``called from`` lines), or its last line."""
        self._reader.join(timeout=1.0)
        lines = [line for line in self.output if not line.startswith(OCTAVE_NOISE)]
        errors = [line for line in lines if line.startswith("error")]
        return (errors[:1] or lines[-1:] or [f"exited with status {self.process.returncode}"])[0]

    def interrupt(self) -> None:
        """Octave killed at once (a program blocked in a toolbox call ignores SIGINT), the bridge
        interrupted (it stops the robot first)."""
        if self.running:
            with contextlib.suppress(ProcessLookupError):  # it ended meanwhile
                os.killpg(self.process.pid, signal.SIGKILL)  # its own session: what Octave started too
        self.end_bridge()

    def wait(self, timeout: float) -> int | None:
        """Octave's status once both it and the bridge ended, within one shared ``timeout`` (the
        bridge killed when it runs out); None while Octave still runs (its bridge serves it on).

        Octave gets the caller's whole ``timeout``, not a fixed second: on a busy machine (load
        20-40 on 2 cores) Octave takes seconds to start, run a short program and exit, and a
        killed one seconds to be reaped, so a 1 s wait reported a program that was ending as
        still running."""
        deadline = time.monotonic() + timeout
        status = super().wait(timeout)
        if status is None:
            return None
        if self.bridge.wait(max(0.0, deadline - time.monotonic())) is None:
            self.bridge.process.kill()
            self.bridge.wait(2.0)
        return status

    def stop(self, timeout: float = BRIDGE_STOP_S) -> int | None:
        self.interrupt()
        status = self.wait(timeout)
        if self.bridge.running:  # Octave not even reaped in time: the robot's server goes anyway
            self.bridge.process.kill()
            self.bridge.wait(2.0)
        return status


def program_path(workspace: Workspace, name: str) -> Path:
    """The program file ``name`` in the workspace; InputError if it is missing, misnamed or not a
    function file (a script cannot be handed ``serPort``; nor is any other file run as one)."""
    text, path = workspace.read_text(name, "program")
    function_name(path)
    if not re.match(r"function\b", first_code_line(text)):
        raise InputError.at(name, None, "not a function file: a program starts with function prog(serPort)")
    return path


def first_code_line(text: str) -> str:
    """The first line of an m-file that is not blank or a comment (``%``, ``#``, ``%{ … %}``)."""
    block = 0
    for raw in text.splitlines():
        line = raw.strip()
        if line in ("%{", "#{"):
            block += 1
        elif line in ("%}", "#}") and block:
            block -= 1
        elif line and not block and not line.startswith(("%", "#")):
            return line
    return ""


async def start_program(studio: Studio, ns: str, name: str) -> MatlabRun | None:
    """Run the workspace's program ``name`` for the Create in ``ns``: the bridge, then Octave once
    it listens. The bridge is the namespace's controller meanwhile (Stop ends it; None is returned
    if it was stopped). InputError: no Octave, a bad file, a bridge that did not start."""
    missing = octave_missing()
    if missing:
        raise InputError(missing)
    path = program_path(studio.workspace, name)
    keyed = {KEY_ENV: new_key()}  # this run's: the bridge serves only the Octave that has it
    bridge = Child(f"matlab_bridge {ns or '/'}", bridge_command(ns), cwd=studio.workspace.root, env=keyed)
    controllers = create_family(studio).controllers
    controllers[ns] = bridge
    try:
        port = await bridge_ready(bridge)
    except InputError:
        bridge.stop()  # it stays the controller shown: its last line says why it ended
        raise
    if controllers.get(ns) is not bridge:
        return None  # Stop was pressed while the bridge started
    run = MatlabRun(f"{path.name} (Octave)", octave_command(path, port), cwd=path.parent, bridge=bridge, env=keyed)
    controllers[ns] = run
    return run


class ProgramChoice:
    """The Autonomous section's m-file part: the workspace's programs among the choices (listed
    again each time the list opens) and one line under them (no Octave; why a start failed)."""

    def __init__(self, studio: Studio, select: ui.select) -> None:
        self.studio = studio
        self.select = select
        self.controllers = {name: name for name in studio.controllers}
        select.set_options({**self.controllers, **program_choices(studio.workspace)}, value=select.value)
        select.on("popup-show", self.refresh).classes("studio-controller-choice")
        self.note = ui.label(octave_missing() or "").classes("text-sm text-orange-700 studio-program-note")

    def refresh(self) -> None:
        self.select.set_options({**self.controllers, **program_choices(self.studio.workspace)}, value=self.select.value)

    async def start(self, ns: str, name: str) -> None:
        self.note.set_text("")
        try:
            run = await start_program(self.studio, ns, name)
        except InputError as err:
            self.note.set_text(f"error: {err}")
            return
        if run is not None:
            ui.notify(f"{run.label} started for {ns or '/'}")
