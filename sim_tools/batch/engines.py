"""Where episodes run: local worker processes (default), or Ray (local or a cluster).

Either way every episode runs in a worker process of :mod:`.supervisor`, never in the process that
writes the table, so whatever a controller does (raise, ``sys.exit``, ``os._exit``, segfault, loop
forever, allocate without end) ends as that episode's error row and the sweep goes on. A worker
runs episodes one after another (start-up is paid once per worker) and is replaced when one kills
it. Each episode's output goes to ``logs/<episode key>.log`` in the sweep's folder; an error row
names that file. Results (:class:`~sim_tools.batch.row.Result`) come back in whatever order
episodes finish; the table orders them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import shutil
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sim_runtime.processes import pid_alive
from sim_tools.batch.row import OK, Result
from sim_tools.batch.supervisor import START_TIMEOUT_S, Limits, OnResult, Supervisor, error_result
from sim_tools.batch.sweep import Episode

#: Ray's object store for a local run: results are a few kB each, Ray's default is 30 % of RAM.
RAY_OBJECT_STORE_BYTES = 100 * 1024 * 1024
#: The episodes' logs, in the sweep's output folder.
LOG_FOLDER = "logs"
#: An episode's log sent back from a Ray node is cut to its last this many bytes.
RAY_LOG_BYTES = 1 << 20
#: Wall seconds to wait, after Ray's shutdown, for its workers to end and their scratch to go.
SCRATCH_WAIT_S = 15.0
#: Fields of an episode's world that are file paths (a Ray node may have them elsewhere).
WORLD_PATH_KEYS = ("map", "config", "world_file", "robot_config")


def log_file(folder: Path, ep: Episode, suffix: str = "") -> Path:
    """Where the output of episode ``ep`` goes."""
    return folder / LOG_FOLDER / f"{ep.key}{suffix}.log"


def _name_log(result: Result) -> Result:
    """An error row says where the episode's output is (relative to the sweep's folder)."""
    row = result["row"]
    if row.status != OK:
        row.error = f"{row.error} [log: {LOG_FOLDER}/{row.key}.log]"
    return result


def run_local(
    episodes: Sequence[Episode],
    workers: int,
    on_result: OnResult,
    limits: Limits,
    folder: Path,
    log_suffix: str = "",
) -> None:
    """Run ``episodes`` on up to ``workers`` worker processes, calling ``on_result`` as each
    finishes; logs go to ``folder/logs/`` (``log_suffix`` before ``.log``)."""
    if not episodes:
        return
    with Supervisor(min(workers, len(episodes)), folder / LOG_FOLDER / "workers.log") as supervisor:
        supervisor.run(
            episodes,
            lambda result: on_result(_name_log(result)),
            limits,
            lambda ep: log_file(folder, ep, log_suffix),
        )


# ------------------------------------------------------------------------------------------ Ray
def run_ray(
    episodes: Sequence[Episode],
    address: str | None,
    workers: int | None,
    on_result: OnResult,
    limits: Limits,
    folder: Path,
) -> None:
    """Run ``episodes`` as Ray tasks: on a local Ray started here (``address`` None, ``workers``
    CPUs, default all) or on the cluster at ``address`` (``ray start --head`` prints it). Ray's
    workers are reused from task to task; each runs its episodes in a worker process of its own.
    On a cluster the sweep's folder (students' modules, maps) is shipped to every node."""
    if not episodes:
        return
    ray = _import_ray()
    started_here = not ray.is_initialized()
    # Ray ships a folder only for a whole job (ray.init), not per task: a Ray started elsewhere
    # (the caller's own ray.init) keeps its own runtime_env.
    ship = (episodes[0].search_path, _config_root()) if address and started_here else None
    before = set(_scratch_root().glob("*"))
    if started_here:
        _init_ray(ray, address, workers, _runtime_env(episodes[0], folder) if ship else None)
    try:
        # max_calls 0: a worker runs any number of tasks; max_retries 0: a lost episode is a row, not a rerun
        remote = ray.remote(max_calls=0, num_cpus=1, max_retries=0)(_ray_episode)
        in_flight_limit = 2 * max(1, int(ray.cluster_resources().get("CPU", 1)))
        _drive_ray(ray, remote, list(episodes), in_flight_limit, ship, on_result, limits, folder)
    finally:
        if started_here:
            ray.shutdown()
            # Ray ends its workers without their exit handlers: their scratch folders (on this
            # machine) go once they are gone, after Ctrl-C too
            _remove_scratch(set(_scratch_root().glob("*")) - before, SCRATCH_WAIT_S)


def _import_ray() -> Any:
    # Ray 2.60 turns token authentication on for new local clusters and writes ~/.ray/auth_token;
    # a cluster this process starts for itself needs none.
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    # Ray's driver swaps Python's crash handler (faulthandler) for its own, which writes to Ray's
    # session log, closed at ray.shutdown: a later crash of the caller's process printed nothing.
    os.environ.setdefault("RAY_DISABLE_FAILURE_SIGNAL_HANDLER", "1")
    try:
        import ray
    except ImportError:
        from sim_runtime.errors import InputError

        raise InputError("--ray needs Ray: pip install 'robot_sims[ray]' (or pip install ray)") from None
    return ray


def _init_ray(ray: Any, address: str | None, workers: int | None, runtime_env: dict[str, Any] | None) -> None:
    if address:
        ray.init(address=address, runtime_env=runtime_env, log_to_driver=False, logging_level=logging.WARNING)
    else:
        ray.init(
            num_cpus=workers or os.cpu_count(),
            object_store_memory=RAY_OBJECT_STORE_BYTES,
            include_dashboard=False,
            log_to_driver=False,
            logging_level=logging.WARNING,
        )


def _config_root() -> str:
    from sim_runtime.paths import config_dir

    return str(config_dir().resolve())


def _runtime_env(ep: Episode, folder: Path) -> dict[str, Any]:
    """Ship the sweep's folder to every node (Ray's ``working_dir``), without the sweep's output."""
    root = Path(ep.search_path)
    excludes = [".git", "__pycache__", "*.mcap"]
    if folder.resolve().is_relative_to(root):
        excludes.append(f"/{folder.resolve().relative_to(root).as_posix()}/")
    return {"working_dir": str(root), "excludes": excludes}


def _drive_ray(
    ray: Any,
    remote: Any,
    queue: list[Episode],
    in_flight_limit: int,
    ship: tuple[str, str] | None,
    on_result: OnResult,
    limits: Limits,
    folder: Path,
) -> None:
    """Keep up to ``in_flight_limit`` tasks in flight; a task that does not answer in twice the time
    limit (plus a worker's start-up) is cancelled, its worker killed: a backstop, as the worker's
    own supervisor stops an episode at the time limit."""
    queue = queue[::-1]
    pending: dict[Any, tuple[Episode, float]] = {}
    patience = 2 * limits.time_limit_s + START_TIMEOUT_S
    while queue or pending:
        while queue and len(pending) < in_flight_limit:
            ep = queue.pop()
            pending[remote.remote(ep, limits, ship)] = (ep, time.monotonic() + patience)
        wake = min(deadline for _, deadline in pending.values())
        done, _ = ray.wait(list(pending), num_returns=1, timeout=max(0.0, wake - time.monotonic()))
        for ref in done:
            ep, _ = pending.pop(ref)
            on_result(_name_log(_ray_result(ray, ref, ep, folder)))
        for ref, (ep, deadline) in list(pending.items()):
            if time.monotonic() > deadline:
                ray.cancel(ref, force=True)
                del pending[ref]
                error = f"time limit {limits.time_limit_s:.1f} s: its Ray task did not answer and was cancelled"
                on_result(_name_log(error_result(ep, error, -1, patience)))


def _ray_result(ray: Any, ref: Any, ep: Episode, folder: Path) -> Result:
    """A finished task's result (its log written to ``folder``), or its Ray error as an error row."""
    from ray.exceptions import RayError

    try:
        result: Result = ray.get(ref)
    except RayError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        return error_result(ep, f"{type(exc).__name__}: {first}", -1, 0.0)
    path = log_file(folder, ep)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(result.pop("log", b""))
    return result


_ray_supervisor: Supervisor | None = None


def _ray_episode(ep: Episode, limits: Limits, ship: tuple[str, str] | None) -> Result:
    """A Ray task: run ``ep`` in this Ray worker's own worker process (kept between tasks);
    returns its result with its log's bytes."""
    global _ray_supervisor
    key = ep.key
    if ship is not None:
        ep = _localize(ep, *ship)
    if _ray_supervisor is None:
        _ray_supervisor = Supervisor(1, _ray_scratch() / "worker.log")
    here = _ray_supervisor.output.parent
    results: list[Result] = []
    log = here / "episode.log"
    _ray_supervisor.run([ep], results.append, limits, lambda _: log)
    result = results[0]
    result["row"].key = key  # the driver's key: the paths in this node's copy differ
    with log.open("rb") as f:
        f.seek(max(0, log.stat().st_size - RAY_LOG_BYTES))
        result["log"] = f.read()
    log.unlink()
    return result


def _scratch_root() -> Path:
    """Where Ray workers on this machine keep their episodes' output (a folder per worker pid)."""
    return Path(tempfile.gettempdir()) / f"robot_sims_batch_{os.getuid()}"


def _ray_scratch() -> Path:
    """This Ray worker's folder for its episodes' output; those of Ray workers now gone (Ray ends
    them without running their exit handlers) are removed."""
    root = _scratch_root()
    _remove_scratch(set(root.glob("*")), 0.0)
    here = root / str(os.getpid())
    here.mkdir(parents=True, exist_ok=True)
    return here


def _remove_scratch(folders: set[Path], wait_s: float) -> None:
    """Remove each of ``folders`` whose Ray worker (its name, a pid) is gone, waiting up to
    ``wait_s`` for them to go; the root too once empty."""
    deadline = time.monotonic() + wait_s
    left = {f for f in folders if f.name.isdigit()}
    while left:
        for folder in [f for f in left if not pid_alive(int(f.name))]:
            shutil.rmtree(folder, ignore_errors=True)
            left.discard(folder)
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    with contextlib.suppress(OSError):
        _scratch_root().rmdir()  # only when empty


def _localize(ep: Episode, sweep_dir: str, config_root: str) -> Episode:
    """``ep`` with the driver's paths moved to this node: the sweep's folder to Ray's copy of it
    (the task's working directory), the shipped ``config/`` to this node's install."""
    here = os.getcwd()
    mine = _config_root()

    def move(path: Any) -> Any:
        for old, new in ((sweep_dir, here), (config_root, mine)):
            if isinstance(path, str) and path.startswith(old + os.sep):
                return new + path[len(old) :]
        return path

    world = {k: move(v) if k in WORLD_PATH_KEYS else v for k, v in ep.world.items()}
    return dataclasses.replace(ep, world=world, search_path=here)
