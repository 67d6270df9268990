"""The SIMROBOT editor's controller choice with algorithm m-files: besides the world's built-in
controllers, every ``.m`` file in the workspace can drive a robot (the original's
``function new = alg(simrobot, matrix, step)``), written to the world file as the robot's
``algorithm`` (relative to the world file) and run by the world in GNU Octave once per step.

Only files in the workspace are offered. *Edit* and *New* (the original's Algorithm menu) show
an algorithm file's text in the page and save it back to the workspace; the world runs it the next
time it starts.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.matlab_alg import function_name, octave_executable
from simrobot_sim.world_file import CONTROLLERS, RobotSpec
from studio.shell.workspace import Workspace

ALGORITHM_PREFIX = "m:"
"""The choice of an algorithm file is ``m:<workspace path>`` (a built-in controller's name never is)."""


def octave_note() -> str:
    """What an algorithm's choice says after its name: ``(Octave)``, or that Octave is missing."""
    try:
        octave_executable()
    except InputError:
        return "(needs GNU Octave: not installed)"
    return "(Octave)"


def algorithm_label(name: str) -> str:
    return f"{name} {octave_note()}"


def algorithm_value(path: str, workspace: Workspace) -> str:
    """The choice naming the algorithm file ``path`` (absolute): its workspace path, or the
    absolute path of a file outside the workspace (a world file opened from elsewhere)."""
    try:
        return ALGORITHM_PREFIX + workspace.relative(Path(path))
    except ValueError:
        return ALGORITHM_PREFIX + path


def algorithm_path(value: str, workspace: Workspace) -> str:
    """The absolute path of the algorithm file a choice names."""
    name = value.removeprefix(ALGORITHM_PREFIX)
    return name if Path(name).is_absolute() else str(workspace.path(name))


class AlgorithmChoice:
    """The robot form's controller list: none (topics), the built-in controllers and the
    workspace's algorithm m-files (listed again each time the list opens)."""

    def __init__(self, select: ui.select, workspace: Workspace, no_controller: str) -> None:
        self.select = select
        self.workspace = workspace
        self.no_controller = no_controller
        select.on("popup-show", self.refresh)
        self.refresh()

    def options(self) -> dict[str, str]:
        names = [self.no_controller, *CONTROLLERS]
        files = self.workspace.files((".m",))
        return {**{n: n for n in names}, **{ALGORITHM_PREFIX + f: algorithm_label(f) for f in files}}

    def refresh(self) -> None:
        self.set(self.select.value or self.no_controller)

    def set(self, value: str) -> None:
        """Choose ``value`` (listed even if it is an algorithm file outside the workspace, or gone)."""
        options = self.options()
        if value not in options:
            options[value] = algorithm_label(value.removeprefix(ALGORITHM_PREFIX))
        self.select.set_options(options, value=value)

    def show(self, robot: RobotSpec) -> None:
        """Show ``robot``'s controller or algorithm."""
        if robot.algorithm:
            self.set(algorithm_value(robot.algorithm, self.workspace))
        else:
            self.set(robot.controller or self.no_controller)

    def chosen(self) -> dict[str, Any]:
        """The robot's ``controller`` and ``algorithm`` as the list chooses them (one of them, or neither)."""
        value = self.select.value
        if isinstance(value, str) and value.startswith(ALGORITHM_PREFIX):
            return {"controller": None, "algorithm": algorithm_path(value, self.workspace)}
        return {"controller": None if value == self.no_controller else value, "algorithm": None}


def algorithm_template(function: str) -> str:
    """A new algorithm file: the original's template (``algtemp.m``), named ``function``."""
    return (
        f"function new = {function}(simrobot, matrix, step)\n"
        "% your algorithm starts here (help simrobot_commands lists what a robot can do;\n"
        "% step is the step's number, matrix the world's map of obstacles and robots)\n"
        "% end of your algorithm\n"
        "new = simrobot;\n"
    )


def new_algorithm(workspace: Workspace, name: str) -> str:
    """Write a new algorithm file ``name`` (``.m`` added if missing) from the template; its
    workspace name. InputError saying what to type when the name cannot be a MATLAB function's,
    or when the file exists (never overwritten: it may be a student's work)."""
    name = name.strip()
    if not name:
        raise InputError("new algorithm: type its file name first (e.g. alg_r1.m)")
    if not name.endswith(".m"):
        name += ".m"
    path = workspace.path(name)
    function = function_name(path, f"new algorithm {name!r}")
    if path.exists() or path.is_symlink():
        raise InputError(f"{name}: the file exists: choose it in the controller list, or type another name")
    workspace.write_text(name, algorithm_template(function))
    return workspace.relative(path)


def editable_algorithm(value: object, workspace: Workspace) -> str:
    """The workspace name of the algorithm file a controller choice names, to edit it; InputError
    saying what to do when the choice is not a workspace algorithm file."""
    if not isinstance(value, str) or not value.startswith(ALGORITHM_PREFIX):
        raise InputError("Edit: choose an algorithm m-file in the controller list first (or make one with New)")
    path = Path(algorithm_path(value, workspace))
    try:
        return workspace.relative(path)
    except ValueError:
        raise InputError(
            f"Edit: {str(path)!r} is outside the workspace {workspace.root}: copy it into the workspace and choose it"
        ) from None


class AlgorithmEditor:
    """The original's Algorithm > Edit and New: a dialog showing an algorithm file's text, saved
    back to the workspace (the file the robot's world runs in Octave)."""

    def __init__(self, workspace: Workspace, say: Callable[[str, bool], None]) -> None:
        self.workspace = workspace
        self.say = say
        self.name = ""
        with ui.dialog() as self.dialog, ui.card().classes("w-[720px] max-w-none"):
            self.title = ui.label("").classes("font-bold simrobot-algorithm-title")
            self.text = (
                ui.textarea().props("rows=18 outlined").classes("w-full font-mono text-sm simrobot-algorithm-text")
            )
            with ui.row().classes("items-center gap-2"):
                ui.button("Save", on_click=self.save).props("dense color=primary").classes("simrobot-algorithm-save")
                ui.button("Cancel", on_click=self.dialog.close).props("dense flat")
                self.problem = ui.label("").classes("text-sm text-red-700")

    def open(self, name: str, note: str = "") -> None:
        """Show the workspace file ``name`` for editing."""
        try:
            text, _path = self.workspace.read_text(name, "algorithm")
        except InputError as err:
            self.say(f"error: {err}", True)
            return
        self.name = name
        self.title.set_text(f"{name}{note}")
        self.text.set_value(text)
        self.problem.set_text("")
        self.dialog.open()

    def save(self) -> None:
        try:
            self.workspace.write_text(self.name, self.text.value or "", overwrite=True)
        except (InputError, OSError) as err:
            self.problem.set_text(f"error: {err}")
            return
        self.dialog.close()
        self.say(f"saved {self.name}: Run it again to run the edited algorithm", False)
