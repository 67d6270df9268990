"""Run one student's grading (a ``robot_sims batch`` process) so that it can harm nobody else.

``robot_sims batch`` already turns a controller that raises, exits, crashes, loops or eats memory
into an error row (time and memory limits, process sessions killed whole). A grading run adds,
when the teacher grades as root (:func:`run_contained`):

- **its own Unix user**: a uid of its own (``uid_base + slot``, no account, no groups), so it can
  read only what every user may read: not another student's home or submission (0700), not the
  gradebook, not the teacher's assignment file; and afterwards **every process of that uid is
  killed** (``kill(-1)`` from that uid), so a daemon that left its session does not survive;
- **RLIMIT_NPROC** (processes and threads of that uid), **RLIMIT_FSIZE** (no file bigger than the
  limit), no core files, ``PR_SET_NO_NEW_PRIVS`` (no set-uid program gives it root back) and
  ``PR_SET_PDEATHSIG`` (it dies with the grader);
- **its own network namespace** (only a loopback of its own: it cannot reach or flood the host's
  network or another run's DDS) and **its own ROS domain**;
- **its own mount namespace**: private, empty ``/tmp`` and ``/dev/shm`` (no other user's scratch
  files or DDS shared memory), its run folder bound at ``/tmp/run`` as its working directory and
  ``HOME``; a folder on the interpreter's path that others cannot enter (``/root`` when Python
  lives in ``/root/.pyenv``) is replaced by an empty one holding just that path.

Not root: the run is the teacher's own user with its own working folder, ROS domain, session
and the batch limits only; it could read what the teacher can (docs/classroom_grading.md).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import os
import resource
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from sim_runtime.processes import kill_me_with_parent

#: Where the run folder appears inside the mount namespace (its cwd and HOME).
INSIDE = "/tmp/run"
_CLONE_NEWNS = 0x00020000
_CLONE_NEWNET = 0x40000000
_MS_BIND = 4096
_MS_REC = 16384
_MS_PRIVATE = 1 << 18
_PR_SET_NO_NEW_PRIVS = 38
_SIOCGIFFLAGS = 0x8913
_SIOCSIFFLAGS = 0x8914
_IFF_UP = 0x1


@dataclass(frozen=True)
class Jail:
    """How one run is contained: its uid/gid (None: the caller's own, not root), ROS domain, the
    most processes+threads of its uid and the largest file it may write (MB)."""

    uid: int | None
    gid: int | None
    domain: int
    max_processes: int = 512
    max_file_mb: int = 256
    #: Keep the host's network (``--ray ADDRESS``: the run must reach the cluster).
    network: bool = False


#: The runs under way (each grading thread's), so that Ctrl-C in the grader stops them all now.
_RUNNING: set[subprocess.Popen[bytes]] = set()
_RUNNING_LOCK = threading.Lock()


#: Set by :func:`stop_all`: a grading thread that was still preparing its run (copying kernels)
#: starts none after the Ctrl-C, and one that started in that instant is killed at once.
_STOPPED = threading.Event()


class RunsStopped(RuntimeError):
    """A run asked for after :func:`stop_all` (the grader was interrupted)."""


def allow_runs() -> None:
    """Runs may start again (a new grading, after one that was interrupted)."""
    _STOPPED.clear()


def stop_all() -> None:
    """Kill every run under way (its session; :func:`run_contained` then kills its uid's rest), and
    refuse the runs asked for from now on."""
    with _RUNNING_LOCK:
        _STOPPED.set()
        for process in _RUNNING:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(process.pid, signal.SIGKILL)


@dataclass(frozen=True)
class Outcome:
    returncode: int
    timed_out: bool
    seconds: float


def contained() -> bool:
    """Whether runs get their own user and namespaces (the grader is root)."""
    return os.geteuid() == 0


def run_contained(
    command: list[str], folder: Path, env: dict[str, str], jail: Jail, timeout_s: float, log: Path
) -> Outcome:
    """Run ``command`` in ``folder`` as ``jail`` says, at most ``timeout_s`` wall seconds, its
    output to ``log``; every process it left is killed before this returns."""
    if _STOPPED.is_set():
        raise RunsStopped("the grader was interrupted: no run starts now")
    env = dict(env, ROS_DOMAIN_ID=str(jail.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env.pop("ROS_STATIC_PEERS", None)
    jailed = contained() and jail.uid is not None
    cwd = INSIDE if jailed else str(folder)
    env.update(HOME=cwd, TMPDIR="/tmp", USER=f"grading{jail.domain}", LOGNAME=f"grading{jail.domain}")
    start = time.monotonic()
    with log.open("ab") as out:
        process = subprocess.Popen(
            command,
            cwd=None if jailed else cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            preexec_fn=_enter(folder, jail) if jailed else _limit_only(jail),
        )
    with _RUNNING_LOCK:
        stopped = _STOPPED.is_set()
        if not stopped:
            _RUNNING.add(process)
    timed_out = False
    try:
        if stopped:  # stop_all came while this one was starting: it ends now, as below
            raise RunsStopped("the grader was interrupted: this run was stopped as it started")
        code = process.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        timed_out = True
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)
        code = process.wait()
    except BaseException:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)
        raise
    finally:
        with _RUNNING_LOCK:
            _RUNNING.discard(process)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)  # what stayed in its session
        if jailed and jail.uid is not None:
            kill_user(jail.uid)
    return Outcome(code, timed_out, time.monotonic() - start)


def processes_of(uid: int) -> list[int]:
    """The pids whose real uid is ``uid``."""
    pids = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        with contextlib.suppress(OSError):
            for line in Path(f"/proc/{entry}/status").read_text().splitlines():
                if line.startswith("Uid:"):
                    if int(line.split()[1]) == uid:
                        pids.append(int(entry))
                    break
    return pids


def kill_user(uid: int, wait_s: float = 10.0) -> None:
    """SIGKILL every process of ``uid`` (which must be a grading uid, used by nothing else), over
    and over until none is left: a fork loop refills its slots as they are killed. Each round is
    one ``kill(-1, SIGKILL)`` from a child of that uid, which the kernel applies to all of them."""
    deadline = time.monotonic() + wait_s
    while processes_of(uid) and time.monotonic() < deadline:
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child only makes system calls
            try:
                os.setgroups([])
                os.setresgid(uid, uid, uid)
                os.setresuid(uid, uid, uid)
                os.kill(-1, signal.SIGKILL)
            finally:
                os._exit(0)
        os.waitpid(pid, 0)
        time.sleep(0.05)


def _limits(jail: Jail, nproc: bool) -> None:
    if nproc:
        resource.setrlimit(resource.RLIMIT_NPROC, (jail.max_processes, jail.max_processes))
    size = jail.max_file_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def _limit_only(jail: Jail) -> Callable[[], None]:
    def setup() -> None:
        _limits(jail, nproc=False)  # the teacher's own uid: its count holds the teacher's processes too

    return setup


def _enter(folder: Path, jail: Jail) -> Callable[[], None]:
    """The child's set-up, as root before the exec: namespaces, mounts, limits, then the uid."""
    keep = interpreter_blocks()
    in_tmp = interpreter_in_tmp()
    uid, gid = jail.uid, jail.gid if jail.gid is not None else jail.uid

    def setup() -> None:
        libc = ctypes.CDLL(None, use_errno=True)
        _check(kill_me_with_parent(libc.prctl), "prctl")
        _check(libc.unshare(_CLONE_NEWNS | (0 if jail.network else _CLONE_NEWNET)), "unshare")
        _check(libc.mount(None, b"/", None, _MS_REC | _MS_PRIVATE, None), "mount --make-rprivate /")
        # opened in the new namespace (a bind's source must be in it), before the tmpfs hide them
        run_fd = os.open(folder, os.O_PATH | os.O_DIRECTORY)
        kept = [(blocked, child, os.open(blocked / child, os.O_PATH)) for blocked, child in keep]
        for blocked, child, fd in kept:
            _tmpfs(libc, str(blocked), "0711")
            (blocked / child).mkdir()
            _bind(libc, fd, str(blocked / child))
        tmp_fds = [(path, os.open(path, os.O_PATH | os.O_DIRECTORY)) for path in in_tmp]
        _tmpfs(libc, "/tmp", "1777")
        for path, fd in tmp_fds:  # a checkout or venv in /tmp: the run needs its Python there
            path.mkdir(parents=True)
            _bind(libc, fd, str(path))
        _tmpfs(libc, "/dev/shm", "1777")
        os.mkdir(INSIDE, 0o700)
        _bind(libc, run_fd, INSIDE)
        os.chdir(INSIDE)
        if not jail.network:
            _loopback_up()
        _limits(jail, nproc=True)
        _check(libc.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0), "prctl")
        os.setgroups([])
        os.setresgid(gid, gid, gid)  # type: ignore[arg-type]
        os.setresuid(uid, uid, uid)  # type: ignore[arg-type]

    return setup


def interpreter_blocks() -> list[tuple[Path, str]]:
    """Folders on the paths of the interpreter and this package that other users cannot enter,
    each with its child on the path (``(/root, ".pyenv")`` for ``/root/.pyenv/...``)."""
    found: list[tuple[Path, str]] = []
    package = Path(__file__).resolve().parent.parent.parent
    for path in (Path(sys.base_prefix).resolve(), Path(sys.prefix).resolve(), package):
        for parent in reversed(path.parents):
            if parent == Path("/") or parent in (b for b, _ in found):
                continue
            if not os.stat(parent).st_mode & 0o001:
                found.append((parent, path.relative_to(parent).parts[0]))
                break
    return found


def interpreter_in_tmp() -> list[Path]:
    """The interpreter's and this package's folders that lie in /tmp (a clone or a venv made
    there), outermost only: the run's private /tmp would hide them, so they are bound back in
    at the same paths. Nothing else of the host's /tmp is visible to the run."""
    package = Path(__file__).resolve().parent.parent.parent
    tmp = Path("/tmp").resolve()
    paths = sorted(
        {p for p in (Path(sys.base_prefix).resolve(), Path(sys.prefix).resolve(), package) if tmp in p.parents}
    )
    outermost: list[Path] = []
    for path in paths:  # sorted: a folder comes before what is inside it
        if not any(kept == path or kept in path.parents for kept in outermost):
            outermost.append(path)
    return outermost


def _check(result: int, what: str) -> None:
    if result != 0:
        code = ctypes.get_errno()
        raise OSError(code, f"{what}: {os.strerror(code)}")


def _tmpfs(libc: ctypes.CDLL, where: str, mode: str) -> None:
    options = f"mode={mode},size=64m".encode()
    _check(libc.mount(b"tmpfs", where.encode(), b"tmpfs", 0, options), f"mount tmpfs {where}")


def _bind(libc: ctypes.CDLL, fd: int, where: str) -> None:
    _check(libc.mount(f"/proc/self/fd/{fd}".encode(), where.encode(), None, _MS_BIND | _MS_REC, None), f"bind {where}")
    os.close(fd)


def _loopback_up() -> None:
    """A new network namespace's loopback starts down; DDS wants it up."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        request = struct.pack("16sH14x", b"lo", 0)
        flags = struct.unpack("16sH14x", fcntl.ioctl(s, _SIOCGIFFLAGS, request))[1]
        try:
            fcntl.ioctl(s, _SIOCSIFFLAGS, struct.pack("16sH14x", b"lo", flags | _IFF_UP))
        except OSError as exc:  # pragma: no cover - a namespace without CAP_NET_ADMIN
            if exc.errno != errno.EPERM:
                raise
