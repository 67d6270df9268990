"""Compile every numba kernel once, into numba's on-disk cache, so a user's first world starts in seconds.

``python -m sim_tools.warmup`` (run by ``make venv``) has each registered simulator's adapter drive
its pure model the way its node does, on small inputs (``warm_up`` in
:mod:`sim_tools.adapters.contract`: the Create's step and every sensor, a SIMROBOT world with both
sensor types, an arm's forward/inverse kinematics and dynamics, the STL readers and the rotation
kernel), then the bag index on a simulator's sample run. Without it the first start of a world
compiles for a minute or more (the arm's inverse dynamics alone is ~25 s of CPU). Each kernel is
cached per argument types, so the calls pass what the nodes pass. The warmers run in parallel
processes (``--jobs``, default: one a core): numba compiles one kernel at a time per process, and
:mod:`sim_runtime.numba_cache` keeps two processes saving one kernel from mixing their entries.

An install warms too: ``setup.py``'s ``build_py`` (pip, ``colcon build``) calls :func:`build_cache`,
which warms the tree being built and ships the cache entries in the build (``--export-to``), so
the installed package's first start loads every kernel. numba keys an entry on its source file's
contents (and :mod:`sim_runtime.numba_cache` on every kernel source of the package), not on
paths or times, so an entry made beside the tree's sources is valid beside their installed
copies; machine code is also keyed on the CPU, so a wheel built on another machine just compiles
at its first start. ``ROBOT_SIMS_BUILD_WARMUP=0`` skips the warm-up of a build.

The worlds themselves compile every kernel they can use before they are ready
(:mod:`sim_runtime.kernels`).

This module imports numpy, numba and the simulators only inside its functions: ``setup.py`` runs
it in a build environment that may have none of them.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

#: The setting that turns the warm-up of a build off (for a wheel built for other machines).
BUILD_WARMUP_ENV = "ROBOT_SIMS_BUILD_WARMUP"
#: Longest first, so that the jobs end together; the learning environments reuse the arm's and
#: the Create's kernels, so they come after them.
ORDER = ("arm", "simrobot", "create", "replay", "learning")
#: The cached kernels no warm-up compiles, and why (``test_warmup`` checks every other one is cached).
NOT_WARMED = {
    "create_sim.geometry.brute_cast_fan": "the reference the tests and bench/ check the grid caster against",
    "simrobot_sim.raycast.cast_ray_exact": "the casters' one-call API for tests and bench/ (the model's: *_into)",
    "simrobot_sim.raycast.cast_scan_exact": "the casters' one-call API for tests and bench/",
    "simrobot_sim.raycast.cast_scan_fast": "the casters' one-call API for tests and bench/",
    "simrobot_sim.raycast._traverse": "cast_ray_exact's traversal (the model's is _traverse_fast)",
    "simrobot_sim.model._plan_moves_parallel": "worlds of 256 robots or more only, whose wide ids every kernel "
    "compiles for anew at their first start",
}
WARMUP_TIMEOUT_S = 3600.0  # a ceiling for a stuck warm-up, far above its minutes on a loaded machine


def warm_replay() -> None:
    """The bag index and the fast pose reader the studio's Replay page opens a bag with, on the
    first simulator's sample run that has one."""
    import numpy as np

    from sim_runtime.bag.cdr import track_positions
    from sim_runtime.bag.index import BagIndex, _message_records
    from sim_tools.adapters.contract import world_parts

    for sample_run in [part.sample_run for part in world_parts().values() if part.sample_run is not None][:1]:
        with tempfile.TemporaryDirectory() as tmp:
            index = BagIndex.open(sample_run(Path(tmp)))
            for topic, info in index.by_topic.items():
                track_positions(info.type, [m.data for m in index.messages(topic)])
            index.close()
    _message_records(np.frombuffer(bytes(9), dtype=np.uint8))  # chunks without message indexes


def warm_learning() -> None:
    """The learning environments' own kernels (the arm's step, the Create observation's clip in
    both precisions: the env's float32 LIDAR, ``policy_controller``'s float64; the SIMROBOT env's
    wheels and rewards), where Gymnasium (and PettingZoo) is installed."""
    import importlib.util

    if importlib.util.find_spec("gymnasium") is None:
        return
    from sim_tools.rl.arm_reach import ArmReachEnv
    from sim_tools.rl.create_nav import CreateNavEnv
    from sim_tools.rl.create_sensors import SENSORS

    for env in (ArmReachEnv(), CreateNavEnv(sensors=SENSORS)):
        env.reset(seed=0)
        env.step(env.action_space.sample())
    if importlib.util.find_spec("pettingzoo") is not None:
        from sim_tools.rl.simrobot_parallel import SimrobotParallelEnv

        agents = SimrobotParallelEnv()
        agents.reset(seed=0)
        agents.step({agent: agents.action_space(agent).sample() for agent in agents.agents})


def warmers() -> dict[str, Callable[[], None]]:
    """Every registered simulator's warm-up by its name, then the bag readers' (``replay``) and the
    learning environments' (``learning``)."""
    from sim_tools.adapters.contract import world_parts

    parts = {name: part.warm_up for name, part in world_parts().items()}
    return {**parts, "replay": warm_replay, "learning": warm_learning}


def warm_one(name: str, warm: Callable[[], None]) -> str:
    """Run one warm-up; a line saying why when it fails ('' when it worked)."""
    try:
        warm()
    except Exception as error:  # a warm-up failure must not fail the install; the world would compile later
        return f"numba warm-up of {name} failed ({type(error).__name__}: {error}); it compiles on first use"
    return ""


def in_order(names: Sequence[str]) -> list[str]:
    """``names`` with those of :data:`ORDER` first, in its order."""
    return sorted(names, key=lambda name: ORDER.index(name) if name in ORDER else len(ORDER))


def warm_in_parallel(names: Sequence[str], jobs: int) -> list[str]:
    """Each warm-up in a process of its own, ``jobs`` at a time: the lines of those that failed."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))  # these modules, from these files

    def run(name: str) -> str:
        command = [sys.executable, "-P", "-m", "sim_tools.warmup", "--only", name]
        try:
            done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=WARMUP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            return f"numba warm-up of {name} failed (no end in {WARMUP_TIMEOUT_S:.0f} s); it compiles on first use"
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
            return f"numba warm-up of {name} failed ({last}); it compiles on first use"
        return done.stdout.strip()

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return [line for line in pool.map(run, in_order(names)) if line]


def export_cache(tree: Path, dest: Path) -> int:
    """Copy numba's cache entries of the packages under ``tree`` into the same places under
    ``dest`` (a build's ``lib`` folder), for the packages ``dest`` has: each index of this numba
    version and of the sources as they are (its stamp), with the data files it names. The number
    of indexes copied."""
    import pickle

    import numba

    from sim_runtime.numba_cache import source_stamp

    copied = 0
    tops = sorted(p.name for p in dest.iterdir() if (p / "__init__.py").is_file())
    for index in sorted(index for top in tops for index in (tree / top).glob("**/__pycache__/*.nbi")):
        package = index.parent.parent.relative_to(tree)
        py_file = index.parent.parent / f"{index.name.split('.', 1)[0]}.py"
        if not (dest / package / "__init__.py").is_file() or not py_file.is_file():
            continue  # not built (a test folder) or not a package
        with index.open("rb") as f:
            if pickle.load(f) != numba.__version__:
                continue
            stamp, overloads = pickle.loads(f.read())
        data = [index.parent / name for name in overloads.values()]
        if stamp != source_stamp(py_file) or not overloads or not all(path.is_file() for path in data):
            continue  # stale: a kernel no warm-up compiled since its sources changed
        target = dest / package / "__pycache__"
        target.mkdir(exist_ok=True)
        for path in [*data, index]:  # the index last: it names files already there
            shutil.copy2(path, target / path.name)
        copied += 1
    return copied


def main(argv: Sequence[str] | None = None) -> int:
    """Warm every simulator's kernels; one line with the time taken."""
    parser = argparse.ArgumentParser(prog="python -m sim_tools.warmup", description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="processes (default: one a core)")
    parser.add_argument("--only", help="one warm-up, in this process (what each job runs)")
    parser.add_argument("--export-to", type=Path, help="then copy the cache entries into this build folder")
    opts = parser.parse_args(argv)
    start = time.monotonic()
    every = warmers()
    if opts.only is not None:
        failure = warm_one(opts.only, every[opts.only])
        print(failure, end="\n" if failure else "")
        return 0
    if opts.jobs > 1:
        failures = warm_in_parallel(list(every), opts.jobs)
    else:
        failures = [line for line in (warm_one(name, every[name]) for name in in_order(list(every))) if line]
    for line in failures:
        print(line)
    print(f"numba kernels compiled and cached in {time.monotonic() - start:.0f} s (worlds now start in seconds)")
    if opts.export_to is not None:
        root = Path(__file__).resolve().parent.parent
        print(f"{export_cache(root, opts.export_to)} kernels' cache entries copied into {opts.export_to}")
    return 0


# ----------------------------------------------------------------------------------- at install
def build_cache(tree: Path, build_lib: Path) -> None:
    """Warm the kernels of the source ``tree`` and copy their cache entries into ``build_lib``
    (``setup.py``'s ``build_py``, under pip or colcon). Never fails the build: without numba (a
    build environment of its own) or on any error it says that the kernels compile at the first
    start instead."""
    if os.environ.get(BUILD_WARMUP_ENV, "1") == "0":
        print(f"{BUILD_WARMUP_ENV}=0: no numba warm-up; the kernels compile at the first start")
        return
    command = [sys.executable, "-P", "-m", "sim_tools.warmup", "--export-to", str(build_lib.resolve())]
    try:
        done = subprocess.run(
            command, cwd=tree, env=warmup_environment(tree), capture_output=True, text=True, timeout=WARMUP_TIMEOUT_S
        )
    except (OSError, subprocess.TimeoutExpired) as error:
        print(f"numba warm-up not done ({error}); the kernels compile at the first start")
        return
    print(done.stdout, end="")
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
        print(f"numba warm-up not done ({last}); the kernels compile at the first start")


def warmup_environment(tree: Path, environ: dict[str, str] | None = None) -> dict[str, str]:
    """The environment the warm-up of a build runs in: this interpreter's own packages (where the
    installed package finds numba), not pip's isolated build environment (pip hides them behind a
    folder ``pip-build-env-*`` on ``PYTHONPATH`` and ``PATH``), with ``tree`` first; numba's
    default cache places (beside the sources), not a ``NUMBA_CACHE_DIR``."""
    env = dict(os.environ if environ is None else environ)
    isolated = False

    def outside_pip(variable: str) -> list[str]:
        nonlocal isolated
        entries = [entry for entry in env.get(variable, "").split(os.pathsep) if entry]
        kept = [entry for entry in entries if "pip-build-env-" not in entry]
        isolated |= len(kept) < len(entries)
        return kept

    env["PYTHONPATH"] = os.pathsep.join([str(tree), *outside_pip("PYTHONPATH")])
    env["PATH"] = os.pathsep.join(outside_pip("PATH"))
    if isolated:
        env.pop("PYTHONNOUSERSITE", None)
    env.pop("NUMBA_CACHE_DIR", None)
    return env


if __name__ == "__main__":
    sys.exit(main())
