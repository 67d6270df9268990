"""Small facts about processes that more than one tool asks."""

from __future__ import annotations

import ctypes
import os
import signal
from collections.abc import Callable

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def kill_me_with_parent(prctl: Callable[..., int]) -> int:
    """In a forked child before its exec: ask the kernel to SIGKILL it when the thread that forked
    it ends, however that ends. ``prctl`` is libc's, looked up before the fork: a first lookup
    allocates, and in the child of a threaded parent malloc's lock may be held by a thread that
    no longer exists. Returns prctl's result (0, or -1 with errno set)."""
    return int(prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0))


def die_with_parent(parent: int | None = None) -> Callable[[], None]:
    """A ``preexec_fn`` for :func:`kill_me_with_parent`. With ``parent`` (the forking process's
    pid, taken before the fork), a child whose parent died before the request exits at once
    instead of living on as a child of init."""
    prctl = ctypes.CDLL(None, use_errno=True).prctl

    def preexec() -> None:
        kill_me_with_parent(prctl)
        if parent is not None and os.getppid() != parent:
            os._exit(1)

    return preexec


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists (a zombie counts: its parent has not reaped it yet).

    Another user's process exists too: signal 0 to it is refused with ``PermissionError``, which
    says it is there.
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
