"""Many independent Create navigation worlds stepped together, as one Gymnasium vector env.

Each sub-environment is a :class:`~sim_tools.rl.create_nav.CreateNavEnv` (its own map, model and
noise stream). :class:`CreateNavVectorEnv` steps them in batches: ``workers=1`` (the default) steps
every one in this process, one after the other; ``workers=k`` splits them into ``k`` contiguous
batches, one stepped here and the others each in a process of its own, all at once (a machine's
cores working together). Whatever the number of workers, sub-env ``i`` plays exactly as the same
``CreateNavEnv`` alone (test_rl_vector_create): ``reset(seed=s)`` seeds it with ``s + i``, and an
episode that ends is reset on the next step (Gymnasium's ``next_step`` autoreset: that step's
action is ignored, its reward is 0). Infos are Gymnasium's vector infos (``info[key]`` an array
over the sub-envs, ``info["_" + key]`` which have it).
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing
import signal
import time
from collections.abc import Sequence
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from sim_runtime.errors import InputError
from sim_tools.rl.create_nav import CreateNavEnv

#: Seconds a closing worker process gets to finish before it is terminated.
_CLOSE_TIMEOUT_S = 5.0
#: Steps over which several workers measure themselves against one process (after warm-up steps).
CALIBRATION_STEPS = 40
_WARMUP_STEPS = 5


def vector_create_nav(
    num_envs: int, workers: int = 1, max_episode_steps: int | None = None, fallback: bool = True, **env_kwargs: Any
) -> CreateNavVectorEnv:
    """``num_envs`` Create navigation envs built with ``env_kwargs`` (``CreateNavEnv``'s
    arguments: map, config, sensors, start, goal, …), stepped together by ``workers`` processes
    (this one included). ``gymnasium.make_vec("robot_sims/CreateNav-v0", num_envs=…)`` calls it,
    with the registered ``max_episode_steps``: each sub-env's ``max_steps`` (give one of the two)."""
    if max_episode_steps is not None:
        if "max_steps" in env_kwargs:
            raise InputError("max_steps and max_episode_steps: the same limit, give one")
        env_kwargs["max_steps"] = max_episode_steps
    return CreateNavVectorEnv(num_envs, workers=workers, fallback=fallback, **env_kwargs)


def _stack_infos(infos: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per-env info dicts → Gymnasium's vector infos (an array per key, ``_key`` who has it)."""
    keys = infos[0].keys()
    if all(info.keys() == keys for info in infos):  # the usual case, and the cheap one
        everyone = np.ones(len(infos), dtype=bool)
        stacked = {key: np.array([info[key] for info in infos]) for key in keys}
        return stacked | {"_" + key: everyone.copy() for key in keys}
    out: dict[str, Any] = {}
    for key in dict.fromkeys(k for info in infos for k in info):
        present = np.array([key in info for info in infos])
        values = [info[key] for info in infos if key in info]
        if present.all():
            out[key] = np.array(values)
        else:
            first = np.asarray(values[0])
            out[key] = np.zeros((len(infos), *first.shape), dtype=first.dtype)
            out[key][present] = values
        out["_" + key] = present
    return out


def _join_infos(parts: Sequence[dict[str, Any]], sizes: Sequence[int]) -> dict[str, Any]:
    """Batches' vector infos → one over every sub-env (a key a batch lacks: masked off there)."""
    if len(parts) == 1:
        return dict(parts[0])
    out: dict[str, Any] = {}
    for key in dict.fromkeys(k for part in parts for k in part if not k.startswith("_")):
        like = next(np.asarray(part[key]) for part in parts if key in part)
        out[key] = np.concatenate(
            [
                part[key] if key in part else np.zeros((n, *like.shape[1:]), like.dtype)
                for part, n in zip(parts, sizes, strict=True)
            ]
        )
        out["_" + key] = np.concatenate(
            [part["_" + key] if key in part else np.zeros(n, bool) for part, n in zip(parts, sizes, strict=True)]
        )
    return out


class _Batch:
    """Consecutive sub-envs stepped one after the other, with next-step autoreset."""

    def __init__(self, count: int, env_kwargs: dict[str, Any]) -> None:
        self.envs = [CreateNavEnv(**env_kwargs) for _ in range(count)]
        self.size: tuple[int, ...] = self.envs[0].observation_space.shape or ()
        self.ended = [False] * count

    def reset(self, seeds: Sequence[int | None], options: dict[str, Any] | None):
        results = [env.reset(seed=seed, options=options) for env, seed in zip(self.envs, seeds, strict=True)]
        self.ended = [False] * len(self.envs)
        return np.stack([obs for obs, _ in results]), _stack_infos([info for _, info in results])

    def step(self, actions: np.ndarray):
        n = len(self.envs)
        obs = np.empty((n, *self.size), dtype=np.float32)
        rewards = np.zeros(n)
        terms = np.zeros(n, dtype=bool)
        truncs = np.zeros(n, dtype=bool)
        infos = []
        for i, env in enumerate(self.envs):
            if self.ended[i]:  # next-step autoreset: this step's action is ignored
                obs[i], info = env.reset()
            else:
                obs[i], rewards[i], terms[i], truncs[i], info = env.step(actions[i])
            self.ended[i] = bool(terms[i] or truncs[i])
            infos.append(info)
        return obs, rewards, terms, truncs, _stack_infos(infos)

    def call(self, name: str, args: tuple, kwargs: dict[str, Any]) -> list[Any]:
        return [getattr(env, name)(*args, **kwargs) for env in self.envs]

    def take(self) -> tuple[list[CreateNavEnv], list[bool]]:
        """This batch's envs as they are (to go on in another process) and which have ended."""
        return self.envs, self.ended

    def adopt(self, envs: list[CreateNavEnv], ended: list[bool]) -> None:
        """Step ``envs`` (another batch's, taken) after this batch's own."""
        self.envs += envs
        self.ended += ended


def worker_signals() -> None:
    """Signals in a worker process forked to step envs: Ctrl-C ignored (the caller handles it and
    closes its workers), SIGTERM back to its default, ending the process. A forked worker inherits
    its parent's handlers, and rclpy's (or an executable's stop flag) only take note of SIGTERM: a
    worker stuck in a step would outlive ``terminate()``, and whoever joins it would wait forever."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _serve(conn: Connection, count: int, env_kwargs: dict[str, Any]) -> None:
    """A worker process: its batch's commands from the pipe until ``close`` (or the pipe closes)."""
    worker_signals()
    batch = _Batch(count, env_kwargs)
    while True:
        try:
            command, args = conn.recv()
        except EOFError:
            return
        if command == "close":
            return
        try:
            reply: tuple[str, Any] = ("ok", getattr(batch, command)(*args))
        except Exception as exc:  # the caller's process raises it (Gymnasium's AsyncVectorEnv does the same)
            reply = ("error", exc)
        try:
            conn.send(reply)
        except Exception as exc:  # an exception that does not pickle: its text then
            conn.send(("error", RuntimeError(repr(exc))))


def _send(pipe: Connection, message: tuple) -> bool:
    """Whether ``message`` reached the worker (False: its process is gone)."""
    try:
        pipe.send(message)
    except OSError:
        return False
    return True


def _receive(pipe: Connection) -> tuple[str, Any]:
    """The worker's reply: ("ok", value), ("error", exception) or ("gone", None)."""
    try:
        return pipe.recv()
    except (EOFError, OSError):
        return "gone", None


class CreateNavVectorEnv(VectorEnv):
    """``num_envs`` :class:`CreateNavEnv` stepped together by ``workers`` processes (see the
    module's docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": ["rgb_array"]}  # noqa: RUF012

    def __init__(self, num_envs: int, *, workers: int = 1, fallback: bool = True, **env_kwargs: Any) -> None:
        for name, value in (("num_envs", num_envs), ("workers", workers)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InputError(f"{name}: expected an integer >= 1, got {value!r}")
        self.num_envs = num_envs
        self.workers = min(workers, num_envs)
        sizes = [num_envs // self.workers + (k < num_envs % self.workers) for k in range(self.workers)]
        self._sizes = sizes
        self._local = _Batch(sizes[0], env_kwargs)  # bad arguments raise here, before any process starts
        self._local_s = 0.0  # wall time of this process's batch in the last exchange
        first = self._local.envs[0]
        self.render_mode = first.render_mode
        self.single_observation_space, self.single_action_space = first.observation_space, first.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._pipes: list[Connection] = []
        self._processes: list[Any] = []
        #: Whether several workers go on measuring themselves (see :meth:`_measure`).
        self.fallback = bool(fallback) and self.workers > 1
        self._timing = [0, 0.0, 0.0]  # steps measured, wall s of the steps, of this process's batch
        #: Why the workers were given up for this process (None: they were not).
        self.fell_back: str | None = None
        # fork: a script without an ``if __name__ == "__main__":`` guard works (spawn would run it
        # again in every worker), and a worker starts at once, its kernels already loaded
        context: Any = multiprocessing.get_context(
            "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
        )
        for count in sizes[1:]:
            mine, theirs = context.Pipe()
            process = context.Process(target=_serve, args=(theirs, count, env_kwargs), daemon=True)
            process.start()
            theirs.close()
            self._pipes.append(mine)
            self._processes.append(process)

    @property
    def envs(self) -> list[CreateNavEnv]:
        """The sub-envs stepped in this process (all of them with ``workers=1``)."""
        return self._local.envs

    def _all(self, command: str, local_args: tuple, remote_args: Sequence[tuple]) -> list[Any]:
        """Every batch's ``command``: the workers' sent first, so they run while this one does."""
        if self.closed:
            raise RuntimeError("CreateNavVectorEnv: used after close()")
        try:
            return self._exchange(command, local_args, remote_args)
        except (KeyboardInterrupt, SystemExit):
            self.close()  # interrupted mid-exchange: the workers' replies would come out of step
            raise

    def _exchange(self, command: str, local_args: tuple, remote_args: Sequence[tuple]) -> list[Any]:
        sent = [_send(pipe, (command, args)) for pipe, args in zip(self._pipes, remote_args, strict=True)]
        results: list[Any] = []
        errors: list[Any] = []
        start = time.perf_counter()
        try:
            results.append(getattr(self._local, command)(*local_args))
        except Exception as exc:
            errors.append(exc)
        self._local_s = time.perf_counter() - start
        for k, (pipe, delivered) in enumerate(zip(self._pipes, sent, strict=True), start=1):
            status, value = _receive(pipe) if delivered else ("gone", None)
            if status == "gone":
                value = RuntimeError(f"CreateNavVectorEnv: worker process {k} has died")
            (results if status == "ok" else errors).append(value)
        if errors:
            raise errors[0]
        return results

    def _split(self, values: Sequence[Any] | np.ndarray) -> list[Any]:
        bounds = np.cumsum([0, *self._sizes]).tolist()
        return [values[lo:hi] for lo, hi in itertools.pairwise(bounds)]

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None):
        """New episodes in every sub-env: ``seed`` an int (sub-env ``i`` gets ``seed + i``), a list
        of one seed per sub-env, or None; ``options`` go to every sub-env."""
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise InputError(f"seed: {len(seeds)} seeds for {self.num_envs} envs")
        parts = [(part, options) for part in self._split(seeds)]
        results = self._all("reset", parts[0], parts[1:])
        return np.concatenate([obs for obs, _ in results]), _join_infos([info for _, info in results], self._sizes)

    def step(self, actions: np.ndarray):
        """One step of every sub-env (``actions``: one row per sub-env); an ended one is reset."""
        actions = np.asarray(actions)
        if actions.shape[:1] != (self.num_envs,):
            raise InputError(f"actions: expected {self.num_envs} rows, got shape {actions.shape}")
        parts = [(part,) for part in self._split(actions)]
        start, sizes = time.perf_counter(), self._sizes
        results = self._all("step", parts[0], parts[1:])
        if self.fallback:
            self._measure(time.perf_counter() - start)  # may bring every env here: the next step's
        obs, rewards, terms, truncs = (np.concatenate([r[k] for r in results]) for k in range(4))
        return obs, rewards, terms, truncs, _join_infos([r[4] for r in results], sizes)

    def _measure(self, wall_s: float) -> None:
        """Several workers against one process, measured over every 40 steps (after 5 warm-up
        steps) while they run: this process's batch
        stepped in ``_local_s`` of the step's ``wall_s``; one process would step them all in about
        ``_local_s × num_envs / batch size``. Slower with workers (on a loaded or small machine,
        or with cheap env steps, the pickling costs more than the parallel stepping gains): their
        envs come here, as they are, and the workers end; the episodes go on exactly as before."""
        n, wall, local = self._timing
        if n >= _WARMUP_STEPS:
            wall += wall_s
            local += self._local_s
        n += 1
        self._timing = [n, wall, local]
        if n < _WARMUP_STEPS + CALIBRATION_STEPS:
            return
        one_process = local * self.num_envs / self._sizes[0]
        if wall > one_process:
            self.fallback = False
            self.fell_back = (
                f"{self.workers} workers took {wall:.3f} s for {CALIBRATION_STEPS} steps, one process about "
                f"{one_process:.3f} s: all {self.num_envs} envs now step in this process"
            )
            self._come_home()
        else:  # faster for now: measured again over the next steps (the machine's load changes)
            self._timing = [_WARMUP_STEPS, 0.0, 0.0]

    def _come_home(self) -> None:
        """Every worker's envs taken into this process; the workers closed."""
        for pipe in self._pipes:
            if not _send(pipe, ("take", ())):
                raise RuntimeError("CreateNavVectorEnv: a worker process has died")
            status, value = _receive(pipe)
            if status != "ok":
                raise value if status == "error" else RuntimeError("CreateNavVectorEnv: a worker process has died")
            self._local.adopt(*value)
        self._end_workers()
        self.workers, self._sizes = 1, [self.num_envs]

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Every sub-env's method ``name`` called with these arguments, their results in order."""
        results = self._all("call", (name, args, kwargs), [(name, args, kwargs)] * len(self._pipes))
        return tuple(value for part in results for value in part)

    def render(self) -> tuple[Any, ...] | None:
        """Every sub-env's frame (``render_mode="rgb_array"``), else None."""
        return self.call("render") if self.render_mode == "rgb_array" else None

    def __del__(self) -> None:
        if hasattr(self, "_pipes") and not self.closed:
            self.close()

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the worker processes (terminated if one does not finish in time) and the sub-envs."""
        self._end_workers()
        for env in self._local.envs:
            env.close()

    def _end_workers(self) -> None:
        for pipe in self._pipes:
            with contextlib.suppress(OSError):  # already gone
                pipe.send(("close", ()))
        for process in self._processes:
            process.join(_CLOSE_TIMEOUT_S)
            if process.is_alive():
                process.terminate()
                process.join()
        for pipe in self._pipes:
            pipe.close()
        self._pipes, self._processes = [], []
