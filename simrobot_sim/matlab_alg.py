"""Robots driven by the original's algorithm m-files (``function new = alg(simrobot, matrix, step)``),
run in GNU Octave through ``oct2py``: one Octave session per world, every algorithm called once per
robot per step, before the step, on that step's readings. Same world, same files: the same tracks.

The robot an algorithm receives is the original's ``@simrobot`` object (``matlab/simrobot/``):
``readusonic``, ``readlaser``, ``setvel``, ``getpos``, ``gethead``, ... in the original's units (map
cells, degrees, rad/s; no echo reads 999999). An algorithm that raises stops its robot, is reported
once and is not called again; so does one that runs longer than ``timeout`` wall seconds in one
step (it is interrupted). The world and the other robots go on. A session that dies (Octave
killed) stops every algorithm robot.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sim_runtime.errors import InputError
from sim_runtime.msgs import ABSURD_COMMAND, command_ok
from sim_runtime.paths import config_dir
from simrobot_sim.model import SimrobotWorld

#: What a sensor reading with no obstacle in range is to an algorithm (the original's value).
NO_ECHO = 999999.0
#: Wall seconds the algorithms of one step may take before the running one is interrupted.
STEP_TIMEOUT = 10.0


def mfiles_dir() -> Path:
    """``matlab/simrobot`` beside ``config/``: the checkout's, or ``share/robot_sims/`` when installed."""
    folder = config_dir().parent / "matlab" / "simrobot"
    if not folder.is_dir():
        raise InputError(f"the SIMROBOT m-files are not installed with robot_sims (no {folder})")
    return folder


def octave_executable() -> str:
    """``$OCTAVE_EXECUTABLE``, else ``octave-cli`` or ``octave`` on PATH; an error saying what to install."""
    given = os.environ.get("OCTAVE_EXECUTABLE")
    if given:
        found = shutil.which(given)
        if found is None:
            raise InputError(f"OCTAVE_EXECUTABLE={given!r} is not an executable: point it at octave-cli")
        return found
    found = shutil.which("octave-cli") or shutil.which("octave")
    if not found:
        raise InputError("algorithm m-files run in GNU Octave: install it (e.g. apt install octave)")
    return found


def function_name(path: Path, where: str) -> str:
    """The function an algorithm file defines (its file name): an error unless it can be one."""
    name = path.stem
    if path.suffix != ".m" or not name.isidentifier() or not name.isascii():
        raise InputError(f"{where}: {str(path)!r} is not an m-file named as a MATLAB function (e.g. alg2.m)")
    return name


def _no_workspace_dump(session: Any) -> None:
    # oct2py ends a session with a signal, on which Octave saves its workspace as octave-workspace
    # in the current folder (whatever the *_dumps_octave_core settings): send it nowhere instead
    session.eval('octave_core_file_name("/dev/null");', nout=0)


def start_octave() -> Any:
    """A fresh Octave session with the SIMROBOT m-files on its path."""
    executable = octave_executable()
    first_import = "oct2py" not in sys.modules
    # importing oct2py starts its own default session: with octave-cli, not the GUI binary
    os.environ.setdefault("OCTAVE_EXECUTABLE", executable)
    try:
        import oct2py
    except ImportError:
        raise InputError("algorithm m-files need the Python package oct2py: pip install oct2py") from None
    default = getattr(oct2py, "octave", None)  # absent when it failed to start
    if first_import and default is not None:
        _no_workspace_dump(default)
        default.exit()  # that default session is not ours: one Octave process less
    session = oct2py.Oct2Py(executable=executable, convert_to_float=False)
    _no_workspace_dump(session)
    session.addpath(str(mfiles_dir()))
    return session


class OctaveAlgorithms:
    """Runs the algorithm m-files of some robots of ``world``: call :meth:`run` before each step.

    ``algorithms``: robot index → its m-file. ``report`` gets each problem once (a sentence naming
    the robot and file). ``session``: an Octave session to reuse (from :func:`start_octave`).
    ``timeout``: wall seconds one step's algorithms may take. ``output`` gets each line the
    algorithms print (``disp``, ``printf``: the original's command window)."""

    def __init__(
        self,
        world: SimrobotWorld,
        algorithms: dict[int, Path],
        report: Callable[[str], None] = print,
        session: Any = None,
        timeout: float = STEP_TIMEOUT,
        output: Callable[[str], None] = print,
    ) -> None:
        self.world = world
        self.timeout = float(timeout)
        self.output = output
        self.files = {i: Path(p).resolve() for i, p in algorithms.items()}
        self.report = report
        self.active = np.zeros(len(world.names), dtype=bool)
        self.active[list(self.files)] = True
        names = self._function_names()
        self.octave = session if session is not None else start_octave()
        try:
            self.octave.eval("clear functions", nout=0)  # a reused session: no algorithm's persistent state
            for folder in sorted({str(p.parent) for p in self.files.values()}):
                self.octave.addpath(folder)
            self._setup(names)
        except BaseException:
            if session is None:  # ours: not left running
                self.close()
            raise

    def _function_names(self) -> list[str]:
        names = [""] * len(self.world.names)
        folders: dict[str, Path] = {}
        for i, path in self.files.items():
            where = f"robot {self.world.names[i]!r}: algorithm"
            names[i] = function_name(path, where)
            if not path.is_file():
                raise InputError(f"{where}: {str(path)!r}: no such file")
            other = folders.setdefault(names[i], path.parent)
            if other != path.parent:
                raise InputError(f"{where}: {names[i]}.m is in two folders ({other}, {path.parent}): rename one")
        return names

    def _setup(self, names: list[str]) -> None:
        sensors = self.world.sensors
        counts = [1 if s.kind == "ultrasonic" else s.rays for s in sensors]
        last = np.cumsum(counts, dtype=float)
        first = last - np.array(counts, dtype=float) + 1
        self.octave.feval(
            "simrobot_world_setup",
            list(self.world.names),
            names,
            np.array([s.robot + 1 for s in sensors], dtype=float).reshape(1, -1),
            [s.name for s in sensors],
            [s.kind for s in sensors],
            first.reshape(1, -1),
            last.reshape(1, -1),
            self.world.grid,
            nout=0,
        )
        for i in self.files:  # the memory (userdata) the world file gives a robot at the start
            memory = self.world.spec.robots[i].memory
            if memory is not None:
                self.octave.feval("simrobot_world_memory", float(i + 1), np.array(memory, dtype=float), nout=0)
        self._sent = self.world.grid.copy()

    def _matrix_changes(self) -> tuple[np.ndarray, np.ndarray]:
        # the cells that changed since the last step (Octave keeps the matrix: far less to send)
        grid = self.world.grid
        cells = np.flatnonzero(grid != self._sent)
        xs, ys = np.unravel_index(cells, grid.shape)
        self._sent[xs, ys] = grid[xs, ys]
        linear = np.ravel_multi_index((xs, ys), grid.shape, order="F") + 1  # Octave's column-major, 1-based
        return linear.astype(float).reshape(1, -1), grid[xs, ys].reshape(1, -1)

    def _readings(self) -> tuple[np.ndarray, np.ndarray]:
        # every sensor's reading in map cells (nearest for ultrasonic, every ray for a laser)
        world = self.world
        values: list[np.ndarray] = []
        nums: list[np.ndarray] = []
        for k, sensor in enumerate(world.sensors):
            if sensor.kind == "ultrasonic":
                dist, num = world.nearest(k)
                values.append(np.array([dist]))
                nums.append(np.array([num]))
            else:
                dists, obstacles = world.ranges(k)
                values.append(dists)
                nums.append(obstacles)
        if not values:
            return np.zeros((1, 0)), np.zeros((1, 0))
        cells = np.concatenate(values) / world.resolution
        cells[~np.isfinite(cells)] = NO_ECHO
        return cells.reshape(1, -1), np.concatenate(nums).astype(float).reshape(1, -1)

    def _pose(self) -> np.ndarray:
        # the original's position (cells from the map's lower-left corner) and heading (degrees, [0, 360))
        world = self.world
        poses = world.poses()
        out = np.empty_like(poses)
        out[:, :2] = (poses[:, :2] - world.origin) / world.resolution
        out[:, 2] = np.mod(np.degrees(poses[:, 2]), 360.0)
        return out

    def run(self) -> None:
        """Call every active algorithm once on the current step and apply what it set."""
        if not self.active.any():
            return
        world = self.world
        values, nums = self._readings()
        args = (
            self.active.astype(float).reshape(1, -1),
            self._pose(),
            world.vel.copy(),
            world.accel.copy(),
            world.power.astype(float).reshape(1, -1),
            world.crashed.astype(float).reshape(1, -1),
            values,
            nums,
            *self._matrix_changes(),
            float(world.step_count + 1),
        )
        try:
            result = self.octave.feval(
                "simrobot_world_step", *args, nout=5, timeout=self.timeout, stream_handler=self.output
            )
        except Exception as err:  # oct2py raises its own errors, pexpect's for a dead session
            self._interrupted(err)
            return
        self._apply(*result)

    def _interrupted(self, err: BaseException) -> None:
        # a step that ran out of time was interrupted: its running algorithm fails, the rest go on
        if "Timed out" not in str(err):
            self._session_lost(err)
            return
        try:
            running = int(self.octave.eval("simrobot_world_running()", nout=1)) - 1
        except Exception as again:  # the session did not survive the interrupt
            self._session_lost(again)
            return
        if not 0 <= running < len(self.active):  # interrupted outside any algorithm
            self._session_lost(err)
            return
        self._failed(running, f"no answer within {self.timeout:g} s (an endless loop?); it was interrupted")

    def _apply(self, velocity: Any, accel: Any, power: Any, crashed: Any, errors: Any) -> None:
        world = self.world
        n = len(world.names)
        velocity = np.asarray(velocity, dtype=float).reshape(n, 2)
        accel = np.asarray(accel, dtype=float).reshape(n, 2)
        power = np.asarray(power, dtype=float).reshape(n)
        crashed = np.asarray(crashed, dtype=float).reshape(n)
        messages = np.asarray(errors, dtype=object).reshape(n)
        for i in np.flatnonzero(self.active).tolist():
            if not messages[i] and not command_ok(*velocity[i], *accel[i]):
                messages[i] = (
                    f"wheel speeds {velocity[i].tolist()} or accelerations {accel[i].tolist()} "
                    f"are absurd (|value| > {ABSURD_COMMAND:g})"
                )
            if messages[i]:
                self._failed(i, str(messages[i]))
                continue
            world.set_wheel_speeds(i, *velocity[i])
            world.set_wheel_accels(i, *accel[i])
            world.set_power(i, bool(power[i]))
            if world.crashed[i] and not crashed[i]:
                world.clear_crash(i)

    def _stop(self, i: int) -> None:
        self.active[i] = False
        self.world.set_wheel_speeds(i, 0.0, 0.0)
        self.world.set_wheel_accels(i, 0.0, 0.0)

    def _failed(self, i: int, message: str) -> None:
        self._stop(i)
        message = " ".join(line.strip() for line in message.splitlines() if line.strip())  # one log line
        name = self.world.names[i]
        self.report(
            f"robot {name!r}: algorithm {self.files[i]} failed at step {self.world.step_count + 1}: "
            f"{message}; the robot stops"
        )

    def _session_lost(self, err: BaseException) -> None:
        robots = ", ".join(repr(self.world.names[i]) for i in np.flatnonzero(self.active))
        for i in np.flatnonzero(self.active):
            self._stop(int(i))
        first_line = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        self.report(
            f"Octave failed at step {self.world.step_count + 1} ({first_line}): robots {robots} stop; the world goes on"
        )
        self.close()

    def close(self) -> None:
        """End the Octave session (safe to call twice)."""
        octave, self.octave = self.octave, None
        if octave is not None:
            with contextlib.suppress(Exception):  # a session already gone: nothing left to end
                octave.exit()
