"""Where episodes run: persistent local worker processes (default), or Ray (local or a cluster).

Each worker process runs episodes one after another (:func:`sim_runtime.batch.episode.run_episode`:
a fresh rclpy context per episode), so start-up (imports, numba's cache) is paid once per worker,
not per episode. Results come back as plain dicts in whatever order episodes finish; the table
orders them.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Callable, Sequence
from typing import Any

from sim_runtime.batch.sweep import Episode

OnResult = Callable[[dict[str, Any]], None]

#: Ray's object store for a local run: results are a few kB each, Ray's default is 30 % of RAM.
RAY_OBJECT_STORE_BYTES = 100 * 1024 * 1024


def _init_local_worker() -> None:
    from sim_runtime.batch.episode import isolate_process

    isolate_process()


def _run(ep: Episode) -> dict[str, Any]:
    from sim_runtime.batch.episode import run_episode

    return run_episode(ep)


def run_local(episodes: Sequence[Episode], workers: int, on_result: OnResult) -> None:
    """Run ``episodes`` on ``workers`` processes (1: in this process), calling ``on_result`` as
    each finishes."""
    if not episodes:
        return
    if workers <= 1:
        from sim_runtime.batch.episode import isolate_process

        isolate_process(0)
        for ep in episodes:
            on_result(_run(ep))
        return
    # spawn, not fork: rclpy and DDS threads do not survive a fork.
    context = multiprocessing.get_context("spawn")
    with context.Pool(min(workers, len(episodes)), initializer=_init_local_worker) as pool:
        for result in pool.imap_unordered(_run, episodes, chunksize=1):
            on_result(result)


def run_ray(episodes: Sequence[Episode], address: str | None, workers: int | None, on_result: OnResult) -> None:
    """Run ``episodes`` as Ray tasks: on a local Ray started here (``address`` None, ``workers``
    CPUs, default all) or on the cluster at ``address`` (``ray start --head`` prints it). Ray's
    workers are reused from task to task, like the local engine's."""
    if not episodes:
        return
    # Ray 2.60 turns token authentication on for new local clusters and writes ~/.ray/auth_token;
    # a cluster this process starts for itself needs none.
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    try:
        import ray
    except ImportError:
        from sim_runtime.errors import InputError

        raise InputError("--ray needs Ray: pip install 'robot_sims[ray]' (or pip install ray)") from None
    started_here = not ray.is_initialized()
    if started_here:
        # Workers import robot_sims (and the sweep's own modules) from their node's Python: install
        # it on every node, with the sweep's folder on a path every node sees.
        if address:
            ray.init(address=address, log_to_driver=False, logging_level=logging.WARNING)
        else:
            ray.init(
                num_cpus=workers or os.cpu_count(),
                object_store_memory=RAY_OBJECT_STORE_BYTES,
                include_dashboard=False,
                log_to_driver=False,
                logging_level=logging.WARNING,
            )
    try:
        remote = ray.remote(max_calls=0, num_cpus=1)(_run)  # max_calls=0: a worker runs any number of tasks
        in_flight_limit = 2 * max(1, int(ray.cluster_resources().get("CPU", 1)))
        queue = list(episodes)
        queue.reverse()
        pending: list[Any] = []
        while queue or pending:
            while queue and len(pending) < in_flight_limit:
                pending.append(remote.remote(queue.pop()))
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                on_result(ray.get(ref))
    finally:
        if started_here:
            ray.shutdown()
