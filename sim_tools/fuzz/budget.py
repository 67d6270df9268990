"""What one fuzz input may cost: CPU seconds and memory, measured in the worker around each input.

An input over its :class:`Budget` is a defect of its target (a loader that takes minutes or
gigabytes over a small file is as broken as one that crashes), whatever its outcome. CPU seconds,
not wall seconds: the figure does not stretch when the machine is busy. Memory is the growth of
the worker's resident set over the input: its peak (``ru_maxrss``, when the input set a new one)
or, below an earlier peak, what a sampling thread saw. The campaign also watches each worker from
outside (:meth:`Budget.kill_mb`): a worker past that is killed at once, before it can take the
machine, and its input counted as a crash.
"""

from __future__ import annotations

import os
import resource
import threading
import time
from dataclasses import dataclass

_PAGE_MB = os.sysconf("SC_PAGE_SIZE") / 2**20


@dataclass(frozen=True)
class Budget:
    """The most one input may take: ``cpu_seconds`` of the worker's CPU and ``memory_mb`` of growth."""

    cpu_seconds: float = 20.0
    memory_mb: float = 1024.0

    @property
    def kill_mb(self) -> float:
        """Resident size (MB) past which the campaign kills a worker: well over any baseline plus the budget."""
        return 2048.0 + 2.0 * self.memory_mb


def rss_mb(pid: int | str = "self") -> float:
    """Resident set size of process ``pid`` in MB (0 when it is gone)."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * _PAGE_MB
    except (OSError, IndexError, ValueError):
        return 0.0


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class Meter:
    """``with Meter() as m: run()``; then ``m.cpu_s`` and ``m.memory_mb`` (peak growth)."""

    def __init__(self, interval_s: float = 0.01) -> None:
        self.interval_s = interval_s
        self.cpu_s = 0.0
        self.memory_mb = 0.0

    def __enter__(self) -> Meter:
        self._base = rss_mb()
        self._peak_before = _peak_mb()
        self._sampled = self._base
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._sample, name="fuzz-meter", daemon=True)
        self._thread.start()
        self._cpu0 = time.process_time()
        return self

    def _sample(self) -> None:
        while not self._done.wait(self.interval_s):
            self._sampled = max(self._sampled, rss_mb())

    def __exit__(self, *_exc: object) -> None:
        self.cpu_s = time.process_time() - self._cpu0
        self._done.set()
        self._thread.join()
        peak = _peak_mb()
        top = peak if peak > self._peak_before else max(self._sampled, rss_mb())
        self.memory_mb = max(top - self._base, 0.0)

    def over(self, budget: Budget) -> str | None:
        """Why the input was over ``budget`` ("12.3 CPU s > 10", "1500 MB > 1024"), or None."""
        if self.cpu_s > budget.cpu_seconds:
            return f"{self.cpu_s:.1f} CPU s > {budget.cpu_seconds:g}"
        if self.memory_mb > budget.memory_mb:
            return f"{self.memory_mb:.0f} MB > {budget.memory_mb:g}"
        return None
