"""One episode in the calling process: a fresh rclpy context, the world, its controllers, the
world stepped directly at ``real_time_factor: 0``, the model sampled after every step, metrics.

Nothing here names a simulator: the episode's simulator's ``world`` adapter (its contract, in
:mod:`sim_tools.adapters.contract`) builds the world from the sweep's world entry
(``make_world``), places the controller nodes (``controller_nodes``), samples the model after
every step (``probe``) and computes the metrics (``METRICS``). An episode is set up, run and torn
down by :class:`_EpisodeRun`; each controller kind (a node class, ours or a user's; a user's
``main``; a model function) is one small class of :mod:`sim_tools.batch.forms`
(:func:`~sim_tools.batch.forms.make_controller`).

Isolation: the process sets ``ROS_AUTOMATIC_DISCOVERY_RANGE=OFF`` (:func:`isolate_process`) and
every episode gets its own context on a domain id above the ones people use interactively, so
nothing outside the episode sees its topics and two episodes never share a graph, however many
run side by side. All of an episode's nodes live in this process, where matching still works.

:func:`run_episode` never raises: a failed episode is a :class:`~sim_tools.batch.row.Row` with
``status: error`` and the error.
"""

from __future__ import annotations

import functools
import math
import os
import random
import struct
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from sim_runtime.errors import InputError
from sim_tools.adapters.contract import EpisodeData, world_part
from sim_tools.batch.forms import (
    LEAN_NODE,
    MATCH_TIMEOUT,
    controller_args,
    controller_node,
    is_user_file,
    load_controller,
    make_controller,
)
from sim_tools.batch.metrics import compute
from sim_tools.batch.plan import Episode
from sim_tools.batch.row import ERROR, OK, Result, Row

#: Domain ids of batch episodes start here (people use 0–20 interactively; discovery is off anyway).
DOMAIN_BASE = 100
_T = TypeVar("_T")
#: The world ignores the episode context's command line, which carries the controller's parameters.
WORLD_NODE: dict[str, Any] = {**LEAN_NODE, "use_global_arguments": False}

_domain_id: int | None = None
_logging_keeper: Any = None
#: The episode running in this process (an error row's sim time).
_running: _EpisodeRun | None = None
#: Where the running episode's sim time goes after every step: a worker's page shared with its
#: supervisor, which reads it when it stops the episode at a limit (None: nowhere).
sim_time_page: Any = None


def isolate_process(worker: int | None = None) -> int:
    """Make this process's ROS traffic invisible outside it; returns its domain id.

    Call before the first ``rclpy.init`` of the process (every engine's worker does)."""
    global _domain_id, _logging_keeper
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"
    os.environ.pop("ROS_STATIC_PEERS", None)
    _domain_id = DOMAIN_BASE + (worker if worker is not None else os.getpid()) % 100
    if _logging_keeper is None:
        # rcl logging is set up when the first context starts and torn down when the last one
        # ends: one idle context for the worker's life spares each episode doing both.
        import rclpy
        from rclpy.context import Context

        _logging_keeper = Context()
        rclpy.init(args=[], context=_logging_keeper, domain_id=_domain_id)
    return _domain_id


# ----------------------------------------------------------------------------------- results
def run_episode(ep: Episode) -> Result:
    """Run ``ep``; returns its :class:`~sim_tools.batch.row.Row` and timing whatever happens."""
    global _running
    _running = None
    tell_sim_time(math.nan)
    if _domain_id is None:
        isolate_process()
    timing: dict[str, Any] = {"episode": ep.index, "pid": os.getpid()}
    start = time.perf_counter()
    try:
        data, sim_time, timing_parts = _simulate(ep)
        timing.update(timing_parts)
        collect_start = time.perf_counter()
        metrics = compute(ep.simulator, ep.metrics, data, ep.search_path)
        timing["collect_s"] = time.perf_counter() - collect_start
        row = Row.of(ep, OK)
        row.sim_time_s = round(sim_time, 9)
        row.metrics = metrics
    except Exception as exc:
        message = f"{type(exc).__name__}: {exc}".strip().replace("\n", " ")
        if not isinstance(exc, InputError | ImportError) and not getattr(exc, "located", False):
            message += at_line(exc)
        row = Row.of(ep, ERROR, message)
        reached = sim_time_now()
        if reached is not None:
            row.sim_time_s = round(reached, 9)
    timing["total_s"] = time.perf_counter() - start
    return {"row": row, "timing": timing}


def user_frame(exc: BaseException) -> traceback.FrameSummary | None:
    """The innermost frame of ``exc``'s stack in a user's file (not ours, Python's or an
    installed library's); None when it has none."""
    return _user_of(traceback.extract_tb(exc.__traceback__))


def _user_of(frames: traceback.StackSummary | list[traceback.FrameSummary]) -> traceback.FrameSummary | None:
    return next((frame for frame in reversed(frames) if is_user_file(frame.filename)), None)


def at_line(exc: BaseException) -> str:
    """`` (at student.py:12)``: the student's line, else the innermost line of the stack."""
    frames = traceback.extract_tb(exc.__traceback__)
    frame = _user_of(frames) or (frames[-1] if frames else None)
    return f" (at {Path(frame.filename).name}:{frame.lineno})" if frame is not None else ""


def sim_time_now() -> float | None:
    """The sim time the running (or last) episode of this process got to, None before its world."""
    world = getattr(_running, "world", None)
    return None if world is None else float(world.sim_time)


def tell_sim_time(sim_time: float) -> None:
    """Put ``sim_time`` on :data:`sim_time_page` (NaN: no world yet)."""
    if sim_time_page is not None:
        struct.pack_into("d", sim_time_page, 0, sim_time)


# -------------------------------------------------------------------------------- simulation
def _simulate(ep: Episode) -> tuple[EpisodeData, float, dict[str, Any]]:
    global _running
    t0 = time.perf_counter()
    episode = _EpisodeRun(ep)
    _running = episode
    try:
        episode.set_up()
        t1 = time.perf_counter()
        data = episode.run()
        t2 = time.perf_counter()
        sim_time = episode.world.sim_time
    finally:
        t3 = time.perf_counter()
        episode.tear_down()
    end = time.perf_counter()
    episode.check_recording()
    timing = {"setup_s": t1 - t0, "run_s": t2 - t1, "teardown_s": end - t3, "transport": episode.transport}
    return data, sim_time, timing


class _EpisodeRun:
    """One episode's context, executor and nodes: :meth:`set_up`, :meth:`run`, :meth:`tear_down`."""

    def __init__(self, ep: Episode) -> None:
        from sim_runtime.run import make_executor
        from sim_tools.batch.forms import EpisodeContext

        self.ep = ep
        form, obj = load_controller(ep)
        self.params = {**ep.controller["parameters"], **ep.params}
        seed_globals(ep.seed)
        self.episode_context = EpisodeContext(controller_args(ep, self.params), _domain_id)
        self.context = self.episode_context.context
        self.controller = make_controller(form, ep, obj, self.params, self.context)
        self.executor = make_executor(self.context)
        self.recorder: Any = None
        self.transport = ""
        self.deliver: Callable[[], Any] = lambda: None

    def set_up(self) -> None:
        """The world, the controller's nodes and the recorder, matched; the transport chosen."""
        from sim_runtime.run import drain
        from sim_tools.batch.bus import DirectBus, direct_eligible

        self.world = _make_world(self.ep, self.context, self.params)
        nodes = [self.world, *self.controller.start(self.world)]
        if self.ep.record_bag:
            self.recorder = _make_recorder(self.ep, self.context)
        for node in nodes + ([self.recorder] if self.recorder else []):
            self.executor.add_node(node)
        transport = self.ep.controller["transport"]
        if transport == "auto":
            transport = self.controller.auto_transport()
        if self.recorder is not None or not direct_eligible(nodes):
            transport = "ros"
        self.transport = transport
        bus = DirectBus(nodes)
        _wait_for_matches(self.executor, bus, self.recorder)
        drain(self.executor)  # latched messages (maps, markers) reach late subscribers as in any run
        if transport == "direct":
            bus.attach()
        self.deliver = bus.flush if transport == "direct" else lambda: drain(self.executor)
        if not self.world.ready_to_step():
            # A lockstep world published step 0 before its controllers existed and waits for
            # their answers: publish it again now, as the world itself does after a while.
            self.world.republish()
            self.deliver()
        self.steps = round(self.ep.duration_s * self.world.physics_rate)
        self.probe = world_part(self.ep.simulator).probe(self.world, self.ep.world, self.steps)

    def run(self) -> EpisodeData:
        """Step the world ``duration_s``: the controller's turn, the step, the messages, a sample."""
        world, controller = self.world, self.controller
        for _ in range(self.steps):
            if world.finished:
                break
            controller.before_step(world)
            if self.transport == "ros":
                while not world.ready_to_step() and not world.finished:
                    self.executor.spin_once(timeout_sec=0.01)
                if world.finished:
                    break
            world.step()
            tell_sim_time(world.sim_time)
            self.deliver()
            controller.after_step(self)
            self.probe.sample()
        return self.probe.data(self.ep.params, self.ep.seed)

    def tear_down(self) -> None:
        """Stop the controller, close the bag, destroy every node, shut the context down."""
        self.controller.stop()
        if self.recorder is not None:
            self.recorder.close()
        for node in list(self.executor.get_nodes()):
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()
        self.episode_context.close()

    def check_recording(self) -> None:
        if self.recorder is not None and self.recorder.error is not None:
            raise RuntimeError(f"recording the bag failed: {self.recorder.error}")


def seed_globals(seed: int) -> None:
    """Seed Python's and numpy's global generators for the controller (before it is built)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)


# ------------------------------------------------------------------------------ before a sweep
#: Wall seconds a ``main`` may take to spin its node when probed for its parameters.
PROBE_TIMEOUT = 5.0
#: What :func:`isolate_process` changes in the environment.
_DISCOVERY_KEYS = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS")


def _discovery_off_meanwhile(probe: Callable[[Episode], _T]) -> Callable[[Episode], _T]:
    """``probe`` with discovery off for the contexts it makes, and the caller's environment back
    afterwards: a probe also runs in the caller's own process (a test, the fuzzer, a notebook's
    ``load_sweep``), whose later child processes must still find each other."""

    @functools.wraps(probe)
    def wrapper(ep: Episode) -> _T:
        saved = {key: os.environ.get(key) for key in _DISCOVERY_KEYS}
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"
        os.environ.pop("ROS_STATIC_PEERS", None)
        try:
            return probe(ep)
        finally:
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value

    return wrapper


@_discovery_off_meanwhile
def probe_controller(ep: Episode) -> dict[str, Any] | None:
    """The parameters (name: rclpy type) the controller of ``ep`` declares, from building its
    node once with ``ep``'s parameters in a context of its own, without a world; None when that
    cannot tell (a model function, or a ``main`` that waits for something before it spins).
    Raises what building it raises."""
    from sim_tools.batch.forms import EpisodeContext, MainRunner, NotSpinning, declared

    if _domain_id is None:
        isolate_process()
    form, obj = load_controller(ep)
    if form == "model":
        return None
    if form == "mfile":
        return {}  # an m-file program takes no parameters: those a sweep sets must be the world's
    extra = world_part(ep.simulator).probe_kwargs(obj) if form == "node" else {}
    if extra is None:
        return {}  # the adapter builds it from the world: it declares nothing a sweep sets
    params = {**ep.controller["parameters"], **ep.params}
    seed_globals(ep.seed)
    episode_context = EpisodeContext(controller_args(ep, params), _domain_id)
    runner: MainRunner | None = None
    nodes: list[Any] = []
    try:
        if form == "main":
            runner = MainRunner(obj, ep.controller["target"])
            try:
                nodes = runner.start(PROBE_TIMEOUT)
            except NotSpinning:
                return None
        else:
            nodes = [controller_node(ep, obj, params, episode_context.context, **extra)]
        return declared(nodes)
    finally:
        if runner is not None:
            runner.stop()
        for node in nodes:
            node.destroy_node()
        episode_context.close()


@_discovery_off_meanwhile
def probe_world(ep: Episode) -> set[str]:
    """The names of the parameters the world of ``ep`` declares (built once, never stepped)."""
    import rclpy.logging
    from rclpy.context import Context

    if _domain_id is None:
        isolate_process()
    context = Context()
    rclpy.init(args=[], context=context, domain_id=_domain_id)
    name = world_part(ep.simulator).WORLD_NODE_NAME  # its start-up summary is no news before a sweep
    level = rclpy.logging.get_logger_level(name)
    rclpy.logging.set_logger_level(name, rclpy.logging.LoggingSeverity.WARN)
    try:
        world = _make_world(ep, context, {})
        try:
            return set(world.list_parameters([], 0).names)
        finally:
            world.destroy_node()
    finally:
        rclpy.logging.set_logger_level(name, level)
        rclpy.shutdown(context=context)


def _wait_for_matches(executor: Any, bus: Any, recorder: Any) -> None:
    """Spin until DDS matched every route the bus found (as a ROS run waits for its graph)."""
    from sim_runtime.testing import spin_until

    expected = [(pub, n) for pub, n in bus.expected_matches() if n]
    ok = spin_until(
        executor, lambda: all(pub.get_subscription_count() >= n for pub, n in expected), timeout=MATCH_TIMEOUT
    )
    if not ok:
        missing = [pub.topic_name for pub, n in expected if pub.get_subscription_count() < n]
        raise RuntimeError(f"publishers {missing} never matched their subscribers in {MATCH_TIMEOUT} s")
    if recorder is not None:
        recorder.discover()
        subs = recorder.subscriptions
        spin_until(executor, lambda: all(s.get_publisher_count() > 0 for s in subs), timeout=MATCH_TIMEOUT)


def _make_recorder(ep: Episode, context: Any) -> Any:
    import rclpy.logging
    from rclpy.logging import LoggingSeverity

    from sim_runtime.bag.record import Recorder
    from sim_runtime.bag.writer import BagWriter

    rclpy.logging.set_logger_level("recorder", LoggingSeverity.WARN)
    return Recorder(BagWriter(Path(ep.bag_dir)), clock="sim", context=context)


# ------------------------------------------------------------------------------------ worlds
def _make_world(ep: Episode, context: Any, params: dict[str, Any]) -> Any:
    """The world node, with the sweep's parameters that it declares (the others it ignores) and
    none of the context's command line (that is the controller's)."""
    from rclpy.parameter import Parameter

    overrides = [Parameter(k, value=v) for k, v in params.items()]
    overrides += [Parameter("real_time_factor", value=0.0), Parameter("seed", value=ep.seed)]
    node = WORLD_NODE
    if ep.controller["kind"] == "mfile":
        # the MATLAB bridge asks the world for a parameter when its odometry is late (a stepping
        # thread held up on a busy machine) before it fails the program's call
        node = {**WORLD_NODE, "start_parameter_services": True}
    return world_part(ep.simulator).make_world(ep.world, ep.pose, overrides, context=context, **node)
