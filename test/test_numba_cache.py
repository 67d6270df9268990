"""numba's cache stays coherent when processes compile one kernel at once (sim_runtime.numba_cache).

Without the lock, four processes compiling four signatures of one fresh kernel left an index entry
naming a file that held another signature's code in 1 of 10 trials: the process that later loads
it crashes. Here a second compiler is seen to wait for the lock a first one holds."""

from __future__ import annotations

import fcntl
import os
import pickle
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
KERNEL = """
import numba

@numba.njit(cache=True)
def doubled_sum(x):
    s = 0
    for i in range(x.shape[0]):
        s += x[i] * 2
    return s
"""
FLOCK_SYSCALL = 73  # x86_64


def compile_in_child(folder: Path, dtype: str) -> subprocess.Popen:
    code = f"import sim_runtime, numpy as np, kernel; print(kernel.doubled_sum(np.arange(5, dtype=np.{dtype})))"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(folder / "cache"), PYTHONPATH=f"{folder}{os.pathsep}{ROOT}")
    return subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)


def index_entries(folder: Path) -> dict[str, tuple]:
    """Each entry of the kernel's index: data file → (the signature it is filed under, the one it holds)."""
    (index,) = (folder / "cache").rglob("*.nbi")
    with index.open("rb") as f:
        pickle.load(f)
        _stamp, overloads = pickle.loads(f.read())
    entries = {}
    for key, name in overloads.items():
        payload = pickle.loads((index.parent / name).read_bytes())
        entries[name] = (tuple(key[0]), tuple(payload[3].args))
    return entries


def wait_in_flock(process: subprocess.Popen, timeout: float = 60.0) -> bool:
    """Whether ``process`` comes to wait in flock(2) before it ends (or the timeout)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and process.poll() is None:
        try:
            if Path(f"/proc/{process.pid}/syscall").read_text().split()[0] == str(FLOCK_SYSCALL):
                return True
        except (OSError, IndexError):
            pass
        time.sleep(0.005)  # polling the child's state, not waiting for time to pass
    return False


def test_a_process_saving_a_kernel_waits_for_the_lock_and_the_index_stays_coherent(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))  # reading an entry back imports the kernel's module

    (tmp_path / "kernel.py").write_text(textwrap.dedent(KERNEL), encoding="utf-8")
    first = compile_in_child(tmp_path, "int64")
    assert first.communicate(timeout=120)[0].strip() == "20"
    (lock_path,) = (tmp_path / "cache").rglob("*.nbi.lock")
    with lock_path.open("ab") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        second = compile_in_child(tmp_path, "float64")
        assert wait_in_flock(second), "the second compiler saved without taking the lock"
        assert len(index_entries(tmp_path)) == 1  # nothing written while we hold the lock
    assert second.communicate(timeout=120)[0].strip() == "20.0"
    entries = index_entries(tmp_path)
    assert len(entries) == 2
    assert all(filed == held for filed, held in entries.values()), entries


CALLEE = """
import numba

@numba.njit(cache=True)
def gain():
    return {gain}
"""
CALLER = """
import numba
from probe.callee import gain

@numba.njit(cache=True)
def doubled():
    return 2 * gain()
"""


def run_caller(folder: Path) -> str:
    code = "import sim_runtime; from probe.caller import doubled; print(doubled())"
    env = dict(os.environ, PYTHONPATH=f"{folder}{os.pathsep}{ROOT}")
    env.pop("NUMBA_CACHE_DIR", None)  # the probe's own __pycache__, as for our packages
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120).stdout


def test_a_cached_kernel_runs_the_new_code_of_a_kernel_it_calls_from_another_file(tmp_path):
    package = tmp_path / "probe"
    package.mkdir()
    (package / "__init__.py").write_text("", encoding="utf-8")
    (package / "caller.py").write_text(textwrap.dedent(CALLER), encoding="utf-8")
    (package / "callee.py").write_text(textwrap.dedent(CALLEE.format(gain=1)), encoding="utf-8")
    assert run_caller(tmp_path).strip() == "2"
    assert list((package / "__pycache__").glob("caller.doubled-*.nbi"))  # cached: the next run loads it
    (package / "callee.py").write_text(textwrap.dedent(CALLEE.format(gain=5)), encoding="utf-8")
    assert run_caller(tmp_path).strip() == "10"  # numba alone would load the old caller: 2


def test_a_cache_entry_made_beside_one_copy_of_a_package_is_loaded_beside_another(tmp_path):
    # What an install ships: entries made beside the build's sources, used beside the installed
    # copies (another folder, another file time). Nothing but the contents may key them.
    first, second = tmp_path / "a", tmp_path / "b"
    package = first / "probe"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("", encoding="utf-8")
    (package / "caller.py").write_text(textwrap.dedent(CALLER), encoding="utf-8")
    (package / "callee.py").write_text(textwrap.dedent(CALLEE.format(gain=3)), encoding="utf-8")
    assert run_caller(first).strip() == "6"
    shutil.copytree(first, second)
    later = time.time() + 3600
    for path in (second / "probe").glob("*.py"):
        os.utime(path, (later, later))
    code = "import sim_runtime; from probe.caller import doubled; print(doubled())"
    env = dict(os.environ, PYTHONPATH=f"{second}{os.pathsep}{ROOT}", NUMBA_DEBUG_CACHE="1")
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120).stdout
    assert out.splitlines()[-1] == "6"
    assert f"data loaded from '{second}" in out, out
    assert "data saved to" not in out, out  # nothing compiled again


def test_two_kernels_of_one_function_with_other_options_keep_apart_cache_entries():
    # numba files an entry by function name and line, not by options: the fast caster's copy of
    # the traversal (fastmath) and the exact one shared one entry, each loading the other's code.
    from simrobot_sim.raycast import _traverse, _traverse_fast

    assert _traverse.targetoptions != _traverse_fast.targetoptions
    assert _traverse._cache._cache_file._index_path != _traverse_fast._cache._cache_file._index_path
