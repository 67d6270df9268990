"""Episodes in worker processes that cannot take the sweep down, whatever a controller does.

A :class:`Supervisor` keeps up to N worker processes (``python -m sim_tools.batch.supervisor``),
each talking to it over its own socket pair (pickled messages), and hands each idle worker the next
episode. A worker runs episodes one after another (:func:`sim_tools.batch.episode.run_episode`),
so start-up (imports, numba's cache) is paid once per worker, not per episode, and writes each
episode's stdout and stderr (the world's, the controller's, rclpy's log lines, a crash's Python
stack) to that episode's log file.

The supervisor never blocks on one worker: it waits on all their sockets at once, with a timeout
until the next deadline. A worker that dies in an episode (``os._exit``, a segfault, the OOM
killer) closes its socket: that episode becomes an error row naming the exit code or signal. One
past the time limit, or whose resident memory (RSS, read from ``/proc``) passes the memory limit,
is killed with SIGKILL (with any processes it started) and its episode becomes an error row. A
controller's ``sys.exit`` is caught in the worker, which reports it and is then replaced. A new
worker takes a lost one's place for the next episode.

Workers are plain subprocesses in their own session, not ``multiprocessing`` children: they work
the same when the supervisor itself runs inside a Ray worker (``multiprocessing``'s spawn would
re-import Ray's worker script), and a Ctrl-C in the terminal reaches only the supervisor, which
kills them. A worker whose supervisor is gone exits within seconds, even in an endless loop.
"""

from __future__ import annotations

import contextlib
import math
import mmap
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from sim_tools.batch.row import ERROR, Result, Row

OnResult = Callable[[Result], None]
LogPath = Callable[[Any], Path]

#: Wall seconds a new worker may take to start (imports, numba's cache on a loaded machine).
START_TIMEOUT_S = 180.0
#: How often busy workers' resident memory is read when there is a memory limit (s).
MEMORY_POLL_S = 0.05
#: How often a worker checks that its supervisor is still there (s).
ORPHAN_POLL_S = 0.5
#: Wall seconds a worker stopped at a limit gets to write its threads' stacks to the episode's
#: log before its SIGKILL (faulthandler writes them from the signal handler itself, whatever the
#: Python code is doing).
DUMP_WAIT_S = 0.3
#: The signal that makes a worker (or the check's process) dump its threads' stacks.
DUMP_SIGNAL = signal.SIGUSR1
_FAULT_FRAME = re.compile(r'File "([^"]+)", line (\d+) in (\S+)')
_PACKAGE_ROOT = str(Path(__file__).resolve().parent.parent.parent)


class WorkerStartError(RuntimeError):
    """A worker process could not start (a broken install, not a controller's fault)."""


@dataclass(frozen=True)
class Limits:
    """Per episode: wall seconds (``time_limit_s``), and the worker's resident memory in MB
    (``memory_limit_mb``, None: none)."""

    time_limit_s: float
    memory_limit_mb: float | None = None


def exit_reason(returncode: int) -> str:
    """How a worker process ended, for an error row."""
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        return f"the episode's process was killed by {name}"
    return f"the episode's process exited with code {returncode}"


def error_result(ep: Any, error: str, pid: int, seconds: float) -> Result:
    """The result of an episode that ended without a result of its own."""
    return {"row": Row.of(ep, ERROR, error), "timing": {"episode": ep.index, "pid": pid, "total_s": seconds}}


def _resident_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/statm", encoding="ascii") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return 0.0


def worker_environment() -> dict[str, str]:
    """The environment of a process that runs students' code: unbuffered (a crash loses no
    print), our package importable, and one hash seed, so that iterating a set of strings goes
    in the same order in every worker and every run."""
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONHASHSEED="0")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (_PACKAGE_ROOT, env.get("PYTHONPATH")) if p)
    return env


# ----------------------------------------------------------------------------- supervisor side
class _Worker:
    """One worker process, its socket, and the episode it runs (if any)."""

    def __init__(self, output: Path, warm: Any, register: Callable[[_Worker], None]) -> None:
        """Start the process; ``register`` is given this worker as soon as the process exists, so a
        Ctrl-C while it is being set up cannot leave it running (in its own session, a terminal's
        Ctrl-C does not reach it: only the supervisor's kill does)."""
        ours, theirs = socket.socketpair()
        self.clock_fd = os.memfd_create("robot_sims-batch-sim-time")  # no file anywhere to clean up
        os.ftruncate(self.clock_fd, 8)
        env = worker_environment()
        fds = [str(theirs.fileno()), str(os.getpid()), str(self.clock_fd)]
        command = [sys.executable, "-m", "sim_tools.batch.supervisor", *fds]
        output.parent.mkdir(parents=True, exist_ok=True)
        with output.open("ab") as log:
            self.process = subprocess.Popen(
                command,
                pass_fds=(theirs.fileno(), self.clock_fd),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
                env=env,
            )
        theirs.close()
        self.conn = Connection(ours.detach())
        self.output = output
        self.started = time.monotonic()
        self.ready = False
        self.episode: Any = None
        self.log: Path | None = None
        self.since = 0.0
        self.deadline = float("inf")
        register(self)
        self.clock = mmap.mmap(self.clock_fd, 8)  # the sim time its episode got to (a double)
        os.close(self.clock_fd)
        self.conn.send(warm)  # the first episode it will see, to warm up on

    def send(self, ep: Any, log: Path, limits: Limits) -> None:
        struct.pack_into("d", self.clock, 0, math.nan)
        self.episode, self.since, self.log = ep, time.monotonic(), log
        self.deadline = self.since + limits.time_limit_s
        self.conn.send((ep, str(log)))

    def sim_time(self) -> float | None:
        """The sim time its episode got to (None: it has no world yet)."""
        value: float = struct.unpack_from("d", self.clock, 0)[0]
        return None if math.isnan(value) else value

    def take(self) -> Any:
        """The episode it ran (now done, one way or another)."""
        ep, self.episode, self.deadline = self.episode, None, float("inf")
        return ep

    def kill(self) -> int:
        """SIGKILL the worker and everything it started (its session); returns its exit code."""
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.process.pid, signal.SIGKILL)
        self.conn.close()
        return self.process.wait()

    def gone(self) -> int:
        """Its socket closed: it is exiting (or has); returns its exit code."""
        self.conn.close()
        try:
            return self.process.wait(timeout=5.0)
        except subprocess.TimeoutExpired:  # it closed its socket but lives on: not ours to wait for
            return self.kill()


class Supervisor:
    """Up to ``workers`` worker processes; :meth:`run` runs episodes on them. Workers stay between
    calls (close with :meth:`close`, or use as a context manager)."""

    def __init__(self, workers: int, output: Path) -> None:
        self.size = max(1, workers)
        self.output = output  # the workers' output outside episodes (start-up errors)
        self.workers: list[_Worker] = []
        self.spare = 0  # 1 once a worker was lost: a warm one waits, so the next loss costs no start-up

    def __enter__(self) -> Supervisor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        for worker in self.workers:
            worker.kill()
        self.workers = []

    def run(self, episodes: Iterable[Any], on_result: OnResult, limits: Limits, log_path: LogPath) -> None:
        """Run every episode, calling ``on_result`` as each finishes; each one's output goes to
        ``log_path(episode)``. On any exception (Ctrl-C) every worker is killed."""
        queue = deque(episodes)
        try:
            while queue or any(w.episode is not None for w in self.workers):
                self._dispatch(queue, limits, log_path)
                self._step(on_result, limits)
        except BaseException:
            self.close()
            raise

    def _dispatch(self, queue: deque[Any], limits: Limits, log_path: LogPath) -> None:
        busy = sum(w.episode is not None for w in self.workers)
        idle = [w for w in self.workers if w.ready and w.episode is None]
        while queue and idle and busy < self.size:
            ep = queue.popleft()
            log = log_path(ep)
            log.parent.mkdir(parents=True, exist_ok=True)
            worker = idle.pop()
            try:
                worker.send(ep, log, limits)
            except OSError:  # it died while idle: the episode waits for another (its EOF is read next)
                worker.take()
                queue.appendleft(ep)
                continue
            busy += 1
        wanted = min(self.size + self.spare, busy + len(queue))
        while queue and len(self.workers) < wanted:
            _Worker(self.output, queue[0], register=self.workers.append)

    def _step(self, on_result: OnResult, limits: Limits) -> None:
        """Wait for the next message, death or deadline; handle what happened."""
        now = time.monotonic()
        busy = [w for w in self.workers if w.episode is not None]
        starting = [w.started + START_TIMEOUT_S for w in self.workers if not w.ready]
        wake = min([w.deadline for w in busy] + starting, default=now + START_TIMEOUT_S)
        if limits.memory_limit_mb is not None and busy:
            wake = min(wake, now + MEMORY_POLL_S)
        by_conn = {w.conn: w for w in self.workers}
        for conn in wait(list(by_conn), timeout=max(0.0, wake - now)):
            self._receive(by_conn[conn], on_result)  # type: ignore[index]
        self._enforce(on_result, limits)

    def _receive(self, worker: _Worker, on_result: OnResult) -> None:
        try:
            message = worker.conn.recv()
        except (EOFError, OSError):
            self._lost(worker, on_result)
            return
        if message[0] == "ready":
            worker.ready = True
            return
        _, result, reusable = message
        worker.take()
        if not reusable:
            self._retire(worker)
        on_result(result)

    def _lost(self, worker: _Worker, on_result: OnResult) -> None:
        code = worker.gone()
        self.workers.remove(worker)
        self.spare = 1
        if not worker.ready:
            tail = worker.output.read_text(errors="replace")[-2000:] if worker.output.exists() else ""
            why = exit_reason(code).replace("the episode's process", "it")
            raise WorkerStartError(f"a batch worker process ended before its first episode ({why}):\n{tail}")
        if worker.episode is None:
            return  # an idle worker died (the OOM killer's choice?): the next episode starts a new one
        seconds = time.monotonic() - worker.since
        note = _crash_note(worker.log)
        on_result(error_result(worker.take(), exit_reason(code) + note, worker.process.pid, seconds))

    def _retire(self, worker: _Worker) -> None:
        worker.kill()
        self.workers.remove(worker)
        self.spare = 1

    def _enforce(self, on_result: OnResult, limits: Limits) -> None:
        """Kill workers past the time limit or the memory limit, and fail on one that never starts."""
        now = time.monotonic()
        for worker in list(self.workers):
            if not worker.ready and now > worker.started + START_TIMEOUT_S:
                raise WorkerStartError(f"a batch worker process did not start in {START_TIMEOUT_S:.0f} s")
            if worker.episode is None:
                continue
            if now > worker.deadline:
                reason = f"time limit {limits.time_limit_s:.1f} s: the episode was stopped"
            elif limits.memory_limit_mb is not None and _resident_mb(worker.process.pid) > limits.memory_limit_mb:
                reason = f"memory limit {limits.memory_limit_mb:g} MB: the episode was stopped"
            else:
                continue
            sim_time = worker.sim_time()
            where = dump_stacks(worker.process.pid, worker.log)
            self._retire(worker)
            result = error_result(
                worker.take(), reason + _stop_note(sim_time, where), worker.process.pid, now - worker.since
            )
            if sim_time is not None:
                result["row"].sim_time_s = sim_time
            on_result(result)


def dump_stacks(pid: int, log: Path | None, start: int | None = None) -> str:
    """Make process ``pid`` dump its threads' stacks into ``log`` (faulthandler, on
    :data:`DUMP_SIGNAL`) and return the innermost function of a user's code in them (``""``:
    none); ``start``: where in the log to look from (default: its end now). The function, not
    its line: a loop stopped at a limit is on one of its lines or another from run to run, and
    the table must not differ with it (the log has every line)."""
    if log is None:
        return ""
    if start is None:
        start = log.stat().st_size if log.exists() else 0
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.kill(pid, DUMP_SIGNAL)
    end = time.monotonic() + DUMP_WAIT_S
    where = ""
    while time.monotonic() < end and not where:
        time.sleep(0.02)
        where = _fault_line(_read_from(log, start), with_line=False)
    return where


def _read_from(log: Path, start: int) -> str:
    try:
        with log.open("rb") as f:
            f.seek(start)
            return f.read(1 << 20).decode(errors="replace")
    except OSError:
        return ""


def _fault_line(text: str, with_line: bool = True) -> str:
    """The innermost user frame of a faulthandler dump (its frames come innermost first; the
    thread that took the signal first): ``student.py:61 in fail``, or without its line
    ``fail() of student.py``."""
    from sim_tools.batch.forms import is_user_file

    for path, line, func in _FAULT_FRAME.findall(text):
        if is_user_file(path):
            return f"{Path(path).name}:{line} in {func}" if with_line else f"{func}() of {Path(path).name}"
    return ""


def _stop_note(sim_time: float | None, where: str) -> str:
    said = [f"at sim time {sim_time:g} s" if sim_time is not None else "", f"in {where}" if where else ""]
    return (" " + ", ".join(s for s in said if s)) if any(said) else ""


def _crash_note(log: Path | None) -> str:
    """`` (in student.py:12 in fail)`` from the crash's Python stack in the log (faulthandler's)."""
    if log is None:
        return ""
    size = log.stat().st_size if log.exists() else 0
    where = _fault_line(_read_from(log, max(0, size - 65536)))
    return f" (in {where})" if where else ""


# --------------------------------------------------------------------------------- worker side
def _watch_parent(parent: int) -> None:
    """Exit when the supervisor is gone (this process is then adopted by another), even while a
    controller loops forever: the loop lets this thread run between its bytecodes."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(ORPHAN_POLL_S)
        os._exit(70)

    threading.Thread(target=watch, daemon=True, name="orphan-watch").start()


def _exit_result(ep: Any, exc: BaseException, seconds: float) -> Result:
    """``sys.exit`` (or another BaseException) in a controller: the episode's row."""
    from sim_tools.batch.episode import at_line

    where = at_line(exc)
    if isinstance(exc, SystemExit):
        what = f"SystemExit: the controller called sys.exit({exc.code!r})"
    else:
        what = f"{type(exc).__name__}: {exc}".strip()
    return error_result(ep, what + where, os.getpid(), seconds)


def _run_logged(ep: Any, log: str, base_fd: int) -> tuple[Result, bool]:
    """Run ``ep`` with fds 1 and 2 on its log file; returns its result and whether this process
    can run another episode."""
    from sim_tools.batch.episode import run_episode

    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    start = time.perf_counter()
    try:
        return run_episode(ep), True
    except BaseException as exc:  # run_episode turns every Exception into a row: this is sys.exit & co
        return _exit_result(ep, exc, time.perf_counter() - start), False
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(base_fd, 1)
        os.dup2(base_fd, 2)


def _warm_up(ep: Any) -> None:
    """Compile (or load from numba's cache) the simulator's kernels and build ``ep``'s world once,
    unstepped, so that imports, compiling and the first context are start-up, not the first
    episode's set-up: that counts against its time limit (a first run may compile kernels), and a
    replaced worker would be slow to take over."""
    try:
        from sim_tools.adapters.contract import world_part
        from sim_tools.batch.episode import probe_world

        if ep is not None:
            world_part(ep.simulator).warm_up()
            probe_world(ep)
    except Exception:  # the episode itself will say what is wrong
        pass


def no_core_files() -> None:
    """A crash of this process (a student's controller segfaulting) leaves its Python stack in the
    log, not a core file of hundreds of MB wherever the system puts cores."""
    import resource

    resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))


def worker_main(fd: int, parent: int, clock_fd: int) -> None:
    """A worker: announce itself, then run the episodes it is sent until its socket closes."""
    import faulthandler

    os.set_inheritable(fd, False)  # a controller's own subprocesses do not hold the socket open
    conn = Connection(fd)
    os.set_inheritable(clock_fd, False)
    from sim_tools.batch import episode

    episode.sim_time_page = mmap.mmap(clock_fd, 8)  # the supervisor reads it at a limit stop
    os.close(clock_fd)
    _watch_parent(parent)
    faulthandler.enable()  # a segfault writes the Python stack to fd 2: the episode's log
    faulthandler.register(DUMP_SIGNAL, all_threads=True)  # a limit stop: every stack to the log
    no_core_files()
    from sim_tools.batch.episode import isolate_process

    isolate_process()
    _warm_up(conn.recv())
    base_fd = os.dup(1)
    conn.send(("ready", os.getpid()))
    while True:
        try:
            ep, log = conn.recv()
        except (EOFError, OSError):
            return
        result, reusable = _run_logged(ep, log, base_fd)
        conn.send(("result", result, reusable))
        if not reusable:
            os._exit(0)  # after sys.exit the process's state is unknown; the supervisor replaces it


if __name__ == "__main__":
    worker_main(int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]))
