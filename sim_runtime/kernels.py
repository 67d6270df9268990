"""Kernels compiled before a world is ready: say so when numba compiles, share the work with a helper process.

The worlds compile every kernel they can use before they are ready (their models'
``compile_kernels``), with :func:`announce_compiling` saying so only when numba really compiles and
:func:`compiled_aside` sharing the work with a second process on a cold cache. ``python -m
sim_tools.warmup`` (run by ``make venv`` and by an install's build) fills numba's cache beforehand.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

#: What a world logs before numba compiles its first kernel (only then: loads from the cache are
#: silent). No time is promised: a cold compile of a world is 10-30 s of CPU, which a loaded
#: machine stretches into minutes. An install ships the cache (``setup.py``'s warm-up), so this is
#: seen only where that could not run, or after the sources changed.
COMPILING_NOTICE = (
    "compiling kernels: none in numba's cache for these sources (once; `python -m sim_tools.warmup` "
    "compiles them all) ..."
)


@contextmanager
def announce_compiling(say: Callable[[str], None]) -> Iterator[None]:
    """Within the block, ``say`` :data:`COMPILING_NOTICE` once when numba starts compiling a kernel
    (a cache miss: nothing when every kernel comes from numba's cache, wherever that is), and when
    the block ends how long it took."""
    from numba.core import event

    class Notice(event.Listener):
        def __init__(self) -> None:
            self.depth = 0  # a kernel's callees are compiled inside its own compile event
            self.compiled = 0
            self.started = 0.0

        def on_start(self, _event: event.Event) -> None:
            if self.depth == 0 and self.compiled == 0:
                say(COMPILING_NOTICE)
                self.started = time.monotonic()
            self.depth += 1

        def on_end(self, _event: event.Event) -> None:
            self.depth -= 1
            self.compiled += self.depth == 0

    notice = Notice()
    with event.install_listener("numba:compile", notice):
        yield
    if notice.compiled:
        seconds = time.monotonic() - notice.started
        say(f"kernels compiled in {seconds:.1f} s (numba caches them for the next start)")


@contextmanager
def compiled_aside(obj: Any, method: str, enabled: bool = True) -> Iterator[None]:
    """Within the block, the first time numba starts compiling (a cold cache), start a process that
    calls ``method`` of a copy of ``obj`` (pickled now, before the block changes it): numba compiles
    one kernel at a time per process, so that method's kernels are compiled, into numba's cache,
    beside whatever the block compiles; call it after the block and it loads them. At the end of
    the block, wait for the helper. Nothing starts when everything is cached or on a single core."""
    from numba.core import event

    pickled = pickle.dumps(obj) if enabled and (os.cpu_count() or 1) > 1 else b""
    helpers: list[subprocess.Popen[bytes]] = []

    class StartHelper(event.Listener):
        def on_start(self, _event: event.Event) -> None:
            if pickled and not helpers:
                helpers.append(_start_helper(pickled, method))

        def on_end(self, _event: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", StartHelper()):
        yield
    for helper in helpers:
        helper.wait()  # its outcome does not matter: anything it did not cache is compiled afterwards


def _start_helper(pickled: bytes, method: str) -> subprocess.Popen[bytes]:
    """A process that unpickles an object from its stdin and calls its ``method``."""
    # the same modules from the same files (numba's cache is per file), nothing on the terminal
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    helper = subprocess.Popen(
        # -P: not the current directory first
        [sys.executable, "-P", "-c", f"import pickle, sys; pickle.load(sys.stdin.buffer).{method}()"],
        stdin=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    stdin = helper.stdin
    assert stdin is not None

    def feed() -> None:  # in a thread: the pipe fills until the helper has imported numba
        with stdin:
            stdin.write(pickled)

    threading.Thread(target=feed, daemon=True).start()
    return helper
