"""numba's on-disk cache, safe when several processes compile the same kernel at once.

numba chooses the data file of a new cache entry from the index it has just read, then rewrites
the index. Two processes compiling different signatures of one kernel at the same moment can
both choose ``<kernel>.1.nbc``: the index then names one signature while the file holds the
other's machine code, which a later process loads and calls with the wrong argument types — a
segfault, long after and far from its cause. Our kernels are compiled in parallel on a cold cache
(a helper process beside each world, batch workers, the worlds a test or the studio starts), so
every save and load of a cache entry here holds a lock on a file beside the kernel's index.

numba also checks a cache entry against its own source file only, while a kernel carries the
code of the kernels it calls, compiled in: after ``git pull`` changed ``geometry.py`` alone, the
cached physics step still ran the old geometry, and in one process its copy and the new one
could meet under one name, with a crash as soon as the result was boxed. Here an entry's stamp
(:func:`source_stamp`) is its file's contents and a digest of every kernel source of its own
top-level package and of ``sim_runtime`` (the only packages a kernel calls into), so a change
anywhere there recompiles them, and nothing else does: not a new path or file time, so the cache
a build ships beside the installed sources is used there.

Both are installed when numba's caching module loads (or at once if it already has): importing
:mod:`sim_runtime` is enough, and every package with kernels does.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path
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


def top_package(py_file: str | Path) -> Path:
    """The folder of the top-level package holding ``py_file`` (its own folder outside a package)."""
    folder = Path(py_file).resolve().parent
    while (folder.parent / "__init__.py").is_file():
        folder = folder.parent
    return folder


@functools.cache
def kernel_sources_digest(package: Path) -> str:
    """SHA-256 of every ``.py`` file under ``package`` that uses numba (read once per process)."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text:
            digest.update(str(path.relative_to(package)).encode() + b"\0" + text)
    return digest.hexdigest()


_BASE = Path(__file__).resolve().parent  # sim_runtime: its kernels are called from every package


@functools.cache
def _file_digest(path: str, mtime_ns: int, size: int) -> bytes:
    """SHA-256 of a file's bytes (read again when its time or size changes)."""
    return hashlib.sha256(Path(path).read_bytes()).digest()


def source_stamp(py_file: str | Path) -> tuple[bytes, tuple[str, ...]]:
    """What a cache entry of a kernel in ``py_file`` is valid for: that file's contents (what
    numba 0.68 stamps; older numba used its time, which every install changes) and the digests
    of :func:`kernel_sources_digest`. No path and no time: an entry made beside a source tree
    is valid beside an installed copy of it (the cache a build ships, ``sim_tools.warmup``)."""
    st = Path(py_file).stat()
    packages = sorted({top_package(py_file), _BASE})
    return _file_digest(str(py_file), st.st_mtime_ns, st.st_size), tuple(kernel_sources_digest(p) for p in packages)


def _stamped(get_source_stamp: Callable[[Any], Any]) -> Callable[[Any], Any]:
    @functools.wraps(get_source_stamp)
    def stamp(self: Any) -> Any:
        return source_stamp(self._py_file)

    return stamp


def _patch(caching: ModuleType) -> None:
    cache_file = caching.IndexDataCacheFile
    if getattr(cache_file.save, "__robot_sims_locked__", False):
        return
    cache_file.save = _locked(cache_file.save, fcntl.LOCK_EX)
    cache_file.load = _locked(cache_file.load, fcntl.LOCK_SH)
    locator = caching._SourceFileBackedLocatorMixin
    locator.get_source_stamp = _stamped(locator.get_source_stamp)


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
    """Guard numba's cache entries with a file lock and package-wide stamps in this process, now
    or when numba loads."""
    if _CACHING in sys.modules:
        _patch(sys.modules[_CACHING])
    elif not any(isinstance(finder, _PatchWhenLoaded) for finder in sys.meta_path):
        sys.meta_path.insert(0, _PatchWhenLoaded())
