"""Process entry: one executor for every node, worlds paced by their real_time_factor."""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from sim_runtime.errors import InputError
from sim_runtime.world_node import SimWorldNode

#: What shows a world started with ``-p rerun:=true``: the tools layer registers its live Rerun
#: view here (:func:`sim_tools.cli.run`, the way every executable starts), so the base runs
#: without Rerun and imports no tool.
live_viewers: list[Callable[[SimWorldNode], object]] = []


def make_executor(context: Context | None = None) -> Executor:
    """The executor every process and test uses (on ``context``, default rclpy's global one).

    rclpy's EventsExecutor is 4-5x faster than SingleThreadedExecutor and, unlike it, does
    not rebuild a wait set over every entity on each spin (178 ms vs 0.3 ms per spin with
    2000 subscriptions, measured here), which a world with hundreds of robots needs.
    """
    return EventsExecutor(context=context)


@contextmanager
def private_ros(args: Sequence[str] | None = None) -> Iterator[tuple[Context, Executor]]:
    """A private rclpy context and its executor, for running worlds inside a library call (a
    demo, a notebook) whether or not rclpy's global context is up; on exit every node added
    to the executor is destroyed and the context shut down."""
    context = Context()
    rclpy.init(args=None if args is None else list(args), context=context)
    executor = make_executor(context)
    try:
        yield context, executor
    finally:
        for node in list(executor.get_nodes()):
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.shutdown(context=context)


def drain(executor: Executor, timeout_sec: float = 1.0, max_rounds: int = 4) -> bool:
    """Run every callback already queued on ``executor``, and what those callbacks queue in turn
    (a controller's answer to the sensor readings of this step), until a round finds nothing
    else queued or ``max_rounds`` rounds ran (a steady stream from another process, such as a
    flood of commands, never leaves the queue empty); True unless the timeout hit.

    The events executor handles work in arrival order, so a no-op task queued now completes only
    after everything queued before it. It is awaited with ``spin_once`` turns, not
    ``spin_until_future_complete``: on the events executor that call keeps ~32 bytes per call,
    which a world stepping at real_time_factor 0 made 10 MB per sim hour.
    """
    deadline = time.monotonic() + timeout_sec
    for _ in range(max_rounds):
        marker = executor.create_task(lambda: None)
        turns = 0
        while not marker.done():
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                return False
            executor.spin_once(timeout_sec=remaining)
            turns += 1
        if turns == 1:  # the marker was all there was
            break
    return True


def spin_steps(executor: Executor, world: SimWorldNode, steps: int, idle_timeout: float = 0.01) -> int:
    """Step ``world`` ``steps`` times as fast as it is ready (a lockstep world waits for its
    controllers), handling every queued callback after each step; returns the steps done
    (fewer if the world finishes first)."""
    done = 0
    while done < steps and not world.finished:
        if world.ready_to_step():
            world.step()
            done += 1
            drain(executor)
        else:
            executor.spin_once(timeout_sec=idle_timeout)
    return done


def split_ros_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """(our arguments, argv for rclpy.init) from a full argv.

    Everything from the first ``--ros-args`` on belongs to ROS; the rest is ours, including
    ``--remap old:=new``, which rclpy would otherwise take for a (deprecated) remap rule.
    """
    argv = list(argv)
    cut = argv.index("--ros-args") if "--ros-args" in argv else len(argv)
    return argv[1:cut], argv[:1] + argv[cut:]


class StopSignal:
    """Ctrl-C and SIGTERM as a flag that an executable's main loop polls.

    rclpy's own handlers shut the context down wherever the program happens to be, so a
    world stopped mid-step failed with "publisher's context is invalid", and Python's
    KeyboardInterrupt surfaced inside callbacks. With a flag the loop finishes what it is
    doing, then stops and cleans up; a second Ctrl-C while a bag is being finished is
    harmless for the same reason.
    """

    def __init__(self) -> None:
        self.requested = False
        #: While True (the nodes being built: no callback runs yet), a stop raises KeyboardInterrupt
        #: wherever start-up is, so a long start-up (a huge map) ends at once, not when it is done.
        self.starting = False
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, self._request)

    def _request(self, _signum: int, _frame: object) -> None:
        self.requested = True
        if self.starting:
            self.starting = False  # once: the clean-up that follows is not interrupted again
            raise KeyboardInterrupt

    @property
    def running(self) -> bool:
        """True until a stop was requested or rclpy was shut down."""
        return not self.requested and rclpy.ok()


def init_ros(args: Sequence[str] | None = None) -> StopSignal:
    """``rclpy.init`` for an executable's main, with our stop flag instead of rclpy's handlers.

    Arguments rcl cannot parse raise :class:`InputError`."""
    stop = StopSignal()
    try:
        rclpy.init(args=None if args is None else list(args), signal_handler_options=SignalHandlerOptions.NO)
    except _rclpy.RCLError as error:  # e.g. "-p name:=" with no value
        raise InputError(f"invalid ROS arguments {' '.join(args or sys.argv)!r}: {error}") from None
    return stop


def _attach_live_view(world: SimWorldNode) -> None:
    if not live_viewers:
        world.get_logger().error("rerun:=true: no live view here; start the world as `robot_sims <world>`")
    for attach in live_viewers:
        attach(world)


def run_nodes(make_nodes: Callable[[], Sequence[Node]], args: list[str] | None = None) -> int:
    """Initialise rclpy, build the nodes, spin them in one executor until shutdown.

    Worlds with ``real_time_factor`` > 0 step on a steady timer; at 0 they step as fast as the
    CPU allows, handling every queued callback between steps. Bad input found while building
    the nodes is printed as one clear line and the process exits with status 2.
    """
    try:
        stop = init_ros(args)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    nodes: list[Node] = []
    try:
        try:
            stop.starting = True
            nodes = list(make_nodes())
        except InputError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print("stopped while starting", file=sys.stderr)
            return 130
        finally:
            stop.starting = False
        executor = make_executor()
        for node in nodes:
            executor.add_node(node)
        worlds = [node for node in nodes if isinstance(node, SimWorldNode)]
        for world in worlds:
            if world.live_view:
                _attach_live_view(world)
        for world in worlds:
            world.start_pacing()  # no-op at real_time_factor 0
            world.get_logger().info(f"ready: {world.pace_text()}")
        while stop.running:
            # Re-read every turn: real_time_factor is a live parameter.
            stepped = False
            for world in worlds:
                if world.real_time_factor == 0.0 and world.ready_to_step():
                    world.step()
                    stepped = True
            if stepped:
                drain(executor)
            else:
                # EventsExecutor.spin() neither fires these timers nor returns on SIGINT here;
                # short spin_once calls do both.
                fast = any(world.real_time_factor == 0.0 for world in worlds)
                executor.spin_once(timeout_sec=0.01 if fast else 0.1)
    except ExternalShutdownException:
        pass
    finally:
        for node in nodes:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
