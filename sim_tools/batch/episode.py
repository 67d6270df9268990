"""One episode in the calling process: a fresh rclpy context, the world, its controllers, the
world stepped directly at ``real_time_factor: 0``, the model sampled after every step, metrics.

Isolation: the process sets ``ROS_AUTOMATIC_DISCOVERY_RANGE=OFF`` (:func:`isolate_process`) and
every episode gets its own context on a domain id above the ones people use interactively, so
nothing outside the episode sees its topics and two episodes never share a graph, however many
run side by side. All of an episode's nodes live in this process, where matching still works.

:func:`run_episode` never raises: a failed episode is a row with ``status: error`` and the error.
"""

from __future__ import annotations

import functools
import os
import random
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from sim_runtime.errors import InputError
from sim_tools.batch.metrics import EpisodeData, compute, load_callable
from sim_tools.batch.sweep import Episode

#: Domain ids of batch episodes start here (people use 0–20 interactively; discovery is off anyway).
DOMAIN_BASE = 100
_T = TypeVar("_T")
#: Wall seconds to wait for an episode's publishers and subscriptions to match.
MATCH_TIMEOUT = 10.0

#: Our nodes in an episode go without what nobody can reach there (parameter services, /rosout):
#: leaving them out halved the set-up plus tear-down (median 0.22 -> 0.10 s, measured alternating).
LEAN_NODE: dict[str, Any] = {"start_parameter_services": False, "enable_rosout": False}
#: The world ignores the episode context's command line, which carries the controller's parameters.
WORLD_NODE: dict[str, Any] = {**LEAN_NODE, "use_global_arguments": False}

_domain_id: int | None = None
_logging_keeper: Any = None


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
def base_row(ep: Episode) -> dict[str, Any]:
    """The columns that say which episode a row is."""
    row: dict[str, Any] = {
        "episode": ep.index,
        "key": ep.key,
        "world": ep.world["label"],
        "controller": ep.controller["label"],
    }
    row.update({f"param.{k}": v for k, v in ep.params.items()})
    if ep.pose is not None:
        row.update(pose_x=ep.pose[0], pose_y=ep.pose[1], pose_theta=ep.pose[2])
    row["seed"] = ep.seed
    return row


def run_episode(ep: Episode) -> dict[str, Any]:
    """Run ``ep``; returns ``{"row": table row, "timing": {...}}`` whatever happens."""
    if _domain_id is None:
        isolate_process()
    timing: dict[str, Any] = {"episode": ep.index, "pid": os.getpid()}
    row = base_row(ep)
    start = time.perf_counter()
    try:
        data, sim_time, timing_parts = _simulate(ep)
        timing.update(timing_parts)
        collect_start = time.perf_counter()
        metrics = compute(ep.simulator, ep.metrics, data, ep.search_path)
        timing["collect_s"] = time.perf_counter() - collect_start
        row.update(status="ok", error="", sim_time_s=round(sim_time, 9))
        row.update(metrics)
    except Exception as exc:
        message = f"{type(exc).__name__}: {exc}".strip().replace("\n", " ")
        if not isinstance(exc, InputError | ImportError):
            where = traceback.extract_tb(exc.__traceback__)[-1]
            message += f" (at {Path(where.filename).name}:{where.lineno})"
        row.update(status="error", error=message)
    timing["total_s"] = time.perf_counter() - start
    return {"row": row, "timing": timing}


# -------------------------------------------------------------------------------- simulation
def _simulate(ep: Episode) -> tuple[EpisodeData, float, dict[str, float]]:
    from sim_runtime.run import drain, make_executor
    from sim_tools.batch.bus import DirectBus, direct_eligible
    from sim_tools.batch.forms import EpisodeContext, MainRunner

    t0 = time.perf_counter()
    controller = ep.controller
    target = controller["target"]
    obj = load_callable(target, ep.search_path)
    form = controller_form(ep, obj)
    params = {**controller["parameters"], **ep.params}
    seed_globals(ep.seed)
    episode_context = EpisodeContext(controller_args(ep, params), _domain_id)
    context = episode_context.context
    executor = make_executor(context)
    nodes: list[Any] = []
    user_main: MainRunner | None = None
    recorder = None
    try:
        world = _make_world(ep, context, params)
        nodes.append(world)
        control_step: Callable[[Any, float], None] | None = None
        if form == "main":
            user_main = MainRunner(obj, target)
            nodes += user_main.start(MATCH_TIMEOUT)
        elif form == "node":
            nodes += _make_controller_nodes(ep, obj, world, params, context)
        else:
            control_step = obj(world.model, dict(params), ep.seed)
            if not callable(control_step):
                raise InputError(f"controller {target}: must return a per-step callable control(model, t)")
        if ep.record_bag:
            recorder = _make_recorder(ep, context)
        for node in nodes + ([recorder] if recorder else []):
            executor.add_node(node)

        transport = controller["transport"]
        if transport == "auto":
            transport = "direct" if controller["kind"] == "ours" or (user_main is None and not nodes[1:]) else "ros"
        if recorder is not None or not direct_eligible(nodes):
            transport = "ros"
        bus = DirectBus(nodes)
        _wait_for_matches(executor, bus, recorder)
        drain(executor)  # latched messages (maps, markers) reach late subscribers as in any run
        if transport == "direct":
            bus.attach()
        deliver: Callable[[], Any] = bus.flush if transport == "direct" else lambda: drain(executor)
        if not world.ready_to_step() and hasattr(world, "_publish_step"):
            # A lockstep SIMROBOT world published step 0 before its controllers existed and
            # waits for their answers: publish it again now, as the world itself does after
            # half a second of waiting (its re-publication).
            world._publish_step()
            deliver()
        probe = _make_probe(ep, world)
        steps = round(ep.duration_s * world.physics_rate)
        t1 = time.perf_counter()
        for _ in range(steps):
            if world.finished:
                break
            if control_step is not None:
                control_step(world.model, world.sim_time)
            if transport == "ros":
                while not world.ready_to_step() and not world.finished:
                    executor.spin_once(timeout_sec=0.01)
                if world.finished:
                    break
            world.step()
            deliver()
            if user_main is not None and user_main.after_step(world.sim_time):
                for node in user_main.new_nodes():  # main spun another node in its turn
                    executor.add_node(node)
                deliver()  # what main published in its turn
            probe.sample()
        t2 = time.perf_counter()
        data = probe.data(ep)
        sim_time = world.sim_time
    finally:
        t3 = time.perf_counter()
        if user_main is not None:
            user_main.stop()  # before shutdown: its thread may still destroy its nodes
        if recorder is not None:
            recorder.close()
        for node in list(executor.get_nodes()):
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        episode_context.close()
    end = time.perf_counter()
    if recorder is not None and recorder.error is not None:
        raise RuntimeError(f"recording the bag failed: {recorder.error}")
    return data, sim_time, {"setup_s": t1 - t0, "run_s": t2 - t1, "teardown_s": end - t3, "transport": transport}


def controller_form(ep: Episode, obj: Any) -> str:
    """``node``, ``main`` or ``model`` (:func:`sim_tools.batch.forms.classify`); ours are nodes."""
    from sim_tools.batch.forms import classify, node_kwargs

    form = "node" if ep.controller["kind"] == "ours" else classify(obj, ep.controller["target"])
    if form == "node" and ep.simulator == "simrobot" and "namespace" not in node_kwargs(obj, {"namespace": ""}):
        raise InputError(
            f"{ep.controller['target']}: a SIMROBOT controller class runs once per robot, each in its "
            "robot's namespace: give its __init__ **kwargs and pass them to super().__init__"
        )
    return form


def controller_parameters(ep: Episode, params: dict[str, Any]) -> dict[str, Any]:
    """What every controller node of ``ep`` gets: sim time, the episode's seed, the sweep's values.

    Our controllers read the messages' stamps, never a clock, and run on sim time only if they
    have timers (:func:`_controller_node`): the world's ``/clock`` delivered to a node every step
    made a bump-and-turn episode's run 37 % longer on the direct bus (median 0.244 -> 0.334 s per
    20 s episode, alternating, 8 each)."""
    sim_time = {} if ep.controller["kind"] == "ours" else {"use_sim_time": True}
    return {**sim_time, "seed": ep.seed, **params}


def controller_args(ep: Episode, params: dict[str, Any]) -> list[str]:
    """The episode context's command line: the controller parameters for every node that reads
    them from there (a class without ``**kwargs``, the nodes of a ``main``); ours take them as
    ``parameter_overrides``."""
    from sim_tools.batch.forms import ros_args

    return ros_args(controller_parameters(ep, params) if ep.controller["kind"] == "user" else {})


def seed_globals(seed: int) -> None:
    """Seed Python's and numpy's global generators for the controller (before it is built)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)


# ------------------------------------------------------------------------------ before a sweep
#: The world nodes' names (their loggers').
WORLD_NAMES = {"create": "create_world", "simrobot": "simrobot_world", "arm": "arm"}
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
    from sim_tools.batch.arm_targets import ArmTargetsNode
    from sim_tools.batch.forms import EpisodeContext, MainRunner, NotSpinning, declared

    if _domain_id is None:
        isolate_process()
    obj = load_callable(ep.controller["target"], ep.search_path)
    form = controller_form(ep, obj)
    if form == "model" or obj is ArmTargetsNode:
        return None if form == "model" else {}
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
            robot, sonar = ("probe", "sonar") if ep.simulator == "simrobot" else ("", "")
            nodes = [_controller_node(ep, obj, params, episode_context.context, robot, sonar)]
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
    name = WORLD_NAMES[ep.simulator]  # its start-up summary is no news before a sweep
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
_world_specs: dict[str, Any] = {}


def _make_world(ep: Episode, context: Any, params: dict[str, Any]) -> Any:
    """The world node, with the sweep's parameters that it declares (the others it ignores) and
    none of the context's command line (that is the controller's)."""
    from rclpy.parameter import Parameter

    overrides = [Parameter(k, value=v) for k, v in params.items()]
    overrides += [Parameter("real_time_factor", value=0.0), Parameter("seed", value=ep.seed)]
    if ep.simulator == "create":
        from create_sim.world_node import CreateWorldNode

        overrides += [
            Parameter("map_file", value=ep.world["map"]),
            Parameter("config_file", value=ep.world["config"]),
        ]
        if ep.pose is not None:
            overrides.append(Parameter("initial_pose", value=[float(v) for v in ep.pose]))
        return CreateWorldNode(parameter_overrides=overrides, context=context, **WORLD_NODE)
    if ep.simulator == "simrobot":
        from simrobot_sim.world_file import load_world
        from simrobot_sim.world_node import SimrobotWorldNode

        path = ep.world["world_file"]
        if path not in _world_specs:  # the bitmap is parsed once per worker
            _world_specs[path] = load_world(path)
        return SimrobotWorldNode(_world_specs[path], parameter_overrides=overrides, context=context, **WORLD_NODE)
    from arm_sim.arm_node import ArmNode

    overrides.append(Parameter("robot_config", value=ep.world["robot_config"]))
    overrides.append(Parameter("skip_missing_meshes", value=True))
    # Any: the episode gives this node an ik_failures counter and counts through a wrapped ikine.
    world: Any = ArmNode(parameter_overrides=overrides, context=context, **WORLD_NODE)
    world.ik_failures = 0
    arm = world.arms[0].arm
    solve = arm.ikine

    def counted_ikine(*args: Any, **kwargs: Any) -> Any:
        result = solve(*args, **kwargs)
        world.ik_failures += not result.success
        return result

    arm.ikine = counted_ikine
    return world


def _make_controller_nodes(ep: Episode, cls: type, world: Any, params: dict[str, Any], context: Any) -> list[Any]:
    """The controller node(s): one for the Create or the arm, one per robot with an ultrasonic
    sensor (namespaced ``/<robot>``) for SIMROBOT."""
    from sim_tools.batch.arm_targets import ArmTargetsNode

    if ep.simulator == "arm" and cls is ArmTargetsNode:
        return [ArmTargetsNode(_target_poses(ep, world), ep.world["hold_s"], context=context, **LEAN_NODE)]
    if ep.simulator != "simrobot":
        return [_controller_node(ep, cls, params, context)]
    robots = [(r.name, next((s.name for s in r.sensors if s.kind == "ultrasonic"), None)) for r in world.spec.robots]
    return [_controller_node(ep, cls, params, context, name, sonar) for name, sonar in robots if sonar is not None]


def _controller_node(
    ep: Episode, cls: type, params: dict[str, Any], context: Any, robot: str = "", sonar: str = ""
) -> Any:
    """One node of class ``cls``, given what its ``__init__`` accepts; what it does not (a class
    without ``**kwargs``) it finds in the episode context's arguments, rclpy's default context."""
    from rclpy.parameter import Parameter

    from sim_tools.batch.forms import node_kwargs

    overrides = [Parameter(k, value=v) for k, v in controller_parameters(ep, params).items()]
    wanted: dict[str, Any] = {"parameter_overrides": overrides, "context": context}
    if robot:
        wanted.update(namespace=f"/{robot}", sensor=sonar)
    kwargs = node_kwargs(cls, wanted)
    if "sensor" in kwargs and "sensor" not in _init_args(cls):
        del kwargs["sensor"]  # **kwargs go on to Node, which takes no sensor
    if ep.controller["kind"] != "ours":
        return cls(**kwargs)
    node = cls(**kwargs, **LEAN_NODE)
    if list(node.timers):
        node.set_parameters([Parameter("use_sim_time", value=True)])
    return node


def _init_args(cls: type) -> set[str]:
    import inspect

    try:
        return set(inspect.signature(cls).parameters)
    except (TypeError, ValueError):
        return set()


# ------------------------------------------------------------------------------------ probes
class _CreateProbe:
    """Pose, bumpers and wall clearance after every step."""

    def __init__(self, world: Any, steps: int) -> None:
        self.world = world
        self.model = world.model
        self.rows = np.empty((steps + 1, 6))
        self.n = 0
        self.sample()

    def sample(self) -> None:
        m = self.model
        x, y, theta = m.pose
        left, right = m.bumps()
        self.rows[self.n] = (self.world.sim_time, x, y, theta, left or right, m.clearance())
        self.n += 1

    def data(self, ep: Episode) -> EpisodeData:
        r = self.rows[: self.n]
        arrays = {"x": r[:, 1], "y": r[:, 2], "theta": r[:, 3], "bump": r[:, 4] > 0, "clearance": r[:, 5]}
        return EpisodeData(r[:, 0], arrays, {"radius_m": self.model.RADIUS}, ep.params, ep.seed)


class _SimrobotProbe:
    """Every robot's pose and crash flag after every step."""

    def __init__(self, world: Any, steps: int) -> None:
        self.world = world
        n = len(world.model.names)
        self.t = np.empty(steps + 1)
        self.xy = np.empty((steps + 1, n, 2))
        self.crashed = np.empty((steps + 1, n), dtype=bool)
        self.n = 0
        self.sample()

    def sample(self) -> None:
        model = self.world.model
        self.t[self.n] = self.world.sim_time
        self.xy[self.n] = model.poses()[:, :2]
        self.crashed[self.n] = model.crashed
        self.n += 1

    def data(self, ep: Episode) -> EpisodeData:
        k = self.n
        arrays = {"x": self.xy[:k, :, 0], "y": self.xy[:k, :, 1], "crashed": self.crashed[:k]}
        info = {"names": list(self.world.model.names), "dt": self.world.physics_dt}
        return EpisodeData(self.t[:k], arrays, info, ep.params, ep.seed)


class _ArmProbe:
    """Flange-to-target distance after every step; the target held is the schedule's at that time."""

    def __init__(self, world: Any, steps: int, targets: np.ndarray, hold_s: float) -> None:
        self.world = world
        self.instance = world.arms[0]
        self.targets = targets
        self.hold_s = hold_s
        self.rows = np.empty((steps + 1, 3))
        self.n = 0
        self.sample()

    def sample(self) -> None:
        t = self.world.sim_time
        k = min(int(t / self.hold_s + 1e-9), len(self.targets) - 1)
        flange = self.instance.arm.fkine(self.instance.motion.q)[:3, 3]
        self.rows[self.n] = (t, k, float(np.linalg.norm(flange - self.targets[k, :3, 3])))
        self.n += 1

    def data(self, ep: Episode) -> EpisodeData:
        r = self.rows[: self.n]
        arrays = {"target": r[:, 1].astype(np.int64), "error": r[:, 2]}
        return EpisodeData(r[:, 0], arrays, {"ik_failures": self.world.ik_failures}, ep.params, ep.seed)


def _make_probe(ep: Episode, world: Any) -> Any:
    steps = round(ep.duration_s * world.physics_rate)
    if ep.simulator == "create":
        return _CreateProbe(world, steps)
    if ep.simulator == "simrobot":
        return _SimrobotProbe(world, steps)
    return _ArmProbe(world, steps, _target_poses(ep, world), ep.world["hold_s"])


# --------------------------------------------------------------------------------------- arm
def _target_poses(ep: Episode, world: Any) -> np.ndarray:
    from sim_tools.batch.arm_targets import target_poses

    return target_poses(world.arms[0].arm, ep.world["targets"])
