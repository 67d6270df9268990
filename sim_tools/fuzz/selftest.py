"""The harness's own target (``ROBOT_SIMS_FUZZ_SELFTEST=1``): inputs that crash, raise, hang or stall."""

from __future__ import annotations

import random
import time
from pathlib import Path
from typing import Any

from sim_tools.fuzz_kit import Case

_selftest_runs = 0


def selftest_case(rng: random.Random, seeds: Any, folder: Path) -> Case:
    """Checks the harness itself: every 7th input kills its process (as a segfault would),
    every 5th raises a plain exception, number 33 never returns, number 34 never returns unless it
    is the first input of its process (a stall), the rest load or raise InputError."""
    number = rng.randrange(35)
    (folder / "number.txt").write_text(str(number), encoding="utf-8")
    return Case(folder, lambda: _run(number))


def _run(number: int) -> None:
    from sim_runtime.errors import InputError

    global _selftest_runs
    _selftest_runs += 1
    if number % 7 == 0:
        import ctypes

        ctypes.string_at(0)  # SIGSEGV
    if number % 5 == 0:
        raise RuntimeError("selftest defect")
    if number == 33 or (number == 34 and _selftest_runs > 1):
        _selftest_hang()
    if number % 2:
        raise InputError("selftest input error")


def _selftest_hang() -> None:
    while True:
        time.sleep(1.0)
