"""Base class of every simulated world: sim clock, fixed physics step, scheduled publishers."""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from rclpy.clock import Clock as RosClock
from rclpy.clock import ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger

from sim_runtime.errors import InputError
from sim_runtime.flow_control import RecorderGate
from sim_runtime.msgs import time_msg
from sim_runtime.params import CheckedNode
from sim_runtime.qos import CLOCK_QOS

#: How many physics steps a world may be behind its wall clock before it gives up on real time
#: (like the MATLAB timer's BusyMode "drop"): physics never takes bigger steps, the run just falls
#: behind the wall clock.
MAX_CATCH_UP_STEPS = 50

#: The most sim time (s) one wall-timer tick runs while catching up; the rest of the backlog is
#: run at the next ticks, with the executor handling what arrived in between. A burst of 50
#: steps read no message for 0.5 s of a Create's sim time: a stop sent by a MATLAB travelDist
#: then came 12 cm late at 3x real time on a busy machine. Commands (subscriptions made with
#: :func:`sim_runtime.qos.create_command_subscription`) are also taken between the steps of a burst.
MAX_BURST_SIM_S = 0.1


#: A start-up phase lasting longer than this (wall seconds) says what it is doing, then again every
#: PROGRESS_EVERY_S: a world taking a minute to start must not look hung.
PROGRESS_AFTER_S = 2.0
PROGRESS_EVERY_S = 2.0


class StartupPhase:
    """One phase of a world's start-up (see :func:`startup_phase`); :meth:`progress` tells how far it is."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.detail = ""
        self.started = time.monotonic()

    def progress(self, done: int, total: int) -> None:
        """``done`` of ``total`` items (walls, rows): shown in the phase's next line."""
        self.detail = f"{done:,} of {total:,} ({100.0 * done / max(total, 1):.0f} %)"

    def line(self) -> str:
        elapsed = time.monotonic() - self.started
        return f"{self.what}{': ' + self.detail if self.detail else ''} ({elapsed:.0f} s so far)"


@contextmanager
def startup_phase(log: Callable[[str], None], what: str) -> Iterator[StartupPhase]:
    """Run a block of start-up work; if it lasts more than :data:`PROGRESS_AFTER_S`, ``log`` a line
    saying what it is (and how far, see :meth:`StartupPhase.progress`), then every
    :data:`PROGRESS_EVERY_S` until it ends. The lines come from a thread, so a block need not
    report anything to be seen; a numba kernel holding the GIL delays them by one of its calls."""
    phase = StartupPhase(what)
    done = threading.Event()

    def watch() -> None:
        wait = PROGRESS_AFTER_S
        while not done.wait(wait):
            log(phase.line())
            wait = PROGRESS_EVERY_S

    watcher = threading.Thread(target=watch, name=f"startup: {what}", daemon=True)
    watcher.start()
    try:
        yield phase
    finally:
        done.set()
        watcher.join()


def namespace_prefix(namespace: str) -> str:
    """The frame prefix a node's namespace gives its robot frames: ``/robot1`` → ``robot1/``, ``/`` → ``''``."""
    ns = namespace.strip("/")
    return f"{ns}/" if ns else ""


def _take(subscription: Subscription) -> Any:
    """The next message waiting on ``subscription`` (None: none waits, or it was destroyed)."""
    try:
        with subscription.handle:
            taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
    except InvalidHandle:
        return None
    return None if taken is None else taken[0]


class _Scheduled:
    """A callback run whenever sim time crosses a multiple of its period."""

    __slots__ = ("callback", "done", "ticks_per_step")

    def __init__(self, callback: Callable[[], None], ticks_per_step: float) -> None:
        self.callback = callback
        self.ticks_per_step = ticks_per_step
        self.done = 0

    def set_rate(self, ticks_per_step: float, step_count: int) -> None:
        """Ticks per physics step from now on (0 = never, capped at every step)."""
        if not (math.isfinite(ticks_per_step) and ticks_per_step >= 0.0):
            raise InputError(f"publish rate must be >= 0 Hz, got {ticks_per_step!r} per step")
        self.ticks_per_step = min(ticks_per_step, 1.0)
        self.done = math.floor(step_count * self.ticks_per_step + 1e-9)

    def due(self, step_count: int) -> bool:
        # Integer tick counts from the step count: no drift however long the run.
        ticks = math.floor(step_count * self.ticks_per_step + 1e-9)
        if ticks > self.done:
            self.done = ticks
            return True
        return False


class SimWorldNode(CheckedNode):
    """A node that owns the simulation clock.

    Subclasses override :meth:`physics_step` and register publishers with :meth:`every`.
    Time advances only through :meth:`step`: tests call it directly (deterministic), and
    :func:`sim_runtime.run.run_nodes` calls it paced by ``real_time_factor``.
    """

    def __init__(self, node_name: str, *, physics_rate: float, **node_kwargs: Any) -> None:
        super().__init__(node_name, **node_kwargs)
        if not (math.isfinite(physics_rate) and physics_rate > 0):
            raise InputError(f"physics rate must be a positive number of Hz, got {physics_rate!r}")
        self.physics_rate = float(physics_rate)
        self.physics_dt = 1.0 / self.physics_rate
        self.real_time_factor = self.declare_checked(
            "real_time_factor",
            1.0,
            math.isfinite,
            "sim seconds per wall second: 1 real time, 0 as fast as possible (>= 0)",
            live=True,
            on_change=self.set_real_time_factor,
            bounds=(0.0, 1e6),
        )
        self.seed = self.declare_checked("seed", 0, None, "noise seed", bounds=(0, 2**63 - 1))
        self.live_view = self.declare_checked("rerun", False, None, "also show the world live in a Rerun viewer")
        self.paused = self.declare_checked(
            "paused",
            False,
            None,
            "hold the simulation (sim time stops); the step service then advances it one physics step",
            live=True,
            on_change=lambda v: setattr(self, "paused", v),
        )
        self.create_service(Trigger, "step", self._on_step)
        self.rng = np.random.default_rng(self.seed)
        self.sim_time = 0.0
        self.step_count = 0
        self.finished = False  # a world that ends (a steps limit) sets this; it then never steps
        self._scheduled: list[_Scheduled] = []
        self._last_warning: dict[str, float] = {}
        #: How often each :meth:`warn_throttled` key was warned about, the throttled times included:
        #: a tool counts a world's rejected inputs (a batch episode its unreachable arm targets)
        #: without reading its log.
        self.warning_counts: Counter[str] = Counter()
        self._clock_pub = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        # Recorders report the /clock they follow: a world whose clock is remapped (a second world
        # in a namespace) is not theirs to wait for.
        self._recorders = RecorderGate(self, self.physics_dt) if self._clock_pub.topic_name == "/clock" else None
        #: Taken between the steps of a catch-up burst too (:meth:`take_commands`); filled by
        #: :func:`sim_runtime.qos.create_command_subscription`.
        self.command_subscriptions: list[Subscription] = []
        self._pacer: Timer | None = None
        self._pace_period = 0.01  # s, wall: the pacing timer's (start_pacing)
        self._paced = False  # stepped by a wall timer (run_nodes), not only by calls to step()

    # -- for subclasses -------------------------------------------------------------------
    def physics_step(self) -> None:
        """Advance the model by ``physics_dt``; override."""

    def ready_to_step(self) -> bool:
        """Whether the next step may run now: not while paused or finished, nor at
        real_time_factor 0 while an attached recorder is behind (:mod:`sim_runtime.flow_control`);
        lockstep worlds also wait for their controllers."""
        if self.finished or self.paused:
            return False
        gate = self._recorders
        return self.real_time_factor != 0.0 or not (gate is not None and gate.attached and gate.holds(self.sim_time))

    def _on_step(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """One physics step by hand, while paused (the SimulatorGUI's step button)."""
        if not self.paused:
            response.success, response.message = False, "not paused: set the 'paused' parameter to true first"
        elif self.finished:
            response.success, response.message = False, "the world has finished"
        else:
            self.step()
            response.success, response.message = True, f"sim time {self.sim_time:.6g} s"
        return response

    def every(self, rate_hz: float, callback: Callable[[], None]) -> _Scheduled:
        """Run ``callback`` after each physics step at which sim time crosses a multiple of
        ``1/rate_hz`` (rate 0 disables it; rates above the physics rate fire every step).
        The returned entry's :meth:`_Scheduled.set_rate` changes the rate later."""
        entry = _Scheduled(callback, 0.0)
        entry.set_rate(rate_hz / self.physics_rate, self.step_count)
        self._scheduled.append(entry)
        return entry

    def starting(self, what: str) -> AbstractContextManager[StartupPhase]:
        """:func:`startup_phase` logging on this node's logger: ``with self.starting("reading the map"):``."""
        return startup_phase(self.get_logger().info, what)

    def pace_text(self) -> str:
        """How this world runs, for its start-up lines."""
        rate = f"physics {self.physics_rate:g} Hz"
        if self.real_time_factor == 0.0:
            return f"{rate}, as fast as possible (real_time_factor 0)"
        if self.real_time_factor == 1.0:
            return f"{rate}, real time"
        return f"{rate}, {self.real_time_factor:g} x real time"

    def stamp(self) -> Time:
        """Current sim time as a ``builtin_interfaces/Time``."""
        return time_msg(self.sim_time)

    def warn_throttled(self, key: str, text: str, period: float = 2.0) -> None:
        """Log a warning at most once per ``period`` wall seconds per ``key``."""
        self.warning_counts[key] += 1
        now = time.monotonic()
        if now - self._last_warning.get(key, -math.inf) >= period:
            self._last_warning[key] = now
            self.get_logger().warning(text)

    # -- time -------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps now, publishing ``/clock`` and every due publisher."""
        for _ in range(n):
            self.physics_step()
            self.step_count += 1
            self.sim_time = self.step_count * self.physics_dt
            self._clock_pub.publish(Clock(clock=self.stamp()))
            for entry in self._scheduled:
                if entry.due(self.step_count):
                    entry.callback()

    def republish(self) -> None:
        """Publish the current step's data again now: every publisher registered with
        :meth:`every` at the physics rate (or above) runs once more. For subscribers that joined
        after the step was published: a lockstep world waits for the answers of controllers built
        after it, and a batch episode or a late controller needs that step's data to answer."""
        for entry in self._scheduled:
            if entry.ticks_per_step >= 1.0:
                entry.callback()

    def start_pacing(self) -> None:
        """Step on a steady wall timer at ``real_time_factor`` (> 0); catches up in bursts.

        At 0 the process's loop steps the world instead (:func:`sim_runtime.run.run_nodes`)."""
        self._paced = True
        if self.real_time_factor <= 0.0 or self._pacer is not None:
            return
        # At most 10 ms between looks, however long a step is: a lockstep world with 1 s steps
        # must notice its controllers' answers promptly, not at the next 1 s tick.
        self._pace_period = min(max(self.physics_dt / self.real_time_factor, 0.001), 0.01)
        self._pace_origin = (time.monotonic(), self.sim_time)
        self._pacer = self.create_timer(self._pace_period, self._pace, clock=RosClock(clock_type=ClockType.STEADY_TIME))

    def stop_pacing(self) -> None:
        """Stop the wall timer (the world then steps only when told to)."""
        if self._pacer is not None:
            self.destroy_timer(self._pacer)
            self._pacer = None

    def set_real_time_factor(self, factor: float) -> None:
        """Change the pace while running: the wall-clock anchor restarts now, so sim time never jumps.

        0 hands the world to the process's as-fast-as-possible loop (:func:`sim_runtime.run.run_nodes`)."""
        self.real_time_factor = float(factor)
        if self._paced:
            self.stop_pacing()
            self.start_pacing()

    def _pace(self) -> None:
        wall0, sim0 = self._pace_origin
        now = time.monotonic()
        due = int((sim0 + (now - wall0) * self.real_time_factor - self.sim_time) / self.physics_dt + 1e-9)
        if due > MAX_CATCH_UP_STEPS:
            # Too slow for this rate: keep a bounded backlog and re-anchor rather than spiral.
            due = MAX_CATCH_UP_STEPS
            self._pace_origin = (now, self.sim_time + due * self.physics_dt)
        for k in range(min(due, self.burst_steps)):  # the rest of the backlog at the next ticks
            if k:
                self.take_commands()  # what came during the burst's last step counts from the next
            if not self.ready_to_step():
                # Lockstep: the wall clock keeps going, so re-anchor when we resume.
                self._pace_origin = (time.monotonic(), self.sim_time)
                break
            self.step()

    @property
    def burst_steps(self) -> int:
        """The most physics steps one wall-timer tick runs: :data:`MAX_BURST_SIM_S` of sim time, at
        least one step, and at least a timer period's worth (a world at 1000x real time still keeps up)."""
        per_tick = float(self._pace_period * self.real_time_factor / self.physics_dt)
        return max(1, int(MAX_BURST_SIM_S / self.physics_dt + 1e-9), math.ceil(per_tick - 1e-9))

    def take_commands(self) -> int:
        """Handle every message waiting on the world's command subscriptions now, as the executor
        would after this callback (their callbacks run in this thread); returns how many. Between
        the steps of a catch-up burst: a command takes effect at the next step, not the burst's end.
        Only the subscriptions made with :func:`sim_runtime.qos.create_command_subscription`: a take
        costs some 50 us on 2 busy cores (load 25), too much for SIMROBOT's two per robot of a thousand
        robots, which the executor takes between ticks (:data:`MAX_BURST_SIM_S` bounds the wait)."""
        taken = 0
        for subscription in self.command_subscriptions:
            while (message := _take(subscription)) is not None:
                subscription.callback(message)
                taken += 1
        return taken
