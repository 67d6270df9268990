"""What the batch tests that press Ctrl-C share: ``robot_sims batch`` started as in a terminal
(its own process group, the foreground group Ctrl-C goes to), a wait on what the run leaves on
disk while it is alive, and Ctrl-C to the whole group."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

T = TypeVar("T")


def start_batch(args: Sequence[str], cwd: Path, env: dict[str, str]) -> subprocess.Popen:
    """``robot_sims batch ARGS`` in ``cwd``, its own session (so its group can be Ctrl-C'd alone)."""
    command = [sys.executable, "-m", "sim_tools.batch.cli", *args]
    return subprocess.Popen(
        command,
        cwd=cwd,
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_as_in_a_terminal,
    )


def _as_in_a_terminal() -> None:
    """Ctrl-C as a terminal's foreground job has it: an ignored or blocked SIGINT survives exec,
    and a pytest worker that ran other modules first may have either (a run that ignored the
    Ctrl-C went on to its end: exit status 0, not 130, in a full suite, never alone)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})


def wait_while_running(run: subprocess.Popen, ready: Callable[[], T | None], within: float) -> T:
    """What ``ready()`` returns once it is not None/False, polled while ``run`` is still alive
    (a run that ended first fails with its stderr), at most ``within`` s (a generous ceiling)."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        assert run.poll() is None, run.stderr.read() if run.stderr else ""
        found = ready()
        if found:
            return found
        time.sleep(0.05)
    raise AssertionError(f"the run never got there in {within} s")


def ctrl_c(run: subprocess.Popen, within: float = 60) -> str:
    """Ctrl-C in the terminal (SIGINT to the run's whole group); its stderr once it has ended."""
    os.killpg(run.pid, signal.SIGINT)
    _, err = run.communicate(timeout=within)
    return err
