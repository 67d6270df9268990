""":func:`sim_tools.batch.sweep.load_sweep` in a child process, under an episode's limits.

Checking a sweep imports the students' modules and builds each controller once
(:mod:`sim_tools.batch.precheck`). A module or constructor that calls ``os._exit``, segfaults,
never returns or allocates without end must end that controller's check with an error naming it,
not end, hang or exhaust ``robot_sims batch`` itself. So the check runs in a child process under
the sweep's own limits: each controller's import and build gets ``time_limit_s`` of wall time, and
the child's resident memory is held to ``memory_limit_mb``, as an episode's worker is. The child
tells which controller's code it is running (a small stage file); when it dies, hangs or passes
the memory limit there, that controller is refused with the reason and the check runs again
without it, so every broken submission is named in one run. The child writes the parsed sweep (or
its :class:`InputError`) to a file, not to stdout, which the students' code may print on.
"""

from __future__ import annotations

import contextlib
import json
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError

#: Wall seconds the check may spend outside any controller's code: reading the files, imports,
#: building one world.
CHECK_TIMEOUT_S = 120.0
#: How much of the child's output an error quotes (characters, from its end).
OUTPUT_TAIL = 600
#: How often the child's memory and stage are looked at (s).
POLL_S = 0.05


def load_sweep_isolated(
    path: str, out: str | None = None, timeout_s: float = CHECK_TIMEOUT_S, broken_as_rows: bool = False
) -> Any:
    """The :class:`~sim_tools.batch.sweep.Sweep` of ``path``, read and checked in a child
    process; an InputError when the sweep is bad, or when a controller cannot run (all of them
    named; with ``broken_as_rows`` they are the sweep's ``broken`` instead), or when the child died
    or hung outside any controller's code."""
    from sim_tools.batch.sweep import broken_error

    time_limit, memory_limit = read_limits(path)
    refused: dict[int, str] = {}
    while True:
        value = _check_once(path, out, refused, timeout_s, time_limit, memory_limit)
        if value is not None:
            break
    if isinstance(value, InputError):
        raise value
    if value.broken and not broken_as_rows:
        raise broken_error(value.source, value.broken, len(value.broken) + len(value.grid_applies))
    return value


def _check_once(
    path: str, out: str | None, refused: dict[int, str], timeout_s: float, time_limit: float, memory: float | None
) -> Any:
    """One child's check: the sweep or its InputError, or None after adding the controller whose
    check killed the child to ``refused``."""
    with tempfile.TemporaryDirectory(prefix="robot_sims-sweep-") as tmp:
        result, log, stage = Path(tmp) / "sweep.pickle", Path(tmp) / "output.log", Path(tmp) / "stage.json"
        args = [path, str(result), str(stage), json.dumps(refused), out if out is not None else ""]
        ended, what, where = _run_child(args, log, stage, timeout_s, time_limit, memory)
        if result.exists():
            return pickle.loads(result.read_bytes())
        at = _stage(stage)
        if at is None or at[0] < 0:
            raise _failed(path, what if ended != "exited" else f"ended: {what}", log)
        k, _, doing, offset = at
        tail = _tail(log, offset)
        refused[k] = f"{what} while {doing}" + (f", in {where}" if where else "")
        refused[k] += f"; its last output: {tail}" if tail else ""
        return None


def read_limits(path: str) -> tuple[float, float | None]:
    """The sweep's ``time_limit_s`` and ``memory_limit_mb`` (its defaults when the file or a value
    is bad: the check itself then says what is wrong)."""
    from sim_runtime.yamlfile import load_yaml
    from sim_tools.batch.sweep import default_time_limit

    def number(value: Any) -> float | None:
        ok = isinstance(value, int | float) and not isinstance(value, bool) and 0 < value < float("inf")
        return float(value) if ok else None

    try:
        data = load_yaml(Path(path), "sweep file")
    except (InputError, OSError):
        data = {}
    data = data if isinstance(data, dict) else {}
    duration = number(data.get("duration_s")) or 1.0
    return number(data.get("time_limit_s")) or default_time_limit(duration), number(data.get("memory_limit_mb"))


def _stage(stage: Path) -> tuple[int, str, str, int] | None:
    """What the child said it is doing: controller index (-1: none), name, what, where its output
    about it starts in the log."""
    try:
        k, label, doing, offset = json.loads(stage.read_text(encoding="utf-8"))
    except (OSError, ValueError, TypeError):
        return None
    return int(k), str(label), str(doing), int(offset)


def _run_child(
    args: list[str], log: Path, stage: Path, timeout_s: float, time_limit: float, memory: float | None
) -> tuple[str, str, str]:
    """Run this module on ``args`` with its output in ``log``, under the limits; returns how it
    ended (``exited``, ``time``, ``memory``), the reason (then it and anything it started are
    killed) and where in the student's code it was (``""``: not known)."""
    from sim_tools.batch.supervisor import (
        _fault_line,
        _read_from,
        _resident_mb,
        dump_stacks,
        exit_reason,
        worker_environment,
    )

    with log.open("wb") as sink:
        child = subprocess.Popen(
            [sys.executable, "-m", __name__, *args],
            stdin=subprocess.DEVNULL,
            stdout=sink,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: killed whole on a limit
            env=worker_environment(),
        )
        seen, since = None, time.monotonic()
        try:
            while True:
                try:
                    code = child.wait(POLL_S)
                except subprocess.TimeoutExpired:
                    pass
                else:
                    start = seen[3] if seen is not None else 0
                    where = _fault_line(_read_from(log, start)) if code < 0 else ""
                    said = exit_reason(code).replace("the episode's process", "the check's process")
                    return "exited", said, where
                now_stage = _stage(stage)
                if now_stage != seen:
                    seen, since = now_stage, time.monotonic()
                in_controller = seen is not None and seen[0] >= 0
                limit = time_limit if in_controller else timeout_s
                if time.monotonic() - since > limit:
                    where = dump_stacks(child.pid, log, seen[3] if seen is not None else 0)
                    _kill(child)
                    if in_controller:
                        return "time", f"time limit {time_limit:.1f} s: stopped", where
                    return (
                        "time",
                        f"did not finish in {timeout_s:.0f} s (a module or constructor that never returns?)",
                        where,
                    )
                if memory is not None and _resident_mb(child.pid) > memory:
                    where = dump_stacks(child.pid, log, seen[3] if seen is not None else 0)
                    _kill(child)
                    return "memory", f"memory limit {memory:g} MB: stopped", where
        except BaseException:  # Ctrl-C while checking: the child goes too
            _kill(child)
            raise


def _kill(child: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(child.pid, signal.SIGKILL)
    child.wait()


def _tail(log: Path, start: int = 0) -> str:
    """The end of the log from ``start`` (a byte offset), on one line."""
    with log.open("rb") as f:
        f.seek(start)
        text = f.read().decode(errors="replace")
    for stack in ("Fatal Python error:", "Current thread 0x", "Thread 0x"):  # a stack: quoted as its line
        text = text.split(stack, 1)[0]
    return " ".join(text[-OUTPUT_TAIL:].split())


def _failed(path: str, what: str, log: Path) -> InputError:
    tail = _tail(log)
    return InputError(
        f"{path}: checking the sweep (importing and building each controller once) {what}"
        + (f"; its last output: {tail}" if tail else "")
    )


def _child(path: str, result: str, stage: str, refused: str, out: str) -> None:
    import faulthandler

    from sim_tools.batch.supervisor import DUMP_SIGNAL, no_core_files
    from sim_tools.batch.sweep import load_sweep

    faulthandler.enable()  # a constructor's segfault: its Python stack in the log, quoted
    no_core_files()
    faulthandler.register(DUMP_SIGNAL, all_threads=True)  # stopped at a limit: where the student is

    def tell(k: int, label: str, doing: str) -> None:
        sys.stdout.flush()
        sys.stderr.flush()
        try:
            offset = os.lseek(1, 0, os.SEEK_CUR)  # the log's end: this controller's output starts here
        except OSError:  # not a file
            offset = 0
        Path(stage).write_text(json.dumps([k, label, doing, offset]), encoding="utf-8")

    try:
        given = {int(k): v for k, v in json.loads(refused).items()}
        value: Any = load_sweep(path, out=out or None, broken_as_rows=True, refused=given, stage=tell)
    except InputError as err:
        value = err
    Path(result).write_bytes(pickle.dumps(value))


if __name__ == "__main__":
    _child(*sys.argv[1:6])
    # Not a plain return: a student's thread left running must not keep the check alive.
    sys.stdout.flush()
    os._exit(0)
