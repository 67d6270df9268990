"""One episode in the calling process: a fresh rclpy context, the world, its controllers, the
world stepped directly at ``real_time_factor: 0``, the model sampled after every step, metrics.

Isolation: the process sets ``ROS_AUTOMATIC_DISCOVERY_RANGE=OFF`` (:func:`isolate_process`) and
every episode gets its own context on a domain id above the ones people use interactively, so
nothing outside the episode sees its topics and two episodes never share a graph, however many
run side by side. All of an episode's nodes live in this process, where matching still works.

:func:`run_episode` never raises: a failed episode is a row with ``status: error`` and the error.
"""

from __future__ import annotations

import json
import os
import threading
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sim_runtime.batch.metrics import EpisodeData, compute, load_callable
from sim_runtime.batch.sweep import Episode
from sim_runtime.errors import InputError

#: Domain ids of batch episodes start here (people use 0–20 interactively; discovery is off anyway).
DOMAIN_BASE = 100
#: Wall seconds to wait for an episode's publishers and subscriptions to match.
MATCH_TIMEOUT = 10.0

#: Our nodes in an episode go without what nobody can reach there (parameter services, /rosout):
#: leaving them out halved the set-up plus tear-down (median 0.22 -> 0.10 s, measured alternating).
LEAN_NODE = {"start_parameter_services": False, "enable_rosout": False}

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
    import rclpy
    from rclpy.context import Context

    from sim_runtime.batch.bus import DirectBus, direct_eligible
    from sim_runtime.run import drain, make_executor

    t0 = time.perf_counter()
    controller = ep.controller
    target = controller["target"]
    obj = load_callable(target, ep.search_path)
    params = {**controller["parameters"], **ep.params}
    is_main = controller["kind"] == "user" and not isinstance(obj, type) and target.endswith(":main")
    if is_main:
        # A main() makes its nodes on rclpy's global context: give it a fresh one per episode,
        # with the parameters as the command line's (-p applies to every node of the context).
        overrides = {"seed": ep.seed, **params}
        argv = ["batch", "--ros-args"] + [a for k, v in overrides.items() for a in ("-p", f"{k}:={json.dumps(v)}")]
        rclpy.init(args=argv, domain_id=_domain_id)
        context = rclpy.utilities.get_default_context()
    else:
        context = Context()
        rclpy.init(args=[], context=context, domain_id=_domain_id)
    executor = make_executor(context)
    nodes: list[Any] = []
    user_main: _MainController | None = None
    recorder = None
    try:
        world = _make_world(ep, context)
        nodes.append(world)
        control_step: Callable[[Any, float], None] | None = None
        if is_main:
            user_main = _MainController(obj)
            nodes += user_main.start()
        elif isinstance(obj, type):
            nodes += _make_controller_nodes(ep, obj, world, params, context)
        elif callable(obj):
            control_step = obj(world.model, dict(params), ep.seed)
            if not callable(control_step):
                raise InputError(f"controller {target}: must return a per-step callable control(model, t)")
        else:
            raise InputError(f"controller {target}: neither a node class, a main nor a function")
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
        if not world.ready_to_step() and hasattr(world, "_publish_step"):
            # A lockstep SIMROBOT world published step 0 before its controllers existed and
            # waits for their answers: publish it again now, as the world itself does after
            # half a second of waiting (its re-publication).
            world._publish_step()
            bus.flush() if transport == "direct" else drain(executor)
        probe = _make_probe(ep, world)
        steps = round(ep.duration_s * world.physics_rate)
        t1 = time.perf_counter()
        for _ in range(steps):
            if world.finished:
                break
            if control_step is not None:
                control_step(world.model, world.sim_time)
            if transport == "direct":
                world.step()
                bus.flush()
            else:
                while not world.ready_to_step() and not world.finished:
                    executor.spin_once(timeout_sec=0.01)
                if world.finished:
                    break
                world.step()
                drain(executor)
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
        if is_main:
            rclpy.shutdown()  # also lets the next episode's init() make a fresh global context
        else:
            rclpy.shutdown(context=context)
    end = time.perf_counter()
    if recorder is not None and recorder.error is not None:
        raise RuntimeError(f"recording the bag failed: {recorder.error}")
    return data, sim_time, {"setup_s": t1 - t0, "run_s": t2 - t1, "teardown_s": end - t3, "transport": transport}


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


def _make_world(ep: Episode, context: Any) -> Any:
    from rclpy.parameter import Parameter

    overrides = [Parameter("real_time_factor", value=0.0), Parameter("seed", value=ep.seed)]
    if ep.simulator == "create":
        from create_sim.world_node import CreateWorldNode

        overrides += [
            Parameter("map_file", value=ep.world["map"]),
            Parameter("config_file", value=ep.world["config"]),
        ]
        if ep.pose is not None:
            overrides.append(Parameter("initial_pose", value=[float(v) for v in ep.pose]))
        return CreateWorldNode(parameter_overrides=overrides, context=context, **LEAN_NODE)
    if ep.simulator == "simrobot":
        from simrobot_sim.world_file import load_world
        from simrobot_sim.world_node import SimrobotWorldNode

        path = ep.world["world_file"]
        if path not in _world_specs:  # the bitmap is parsed once per worker
            _world_specs[path] = load_world(path)
        return SimrobotWorldNode(_world_specs[path], parameter_overrides=overrides, context=context, **LEAN_NODE)
    from arm_sim.arm_node import ArmNode

    overrides.append(Parameter("robot_config", value=ep.world["robot_config"]))
    overrides.append(Parameter("skip_missing_meshes", value=True))
    world = ArmNode(parameter_overrides=overrides, context=context, **LEAN_NODE)
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
    from rclpy.parameter import Parameter

    overrides = [Parameter("seed", value=ep.seed)] + [Parameter(k, value=v) for k, v in params.items()]
    if ep.simulator == "simrobot":
        nodes = []
        for robot in world.spec.robots:
            sonar = next((s.name for s in robot.sensors if s.kind == "ultrasonic"), None)
            if sonar is not None:
                kwargs = {"namespace": f"/{robot.name}", "parameter_overrides": overrides, "context": context}
                if ep.controller["kind"] == "ours":
                    kwargs.update(LEAN_NODE)
                if "sensor" in _init_args(cls):
                    kwargs["sensor"] = sonar
                nodes.append(cls(**kwargs))
        return nodes
    from sim_runtime.batch.arm_targets import ArmTargetsNode

    if ep.simulator == "arm" and cls is ArmTargetsNode:
        return [ArmTargetsNode(_target_poses(ep, world), ep.world["hold_s"], context=context, **LEAN_NODE)]
    lean = LEAN_NODE if ep.controller["kind"] == "ours" else {}
    return [cls(parameter_overrides=overrides, context=context, **lean)]


def _init_args(cls: type) -> set[str]:
    import inspect

    try:
        return set(inspect.signature(cls.__init__).parameters)
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
    from sim_runtime.batch.arm_targets import target_poses

    return target_poses(world.arms[0].arm, ep.world["targets"])


# ------------------------------------------------------------------------- a user's main()
class _MainController:
    """A user's ``main()`` that builds its node(s) and calls ``rclpy.spin(node)``: run in a thread
    with ``rclpy.init/spin/shutdown/ok`` redirected to the episode, so its nodes join the episode's
    executor and their callbacks run in the stepping thread, deterministically."""

    def __init__(self, main: Callable[..., Any]) -> None:
        self.main = main
        self.nodes: list[Any] = []
        self.ready = threading.Event()
        self.finish = threading.Event()
        self.error: BaseException | None = None
        self.thread: threading.Thread | None = None
        self._saved: dict[str, Any] = {}

    def start(self) -> list[Any]:
        import rclpy

        def spin(node: Any, executor: Any = None) -> None:
            self.nodes.append(node)
            self.ready.set()
            self.finish.wait()

        self._saved = {name: getattr(rclpy, name) for name in ("init", "spin", "shutdown", "ok")}
        rclpy.init = lambda *a, **k: None
        rclpy.spin = spin
        rclpy.shutdown = lambda *a, **k: None
        rclpy.ok = lambda *a, **k: not self.finish.is_set()

        def run() -> None:
            try:
                self.main()
            except BaseException as exc:
                self.error = exc
            finally:
                self.ready.set()

        self.thread = threading.Thread(target=run, daemon=True)
        self.thread.start()
        self.ready.wait(timeout=MATCH_TIMEOUT)
        if self.error is not None or not self.nodes:
            self.stop()
            raise RuntimeError(f"the controller's main() did not reach rclpy.spin: {self.error or 'timeout'}")
        return self.nodes

    def stop(self) -> None:
        import rclpy

        self.finish.set()
        if self.thread is not None:
            self.thread.join(timeout=MATCH_TIMEOUT)
        for name, value in self._saved.items():
            setattr(rclpy, name, value)
        self._saved = {}
