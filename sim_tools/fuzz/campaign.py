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
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

from sim_runtime.inputfile import is_regular_file
from sim_tools.fuzz.budget import Budget, Meter, rss_mb

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
    """Target, exception type and the innermost frame of the code under test (not the fuzzer's,
    the fuzz kit's or a simulator's fuzz part): one line per distinct defect."""
    from sim_tools.fuzz.targets import harness_files

    harness = harness_files()
    frames = traceback.extract_tb(exc.__traceback__)
    ours = [f for f in frames if not ("/sim_tools/fuzz" in f.filename or f.filename in harness)] or frames
    where = f"{Path(ours[-1].filename).name}:{ours[-1].lineno}" if ours else "?"
    return f"{name}: {type(exc).__name__} at {where}"


def _worker(
    seed_folder: str,
    seed: int,
    tasks: Any,
    results: Any,
    current: Any,
    started: Any,
    out: str,
    log: str,
    budget: Budget,
) -> None:
    """Run inputs of the ranges put on ``tasks``; one result per input on the pipe ``results``."""
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    import faulthandler

    from sim_tools.batch.supervisor import no_core_files

    faulthandler.enable()
    no_core_files()  # the inputs crashing it on purpose are reported with their stacks
    faulthandler.register(signal.SIGUSR1, all_threads=True)  # the parent asks for our stacks before killing a hang
    warnings.simplefilter("ignore")
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    from sim_tools.fuzz.targets import Seeds, warm_up

    seeds = Seeds.load(Path(seed_folder))
    scratch = Path(tempfile.mkdtemp(prefix="fuzz-", dir="/dev/shm" if os.path.isdir("/dev/shm") else None))
    warm_up(seeds, scratch / "warm-up")
    try:
        while (task := tasks.get()) is not None:
            for index in range(*task):
                started.value = time.monotonic()
                current.value = index
                result = _run_input(index, seed, seeds, scratch / str(index), Path(out), budget)
                current.value = _IDLE
                results.send(result)  # synchronous: survives our crash
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def outcome_of(run: Callable[[], object], meter: Meter) -> str:
    """``run()`` measured by ``meter``: "ok", or "input_error" where it refused its input; any
    other exception (a defect) goes on to the caller."""
    from sim_runtime.errors import InputError

    try:
        with meter:
            run()
    except InputError:
        return "input_error"
    return "ok"


def _run_input(
    index: int, seed: int, seeds: Any, folder: Path, out: Path, budget: Budget | None = None
) -> tuple[int, str, str, str]:
    """Make and run input ``index`` in ``folder``, saving it if it is a defect: (index, target,
    outcome, signature). An input over ``budget`` (CPU seconds, memory) is a defect too."""
    from sim_tools.fuzz.targets import make_case, target_of

    name = target_of(index, seed)
    signature = ""
    meter = Meter()
    try:
        name, case = make_case(index, seed, seeds, folder)
        outcome = outcome_of(case.run, meter)
        over = meter.over(budget) if budget is not None else None
        if over is not None:
            outcome, signature = "defect", f"{name}: over budget ({'CPU' if 'CPU' in over else 'memory'})"
            _save(out, name, index, seed, folder, "defect", f"over the per-input budget: {over} ({case.note})")
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            raise
        outcome = "defect"
        signature = _signature(name, exc)
        _save(out, name, index, seed, folder, "defect", "".join(traceback.format_exception(exc)))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return index, name, outcome, signature


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
        seed_folder, seed, out, budget = self.args
        self.log = log = str(Path(out) / f"worker-{self.number}.log")
        self.process = self.ctx.Process(
            target=_worker,
            args=(seed_folder, seed, self.tasks, sender, self.current, self.started, out, log, budget),
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


class Campaign:
    """A campaign's state: its worker slots, the next input to hand out, the report, and the hung
    inputs being run once more alone. :meth:`run` hands inputs out until they or the time run out.

    A worker process is replaced by a fresh one after ``recycle_after`` inputs (at the end of a
    batch): what the libraries under test keep between inputs (Rerun keeps threads of every
    recording made) must not pile up over a long campaign and slow or stall the later inputs."""

    def __init__(
        self,
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
        budget: Budget | None = None,
    ) -> None:
        self.budget = budget or Budget()
        self.inputs, self.seconds, self.workers, self.seed = inputs, seconds, workers, seed
        self.out = Path(out)
        self.batch, self.hang_seconds, self.recycle_after, self.progress = batch, hang_seconds, recycle_after, progress
        self.report = Report(seed=seed, workers=workers, out=str(self.out))
        self.next_index = 0
        self.finished = 0
        self.confirming: dict[int, str] = {}  # hung input -> the hung worker's stacks, while it runs again alone
        self.slots: list[_Slot] = []

    def run(self) -> Report:
        """Run up to ``inputs`` inputs (fewer if ``seconds`` run out) and report what happened."""
        seed_folder = self._prepare()
        ctx = mp.get_context("spawn")
        self.begin = self.last_print = time.monotonic()
        args = (str(seed_folder), self.seed, str(self.out), self.budget)
        self.slots = [_Slot(ctx, args, n) for n in range(self.workers)]
        try:
            while self._round():
                pass
        finally:
            self._stop_workers()
        self.report.inputs = self.finished
        self.report.seconds = time.monotonic() - self.begin
        (self.out / "summary.json").write_text(json.dumps(self.report.to_json(), indent=1), encoding="utf-8")
        return self.report

    def _prepare(self) -> Path:
        """A fresh seed corpus (and no defects of an earlier campaign) in the output folder."""
        from sim_tools.fuzz.targets import Seeds, prepare_seeds

        shutil.rmtree(self.out / "defects", ignore_errors=True)
        self.out.mkdir(parents=True, exist_ok=True)
        seed_folder = self.out / "seeds"
        shutil.rmtree(seed_folder, ignore_errors=True)
        prepare_seeds(seed_folder)
        self.seeds = Seeds.load(seed_folder)
        return seed_folder

    def _round(self) -> bool:
        """Hand out work, take in results, deal with dead and hung workers; False when it is over."""
        self._hand_out(out_of_time=time.monotonic() - self.begin > self.seconds)
        if all(slot.task is None for slot in self.slots):
            return False
        ready = wait([slot.results for slot in self.slots if slot.task is not None], timeout=0.2)
        for slot in self.slots:
            if slot.results in ready:
                slot.receive(self.record)
        now = time.monotonic()
        for slot in self.slots:
            if slot.task is not None:
                self._check(slot, now)
        if self.progress and now - self.last_print > 10.0:
            self.last_print = now
            elapsed = now - self.begin
            print(f"fuzz: {self.finished} inputs, {self.report.failures} failures, {elapsed:.0f} s", file=sys.stderr)
        return now - self.begin <= self.seconds + 2 * self.hang_seconds  # a slow batch must not hold it past its budget

    def _hand_out(self, out_of_time: bool) -> None:
        """An idle worker is recycled if due, then given the rest of a lost batch or the next batch."""
        for slot in self.slots:
            if slot.task is None and slot.inputs_run >= self.recycle_after:
                slot.recycle()
                self.report.recycled += 1
            if slot.task is None and slot.pending is not None:  # the rest of a lost worker's batch
                slot.give(slot.pending)
                slot.pending = None
            if slot.task is None and self.next_index < self.inputs and not out_of_time:
                task = (self.next_index, min(self.next_index + self.batch, self.inputs))
                self.next_index = task[1]
                slot.give(task)

    def _check(self, slot: _Slot, now: float) -> None:
        """A busy worker that died is a crash (once its last results are in); one too long on an input, a hang."""
        if not slot.process.is_alive():
            slot.receive(self.record)
            if slot.task is not None:
                self._lost(slot, "crash")
        elif slot.current.value != _IDLE and now - slot.started.value > self.hang_seconds:
            self._lost(slot, "hang")
        elif slot.current.value != _IDLE and rss_mb(slot.process.pid) > self.budget.kill_mb:
            # far over the memory budget: killed before it takes the machine, counted as a crash
            self._lost(slot, "crash", f"killed at over {self.budget.kill_mb:.0f} MB resident")

    def _stop_workers(self) -> None:
        for slot in self.slots:
            if slot.process.is_alive():
                slot.tasks.put(None)
        for slot in self.slots:
            slot.process.join(timeout=5)
            if slot.process.is_alive():
                slot.process.kill()

    def record(self, index: int, name: str, outcome: str, signature: str = "") -> None:
        """Count one input's outcome; a hung input that ended when run alone is a stall."""
        self.finished += 1
        stacks = self.confirming.pop(index, None)
        if stacks is not None and outcome in ("ok", "input_error"):  # it hung only after other inputs
            self.report.counts[name][STALL] += 1
            self.report.stalls[f"{name}: stall"].append(index)
            self._save_lost(index, STALL, f"hung in a worker; run again alone in a fresh one: {outcome}\n\n{stacks}")
            return
        self.report.counts[name][outcome] += 1
        if signature:
            self.report.defects[signature].append(index)

    def _save_lost(self, index: int, outcome: str, detail: str) -> str:
        """Rebuild the input a lost worker was running and save it; returns its target's name."""
        from sim_tools.fuzz.targets import make_case

        scratch = Path(tempfile.mkdtemp(prefix="fuzz-lost-"))
        try:
            name, _ = make_case(index, self.seed, self.seeds, scratch / "case")
            _save(self.out, name, index, self.seed, scratch / "case", outcome, detail)
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
        return name

    def _lost(self, slot: _Slot, outcome: str, why: str = "") -> None:
        """The worker died or hung on its current input: restart it; record a crash, or run a hung
        input once more, alone, before recording it."""
        index = slot.current.value
        stacks = _stacks_of_hung(slot) if outcome == "hang" else ""
        exitcode = self._restart(slot, index)
        if index == _IDLE:
            return
        if outcome == "hang" and index not in self.confirming:
            self.confirming[index] = f"the worker's threads when it was killed:\n{stacks}"
            slot.give((index, index + 1))
            return
        detail = f"exit code {exitcode}" + (f": {why}" if why else "")
        if stacks:
            detail += f" (it hung when run alone too)\n\nthe worker's threads when it was killed:\n{stacks}"
        self.confirming.pop(index, None)
        name = self._save_lost(index, outcome, detail)
        self.record(index, name, outcome, f"{name}: {outcome} (exit code {exitcode})")

    def _restart(self, slot: _Slot, index: int) -> int | None:
        """Kill the worker and start a fresh one, to go on after ``index`` with the rest of its
        batch; returns the old one's exit code."""
        if slot.process.is_alive():
            slot.process.kill()
        slot.process.join()
        exitcode = slot.process.exitcode
        self.report.restarts += 1
        rest = (index + 1 if index != _IDLE else slot.done_upto, slot.task[1]) if slot.task else None
        slot.results.close()
        slot.start()
        slot.task = None
        if rest and rest[0] < rest[1]:
            slot.pending = rest
        return exitcode


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
