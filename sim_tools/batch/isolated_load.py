""":func:`sim_tools.batch.sweep.load_sweep` in a child process.

Checking a sweep imports the students' modules and builds each controller once
(:mod:`sim_tools.batch.precheck`). A module or constructor that calls ``os._exit``, segfaults or
never returns must end that check with one error naming the sweep, not end or hang
``robot_sims batch`` itself. The child writes the parsed sweep (or its :class:`InputError`) to a
file, not to stdout, which the students' code may print on.
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError

#: Wall seconds the check may take: imports, one build of each controller and of one world.
CHECK_TIMEOUT_S = 120.0
#: How much of the child's output an error quotes (characters, from its end).
OUTPUT_TAIL = 600


def load_sweep_isolated(path: str, out: str | None = None, timeout_s: float = CHECK_TIMEOUT_S) -> Any:
    """The :class:`~sim_tools.batch.sweep.Sweep` of ``path``, read and checked in a child
    process; an InputError when the sweep is bad or the child died or hung while checking it."""
    with tempfile.TemporaryDirectory(prefix="robot_sims-sweep-") as tmp:
        result, log = Path(tmp) / "sweep.pickle", Path(tmp) / "output.log"
        code = _run_child([path, str(result), *([out] if out is not None else [])], log, timeout_s)
        if code is None:
            hung = f"did not finish in {timeout_s:.0f} s (a module or constructor that never returns?)"
            raise _failed(path, hung, log)
        if not result.exists():
            from sim_tools.batch.supervisor import exit_reason

            raise _failed(path, f"ended: {exit_reason(code)}", log)
        value = pickle.loads(result.read_bytes())
    if isinstance(value, InputError):
        raise value
    return value


def _run_child(args: list[str], log: Path, timeout_s: float) -> int | None:
    """Run this module on ``args`` with its output in ``log``; its exit status, None on timeout
    (then it and anything it started are killed)."""
    from sim_tools.batch.supervisor import worker_environment

    with log.open("wb") as sink:
        child = subprocess.Popen(
            [sys.executable, "-m", __name__, *args],
            stdin=subprocess.DEVNULL,
            stdout=sink,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: killed whole on a timeout
            env=worker_environment(),
        )
        try:
            return child.wait(timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)
            child.wait()
            return None
        except BaseException:  # Ctrl-C while checking: the child goes too
            os.killpg(child.pid, signal.SIGKILL)
            child.wait()
            raise


def _failed(path: str, what: str, log: Path) -> InputError:
    tail = " ".join(log.read_text(errors="replace")[-OUTPUT_TAIL:].split())
    return InputError(
        f"{path}: checking the sweep (importing and building each controller once) {what}"
        + (f"; its last output: {tail}" if tail else "")
    )


def _child(path: str, result: str, out: str | None) -> None:
    from sim_tools.batch.sweep import load_sweep

    try:
        value: Any = load_sweep(path, out=out)
    except InputError as err:
        value = err
    Path(result).write_bytes(pickle.dumps(value))


if __name__ == "__main__":
    _child(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None)
    # Not a plain return: a student's thread left running must not keep the check alive.
    sys.stdout.flush()
    os._exit(0)
