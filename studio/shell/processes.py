"""Worlds, controllers and recorders the studio starts: each a child process of its own.

A world runs as ``robot_sims create_world`` in a subprocess rather than in the studio's executor:
its paced physics must not share a Python interpreter (GIL) with the web server, a bad map ends
that process with its one-line error instead of the studio, and it is exactly the program a
student runs in a terminal. Controllers and the recorder are the existing executables too.
Nothing here ever runs a file that came from the browser: only executables and the
``module:function`` controllers given on the studio's command line.
"""

from __future__ import annotations

import collections
import os
import shlex
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from sim_runtime.errors import InputError
from sim_tools.cli import executable_command

RUN_FUNCTION = (
    "import importlib, sys; module, function = sys.argv[1].split(':'); sys.argv = sys.argv[1:]; "
    "sys.exit(getattr(importlib.import_module(module), function)() or 0)"
)


__all__ = [
    "Child",
    "controller_command",
    "executable_command",
    "namespace_args",
    "parse_controller",
    "stop_all",
    "world_ros_args",
    "yaml_string",
]
CLOCK = "/clock"


def controller_command(target: str, ros_args: list[str]) -> list[str]:
    """argv of a controller: a robot_sims executable name, ``module:function``, or a command line."""
    if ":" in target and "/" not in target and " " not in target:
        return [sys.executable, "-c", RUN_FUNCTION, target, "--ros-args", *ros_args]
    words = shlex.split(target)
    if len(words) == 1 and "/" not in target:
        return executable_command(target, ["--ros-args", *ros_args])
    return [*words, "--ros-args", *ros_args]


def parse_controller(spec: str) -> tuple[str, str]:
    """``name=module:function`` or ``name=command`` from ``--controller``."""
    name, sep, target = spec.partition("=")
    if not sep or not name.strip() or not target.strip():
        raise InputError(f"--controller {spec!r}: expected name=module:function or name=command")
    return name.strip(), target.strip()


def yaml_string(value: str) -> str:
    """A parameter value rcl reads back as exactly this string (YAML single quotes; '' = empty)."""
    return "'" + value.replace("'", "''") + "'"


def clock_topic(ns: str, owns_clock: bool) -> str:
    """Where a world in ``ns`` publishes its clock: ``/clock`` if it owns it (or is in the root),
    else ``<ns>/clock``: one ``/clock`` per domain, so a recording has one timeline."""
    return CLOCK if owns_clock or not ns else f"{ns}{CLOCK}"


def namespace_args(ns: str, owns_clock: bool = False) -> list[str]:
    """The remap rules of a world (or its controller) in ``ns``: ``__ns`` and the clock topic."""
    if not ns:
        return []
    args = ["-r", f"__ns:={ns}"]
    return args if owns_clock else [*args, "-r", f"{CLOCK}:={clock_topic(ns, False)}"]


def world_ros_args(
    ns: str, map_file: str, config_file: str, pose: tuple[float, float, float], owns_clock: bool = False
) -> list[str]:
    """``--ros-args`` of a Create world in namespace ``ns`` ('' = root) with these files and pose,
    publishing its clock on :func:`clock_topic`."""
    args = [
        "--ros-args",
        "-p", f"map_file:={yaml_string(map_file)}",
        "-p", f"config_file:={yaml_string(config_file)}",
        "-p", f"initial_pose:=[{pose[0]!r}, {pose[1]!r}, {pose[2]!r}]",
    ]  # fmt: skip
    return args + namespace_args(ns, owns_clock)


class Child:
    """A child process with the last lines of its output kept for the page (and echoed, prefixed
    with its label, to the studio's own output)."""

    def __init__(self, label: str, argv: list[str], cwd: Path | None = None, clock: str = "") -> None:
        self.label = label
        self.argv = argv
        self.clock = clock  # the clock topic of a world ('' for controllers and recorders)
        self.output: collections.deque[str] = collections.deque(maxlen=50)
        self.process = subprocess.Popen(
            argv,
            cwd=cwd,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,  # Ctrl-C in the studio's terminal reaches the studio only
            env=os.environ.copy(),
        )
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.output.append(line.rstrip())
            # The studio's terminal shows every child's lines, prefixed as ros2 launch does.
            print(f"[{self.label}] {line.rstrip()}", flush=True)

    @property
    def running(self) -> bool:
        return self.process.poll() is None

    def error_line(self) -> str:
        """The child's ``error: …`` line (or last line) once it has ended."""
        self._reader.join(timeout=1.0)  # its last lines may still be in the pipe
        errors = [line for line in self.output if line.startswith("error")]
        return (errors or list(self.output) or [f"exited with status {self.process.returncode}"])[-1]

    def wait(self, timeout: float) -> int | None:
        try:
            return self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def interrupt(self) -> None:
        """SIGINT, as Ctrl-C in its terminal (a recorder finishes its bag)."""
        if self.running:
            self.process.send_signal(signal.SIGINT)

    def stop(self, timeout: float = 5.0) -> int | None:
        """SIGINT, then SIGKILL after ``timeout``."""
        stop_all([self], timeout)
        return self.process.returncode


def stop_all(children: list[Child], timeout: float = 3.0, patient: Child | None = None) -> None:
    """Stop ``children`` together: SIGINT to all, one shared ``timeout``, then SIGKILL to those
    left (one after another, five worlds took five times one world's time). ``patient`` (a
    recorder finishing its bag) gets one second more before it is killed."""
    for child in children:
        child.interrupt()
    start = time.monotonic()
    for child in sorted(children, key=lambda c: c is patient):  # the patient one last
        allowed = timeout + (1.0 if child is patient else 0.0)
        child.wait(max(0.0, start + allowed - time.monotonic()))
        if child.running:
            child.process.kill()
            child.wait(2.0)
