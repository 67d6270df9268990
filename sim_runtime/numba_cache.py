"""numba's on-disk cache, safe when several processes compile the same kernel at once.

numba chooses the data file of a new cache entry from the index it has just read, then rewrites
the index. Two processes compiling different signatures of one kernel at the same moment can
both choose ``<kernel>.1.nbc``: the index then names one signature while the file holds the
other's machine code, which a later process loads and calls with the wrong argument types — a
segfault, long after and far from its cause. Our kernels are compiled in parallel on a cold cache
(a helper process beside each world, batch workers, the worlds a test or the studio starts), so
every save and load of a cache entry here holds a lock on a file beside the kernel's index.

The lock is installed when numba's caching module loads (or at once if it already has): importing
:mod:`sim_runtime` is enough, and every package with kernels does.
"""

from __future__ import annotations

import fcntl
import functools
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from collections.abc import Callable
from types import ModuleType
from typing import Any

_CACHING = "numba.core.caching"


def _locked(method: Callable[..., Any], mode: int) -> Callable[..., Any]:
    @functools.wraps(method)
    def locked(self: Any, *args: Any) -> Any:
        try:
            lock = open(self._index_path + ".lock", "ab")  # noqa: SIM115 (closed below, after the call)
        except OSError:  # a read-only cache folder: nobody writes there, nothing to guard
            return method(self, *args)
        with lock:
            fcntl.flock(lock, mode)
            return method(self, *args)

    locked.__robot_sims_locked__ = True  # type: ignore[attr-defined]
    return locked


def _patch(caching: ModuleType) -> None:
    cache_file = caching.IndexDataCacheFile
    if getattr(cache_file.save, "__robot_sims_locked__", False):
        return
    cache_file.save = _locked(cache_file.save, fcntl.LOCK_EX)
    cache_file.load = _locked(cache_file.load, fcntl.LOCK_SH)


class _PatchWhenLoaded(importlib.abc.MetaPathFinder):
    """Finds nothing itself: wraps the loading of numba's caching module to patch it."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if name != _CACHING:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        loader = spec.loader
        exec_module = loader.exec_module

        def exec_and_patch(module: ModuleType) -> None:
            exec_module(module)
            _patch(module)

        loader.exec_module = exec_and_patch  # type: ignore[method-assign]
        return spec


def lock_numba_cache() -> None:
    """Guard numba's cache entries with a file lock in this process, now or when numba loads."""
    if _CACHING in sys.modules:
        _patch(sys.modules[_CACHING])
    elif not any(isinstance(finder, _PatchWhenLoaded) for finder in sys.meta_path):
        sys.meta_path.insert(0, _PatchWhenLoaded())
