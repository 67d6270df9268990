"""Worlds, controllers and recorders the studio starts: each a child process of its own.

A world runs as ``robot_sims create_world`` in a subprocess rather than in the studio's executor:
its paced physics must not share a Python interpreter (GIL) with the web server, a bad map ends
that process with its one-line error instead of the studio, and it is exactly the program a
student runs in a terminal. Controllers and the recorder are the existing executables too.
Nothing here ever runs a file that came from the browser: only executables and the
``module:function`` controllers given on the studio's command line.

Every child dies with the studio, however the studio ends: a clean stop interrupts them
(:func:`stop_all`), and a studio killed outright (SIGKILL, the OOM killer) kills them through the
kernel's parent-death signal (:func:`die_with_parent`). What they print is the students' to read:
each child's lines are kept (the page's Output view), written to a log file in the workspace's
hidden folder and echoed to the studio's own output.
"""

from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import itertools
import os
import queue
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_runtime.processes import die_with_parent
from sim_tools.cli import executable_command

RUN_FUNCTION = (
    "import importlib, sys; module, function = sys.argv[1].split(':'); sys.argv = sys.argv[1:]; "
    "sys.exit(getattr(importlib.import_module(module), function)() or 0)"
)


__all__ = [
    "PROCESSES",
    "Child",
    "Processes",
    "controller_command",
    "die_with_parent",
    "executable_command",
    "namespace_args",
    "parse_controller",
    "stop_all",
    "world_ros_args",
    "yaml_string",
]
CLOCK = "/clock"
OUTPUT_LINES = 2000  # lines of each child kept for the Output view (the log file keeps them all)
ENDED_KEPT = 100  # ended children the Output view still lists (the oldest are forgotten)
OUTPUT_FOLDER = ".robot_sims/output"  # in the workspace: each child's log file


@dataclass
class Processes:
    """What the studio knows of every child it started, whichever page started it: the Output
    view's list, where their logs go, and how many worlds it may run at once."""

    log_folder: Path | None = None  # None: no log files (a studio not yet started, a unit test)
    max_worlds: int | None = None  # None: no limit
    children: list[Child] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, child: Child) -> None:
        with self.lock:
            self.children.append(child)
            ended = [c for c in self.children if not c.running]
            for old in ended[: max(0, len(ended) - ENDED_KEPT)]:
                self.children.remove(old)

    def listed(self) -> list[Child]:
        """Every child still known, newest first."""
        with self.lock:
            return list(reversed(self.children))

    def running(self) -> list[Child]:
        return [child for child in self.listed() if child.running]

    def world_refusal(self, running_worlds: int) -> str | None:
        """Why one more world may not start beside ``running_worlds`` (None: it may)."""
        if self.max_worlds is None or running_worlds < self.max_worlds:
            return None
        worlds = "world" if self.max_worlds == 1 else "worlds"
        verb = "runs" if running_worlds == 1 else "run"
        return (
            f"this studio runs at most {self.max_worlds} {worlds} at once (--max-worlds, "
            f"ROBOT_SIMS_MAX_WORLDS) and {running_worlds} already {verb}: stop one first"
        )


PROCESSES = Processes()
"""The studio's children (one studio per process: its shell configures this at start)."""


class Spawner:
    """One long-lived thread that forks every child: the parent-death signal fires when the thread
    that forked exits, and a page's handler may run in a short-lived worker thread."""

    def __init__(self) -> None:
        self._requests: queue.SimpleQueue[tuple[dict[str, Any], concurrent.futures.Future]] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._start = threading.Lock()

    def popen(self, argv: list[str], **kwargs: Any) -> subprocess.Popen:
        if sys.platform != "linux":
            return subprocess.Popen(argv, **kwargs)
        with self._start:
            if self._thread is None:
                self._thread = threading.Thread(target=self._serve, name="studio-spawner", daemon=True)
                self._thread.start()
        done: concurrent.futures.Future = concurrent.futures.Future()
        self._requests.put(({"args": argv, **kwargs}, done))
        return done.result()

    def _serve(self) -> None:
        preexec = die_with_parent(os.getpid())
        while True:
            kwargs, done = self._requests.get()
            try:
                done.set_result(subprocess.Popen(**kwargs, preexec_fn=preexec))
            except BaseException as err:  # a missing program: the caller's error, raised there
                done.set_exception(err)


SPAWNER = Spawner()
LOG_NUMBERS = itertools.count(1)


def log_path(folder: Path, label: str) -> Path:
    """A new log file for a child labelled ``label``: the time, a number and the label in its name."""
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", label).strip("_")[:60] or "process"
    return folder / f"{time.strftime('%Y%m%d-%H%M%S')}-{next(LOG_NUMBERS)}-{slug}.log"


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
    """A child process with the last lines of its output kept for the page, written to its log
    file (in :data:`PROCESSES`' folder) and echoed, prefixed with its label, to the studio's own
    output. It is SIGKILLed by the kernel if the studio dies without stopping it."""

    def __init__(
        self, label: str, argv: list[str], cwd: Path | None = None, clock: str = "", env: dict[str, str] | None = None
    ) -> None:
        self.label = label
        self.argv = argv
        self.clock = clock  # the clock topic of a world ('' for controllers and recorders)
        self.output: collections.deque[str] = collections.deque(maxlen=OUTPUT_LINES)
        self.started = time.time()
        self.stopping = False  # a Stop button is waiting for it to end (studio.shell.kit.stop_started_world)
        self.log_file = self._open_log()
        self.process = SPAWNER.popen(
            argv,
            cwd=cwd,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,  # Ctrl-C in the studio's terminal reaches the studio only
            env={**os.environ, **(env or {})},  # (env: what it gets beside the studio's own)
        )
        self.line_count = 0  # lines read so far (the Output page redraws when it grows)
        PROCESSES.add(self)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _open_log(self) -> Path | None:
        folder = PROCESSES.log_folder
        if folder is None:
            return None
        try:
            folder.mkdir(mode=0o700, parents=True, exist_ok=True)
            path = log_path(folder, self.label)
            path.write_text(f"$ {shlex.join(self.argv)}\n", encoding="utf-8")
        except OSError as err:  # a full disk or a read-only workspace: the view still has the lines
            self.output.append(f"(no log file: {err.strerror or err})")
            return None
        return path

    def _read(self) -> None:
        assert self.process.stdout is not None
        log = self._log_writer()
        for line in self.process.stdout:
            self.output.append(line.rstrip())
            self.line_count += 1
            if log is not None:
                log.write(line)
                log.flush()
            # The studio's terminal shows every child's lines, prefixed as ros2 launch does; a
            # terminal or log that went away (a dead Jupyter server's pipe) must not end the reading.
            with contextlib.suppress(OSError, ValueError):
                print(f"[{self.label}] {line.rstrip()}", flush=True)
        if log is not None:
            status = Child.wait(self, 5.0)  # its output closed: it has ended, or nearly (not a subclass's wait)
            log.write(f"(ended: {'still running' if status is None else f'exit status {status}'})\n")
            log.close()

    def _log_writer(self) -> Any:
        if self.log_file is None:
            return None
        try:
            return self.log_file.open("a", encoding="utf-8")
        except OSError:
            return None

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
