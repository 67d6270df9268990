"""The SIMROBOT editor's controller choice with algorithm m-files: besides the world's built-in
controllers, every ``.m`` file in the workspace can drive a robot (the original's
``function new = alg(simrobot, matrix, step)``), written to the world file as the robot's
``algorithm`` (relative to the world file) and run by the world in GNU Octave once per step.

Only files already in the workspace are offered: the studio never runs a file from the browser.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from nicegui import ui

from sim_runtime.errors import InputError
from simrobot_sim.matlab_alg import octave_executable
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
