"""A fuzz campaign: inputs run in worker processes, restarted when one dies or hangs.

Input ``i`` of a campaign with seed ``s`` is a pure function of (s, i) and the seed corpus, so the
parent can rebuild the input a crashed worker was running and save it; each defect is saved as
its input folder plus ``defect.txt`` (target, outcome, traceback, how to replay it).

A hung worker is asked for its threads' stacks before it is killed, and the input is run once more,
alone, in the fresh worker: if it hangs again it is a hang; if it ends there, the input did not
cause it (the worker's history or the machine did) and it is reported apart, as a *stall*, with
the stacks, and not counted against the input.
"""

from __future__ import annotations

import collections
import json
import multiprocessing as mp
import os
import shutil
import signal
import sys
import tempfile
import time
import traceback
import warnings
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

from sim_runtime.inputfile import is_regular_file

OUTCOMES = ("ok", "input_error", "defect", "crash", "hang")
STALL = "stall"
"""A hang its input does not reproduce alone: reported with the hung worker's stacks, not an input failure."""
_IDLE = -1


@dataclass
class Report:
    """What a campaign found: counts per target and outcome, defects by signature, timing."""

    seed: int
    inputs: int = 0
    seconds: float = 0.0
    workers: int = 0
    restarts: int = 0
    recycled: int = 0  # workers replaced after recycle_after inputs (not a failure)
    counts: dict[str, collections.Counter] = field(default_factory=lambda: collections.defaultdict(collections.Counter))
    defects: dict[str, list[int]] = field(default_factory=lambda: collections.defaultdict(list))
    stalls: dict[str, list[int]] = field(default_factory=lambda: collections.defaultdict(list))
    out: str = ""

    @property
    def failures(self) -> int:
        return sum(c["defect"] + c["crash"] + c["hang"] for c in self.counts.values())

    def table(self) -> str:
        columns = (*OUTCOMES, STALL)
        rows = [f"{'target':<16}" + "".join(f"{o:>12}" for o in ("inputs", *columns))]
        total: collections.Counter = collections.Counter()
        for name in sorted(self.counts):
            c = self.counts[name]
            total.update(c)
            rows.append(f"{name:<16}{sum(c.values()):>12}" + "".join(f"{c[o]:>12}" for o in columns))
        rows.append(f"{'total':<16}{sum(total.values()):>12}" + "".join(f"{total[o]:>12}" for o in columns))
        rate = self.inputs / self.seconds if self.seconds else 0.0
        rows.append(
            f"{self.inputs} inputs in {self.seconds:.1f} s ({rate:.0f}/s) on {self.workers} workers, "
            f"{self.restarts} worker restarts, {self.recycled} recycled, seed {self.seed}"
        )
        for signature, indices in sorted(self.defects.items()):
            rows.append(f"DEFECT x{len(indices)} {signature} (e.g. input {indices[0]})")
        for signature, indices in sorted(self.stalls.items()):
            rows.append(
                f"STALL x{len(indices)} {signature} (e.g. input {indices[0]}): ended when run alone; "
                f"the hung worker's stacks are in {self.out}/defects/*-{STALL}-{indices[0]}/defect.txt"
            )
        return "\n".join(rows)

    def to_json(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "inputs": self.inputs,
            "seconds": round(self.seconds, 2),
            "workers": self.workers,
            "restarts": self.restarts,
            "recycled": self.recycled,
            "counts": {k: dict(v) for k, v in self.counts.items()},
            "defects": {k: v[:20] for k, v in self.defects.items()},
            "stalls": {k: v[:20] for k, v in self.stalls.items()},
        }


def _signature(name: str, exc: BaseException) -> str:
    """Target, exception type and the innermost frame of our code: one line per distinct defect."""
    frames = traceback.extract_tb(exc.__traceback__)
    ours = [f for f in frames if "/sim_tools/fuzz/" not in f.filename] or frames
    where = f"{Path(ours[-1].filename).name}:{ours[-1].lineno}" if ours else "?"
    return f"{name}: {type(exc).__name__} at {where}"


def _worker(
    seed_folder: str, seed: int, tasks: Any, results: Any, current: Any, started: Any, out: str, log: str
) -> None:
    """Run inputs of the ranges put on ``tasks``; one result per input on the pipe ``results``."""
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    import faulthandler

    faulthandler.enable()
    faulthandler.register(signal.SIGUSR1, all_threads=True)  # the parent asks for our stacks before killing a hang
    warnings.simplefilter("ignore")
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    from sim_runtime.errors import InputError
    from sim_tools.fuzz.targets import Seeds, make_case, target_of, warm_up

    seeds = Seeds.load(Path(seed_folder))
    scratch = Path(tempfile.mkdtemp(prefix="fuzz-", dir="/dev/shm" if os.path.isdir("/dev/shm") else None))
    warm_up(seeds, scratch / "warm-up")
    try:
        while True:
            task = tasks.get()
            if task is None:
                return
            for index in range(*task):
                started.value = time.monotonic()
                current.value = index
                folder = scratch / str(index)
                name = target_of(index, seed)
                signature = ""
                try:
                    name, case = make_case(index, seed, seeds, folder)
                    case.run()
                    outcome = "ok"
                except InputError:
                    outcome = "input_error"
                except BaseException as exc:
                    if isinstance(exc, KeyboardInterrupt):
                        raise
                    outcome = "defect"
                    signature = _signature(name, exc)
                    _save(Path(out), name, index, seed, folder, "defect", "".join(traceback.format_exception(exc)))
                finally:
                    shutil.rmtree(folder, ignore_errors=True)
                current.value = _IDLE
                results.send((index, name, outcome, signature))  # synchronous: survives our crash
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _copy_regular_file(source: str, dest: str) -> None:
    if is_regular_file(source):
        shutil.copy2(source, dest)


def _save(out: Path, name: str, index: int, seed: int, folder: Path, outcome: str, detail: str) -> None:
    """Keep a defect's input (at most 20 per target and outcome) with what happened."""
    kept = out / "defects"
    if len(list(kept.glob(f"{name}-{outcome}-*"))) >= 20 if kept.is_dir() else False:
        return
    dest = kept / f"{name}-{outcome}-{index}"
    if folder.is_dir():  # links as links, FIFOs skipped: copying them would read /dev/zero or wait
        shutil.copytree(folder, dest, dirs_exist_ok=True, symlinks=True, copy_function=_copy_regular_file)
    dest.mkdir(parents=True, exist_ok=True)
    (dest / "defect.txt").write_text(
        f"target {name}, input {index} of seed {seed}: {outcome}\n"
        f"replay: python -m sim_tools.fuzz --replay {index} --seed {seed}\n\n{detail}\n",
        encoding="utf-8",
    )


def _stacks_of_hung(slot: _Slot) -> str:
    """Every thread's Python stack in a hung worker (it dumps them into its log on SIGUSR1): what
    a hang was doing, since replaying its input alone may not hang."""
    log = Path(slot.log)
    size = log.stat().st_size if log.exists() else 0
    try:
        os.kill(slot.process.pid, signal.SIGUSR1)
    except (ProcessLookupError, TypeError):
        return ""
    time.sleep(1.0)  # faulthandler writes at once, from its signal handler, GIL or not
    with open(log, "rb") as f:
        f.seek(size)
        text = f.read().decode("utf-8", "replace")
    return text[-20000:]


class _Slot:
    """One worker process and the range of inputs it is working through."""

    def __init__(self, ctx: Any, args: tuple, number: int) -> None:
        self.ctx, self.args, self.number = ctx, args, number
        self.task: tuple[int, int] | None = None
        self.pending: tuple[int, int] | None = None  # inputs to go on with after a hung one is rerun
        self.done_upto = 0
        self.start()

    def start(self) -> None:
        self.inputs_run = 0  # by this process
        self.tasks = self.ctx.Queue()
        self.current = self.ctx.Value("q", _IDLE, lock=False)
        self.started = self.ctx.Value("d", time.monotonic(), lock=False)
        self.results, sender = self.ctx.Pipe(duplex=False)
        seed_folder, seed, out = self.args
        self.log = log = str(Path(out) / f"worker-{self.number}.log")
        self.process = self.ctx.Process(
            target=_worker,
            args=(seed_folder, seed, self.tasks, sender, self.current, self.started, out, log),
            daemon=True,
        )
        self.process.start()
        sender.close()

    def receive(self, record: Any) -> None:
        """Record every result waiting in the pipe (all of them, when the worker has died)."""
        try:
            while self.results.poll():
                index, name, outcome, signature = self.results.recv()
                record(index, name, outcome, signature)
                self.inputs_run += 1
                self.done_upto = index + 1
                if self.task is not None and index + 1 == self.task[1]:
                    self.task = None
        except (EOFError, OSError):
            pass

    def recycle(self) -> None:
        """A fresh worker process for the next task (this one is idle: its results are all in)."""
        self.tasks.put(None)
        self.process.join(timeout=10)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.results.close()
        self.start()

    def give(self, task: tuple[int, int]) -> None:
        self.task = task
        self.done_upto = task[0]
        self.tasks.put(task)


def run_campaign(
    inputs: int,
    *,
    seconds: float = 900.0,
    workers: int = 2,
    seed: int = 1,
    out: str | Path = "out/fuzz",
    batch: int = 50,
    hang_seconds: float = 30.0,
    recycle_after: int = 1000,
    progress: bool = True,
) -> Report:
    """Run up to ``inputs`` inputs (fewer if ``seconds`` run out) and report what happened.

    A worker process is replaced by a fresh one after ``recycle_after`` inputs (at the end of a
    batch): what the libraries under test keep between inputs (Rerun keeps threads of every
    recording made) must not pile up over a long campaign and slow or stall the later inputs."""
    from sim_tools.fuzz.targets import Seeds, make_case, prepare_seeds

    out = Path(out)
    shutil.rmtree(out / "defects", ignore_errors=True)
    out.mkdir(parents=True, exist_ok=True)
    seed_folder = out / "seeds"
    shutil.rmtree(seed_folder, ignore_errors=True)
    prepare_seeds(seed_folder)
    seeds = Seeds.load(seed_folder)
    ctx = mp.get_context("spawn")
    report = Report(seed=seed, workers=workers, out=str(out))
    begin = time.monotonic()
    slots = [_Slot(ctx, (str(seed_folder), seed, str(out)), n) for n in range(workers)]
    next_index = 0
    finished = 0
    last_print = begin

    confirming: dict[int, str] = {}  # hung input -> the hung worker's stacks, while it runs again alone

    def record(index: int, name: str, outcome: str, signature: str = "") -> None:
        nonlocal finished
        finished += 1
        stacks = confirming.pop(index, None)
        if stacks is not None and outcome in ("ok", "input_error"):  # it hung only after other inputs
            report.counts[name][STALL] += 1
            report.stalls[f"{name}: stall"].append(index)
            save_lost(index, STALL, f"hung in a worker; run again alone in a fresh one: {outcome}\n\n{stacks}")
            return
        report.counts[name][outcome] += 1
        if signature:
            report.defects[signature].append(index)

    def save_lost(index: int, outcome: str, detail: str) -> str:
        """Rebuild the input a lost worker was running and save it; returns its target's name."""
        scratch = Path(tempfile.mkdtemp(prefix="fuzz-lost-"))
        try:
            name, _ = make_case(index, seed, seeds, scratch / "case")
            _save(out, name, index, seed, scratch / "case", outcome, detail)
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
        return name

    def lost(slot: _Slot, outcome: str) -> None:
        """The worker died or hung on its current input: restart it; record a crash, or run a hung
        input once more, alone, before recording it."""
        index = slot.current.value
        stacks = _stacks_of_hung(slot) if outcome == "hang" else ""
        if slot.process.is_alive():
            slot.process.kill()
        slot.process.join()
        exitcode = slot.process.exitcode
        report.restarts += 1
        rest = (index + 1 if index != _IDLE else slot.done_upto, slot.task[1]) if slot.task else None
        slot.results.close()
        slot.start()
        slot.task = None
        if rest and rest[0] < rest[1]:
            slot.pending = rest
        if index == _IDLE:
            return
        if outcome == "hang" and index not in confirming:
            confirming[index] = f"the worker's threads when it was killed:\n{stacks}"
            slot.give((index, index + 1))
            return
        detail = f"exit code {exitcode}"
        if stacks:
            detail += f" (it hung when run alone too)\n\nthe worker's threads when it was killed:\n{stacks}"
        confirming.pop(index, None)
        name = save_lost(index, outcome, detail)
        record(index, name, outcome, f"{name}: {outcome} (exit code {exitcode})")

    try:
        while True:
            out_of_time = time.monotonic() - begin > seconds
            for slot in slots:
                if slot.task is None and slot.inputs_run >= recycle_after:
                    slot.recycle()
                    report.recycled += 1
                if slot.task is None and slot.pending is not None:  # the rest of a lost worker's batch
                    slot.give(slot.pending)
                    slot.pending = None
                if slot.task is None and next_index < inputs and not out_of_time:
                    task = (next_index, min(next_index + batch, inputs))
                    next_index = task[1]
                    slot.give(task)
            if all(slot.task is None for slot in slots):
                break
            ready = wait([slot.results for slot in slots if slot.task is not None], timeout=0.2)
            for slot in slots:
                if slot.results in ready:
                    slot.receive(record)
            now = time.monotonic()
            for slot in slots:
                if slot.task is None:
                    continue
                if not slot.process.is_alive():
                    slot.receive(record)
                    if slot.task is not None:
                        lost(slot, "crash")
                elif slot.current.value != _IDLE and now - slot.started.value > hang_seconds:
                    lost(slot, "hang")
            if progress and now - last_print > 10.0:
                last_print = now
                print(f"fuzz: {finished} inputs, {report.failures} failures, {now - begin:.0f} s", file=sys.stderr)
            if now - begin > seconds + 2 * hang_seconds:
                break  # hard stop: a slow batch must not hold the campaign past its budget
    finally:
        for slot in slots:
            if slot.process.is_alive():
                slot.tasks.put(None)
        for slot in slots:
            slot.process.join(timeout=5)
            if slot.process.is_alive():
                slot.process.kill()
    report.inputs = finished
    report.seconds = time.monotonic() - begin
    (out / "summary.json").write_text(json.dumps(report.to_json(), indent=1), encoding="utf-8")
    return report


def replay(index: int, seed: int, out: str | Path = "out/fuzz") -> None:
    """Run one input of a campaign in this process, with its traceback (for debugging a defect)."""
    from sim_tools.fuzz.targets import Seeds, make_case, prepare_seeds

    out = Path(out)
    if not (out / "seeds").is_dir():
        prepare_seeds(out / "seeds")
    folder = out / f"replay-{index}"
    shutil.rmtree(folder, ignore_errors=True)
    name, case = make_case(index, seed, Seeds.load(out / "seeds"), folder)
    print(f"input {index} ({name}) in {folder}", file=sys.stderr)
    case.run()
