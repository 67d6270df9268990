"""Base class of every simulated world: sim clock, fixed physics step, scheduled publishers."""

from __future__ import annotations

import array
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock as RosClock
from rclpy.clock import ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from sim_runtime.errors import InputError
from sim_runtime.msgs import time_msg
from sim_runtime.qos import CLOCK_QOS

#: How many physics steps one wall-timer tick may run to catch up before the world
#: gives up on real time (like the MATLAB timer's BusyMode "drop"): physics never
#: takes bigger steps, the run just falls behind the wall clock.
MAX_CATCH_UP_STEPS = 50


def _like(default: Any, value: Any) -> Any:
    """``value`` converted to ``default``'s type where that loses nothing, else None."""
    if isinstance(default, bool) or default is None:
        return value if isinstance(value, bool) or default is None else None
    if isinstance(default, float):
        return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
    if isinstance(default, int):
        return value if isinstance(value, int) and not isinstance(value, bool) else None
    if isinstance(default, str):
        return value if isinstance(value, str) else None
    if isinstance(default, list | tuple):
        if not isinstance(value, list | tuple | array.array):
            return None
        items = list(value)
        if default and isinstance(default[0], float):
            if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in items):
                return None
            return [float(v) for v in items]
        return items
    return value


class _Scheduled:
    """A callback run whenever sim time crosses a multiple of its period."""

    __slots__ = ("callback", "ticks_per_step", "done")

    def __init__(self, callback: Callable[[], None], ticks_per_step: float) -> None:
        self.callback = callback
        self.ticks_per_step = ticks_per_step
        self.done = 0

    def due(self, step_count: int) -> bool:
        # Integer tick counts from the step count: no drift however long the run.
        ticks = math.floor(step_count * self.ticks_per_step + 1e-9)
        if ticks > self.done:
            self.done = ticks
            return True
        return False


class SimWorldNode(Node):
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
        self.real_time_factor = float(
            self.declare_checked(
                "real_time_factor",
                1.0,
                lambda v: math.isfinite(v) and v >= 0.0,
                "sim seconds per wall second: 1 real time, 0 as fast as possible (must be >= 0)",
            )
        )
        self.seed = int(self.declare_checked("seed", 0, lambda v: v >= 0, "noise seed (must be >= 0)"))
        self.live_view = bool(self.declare_parameter("rerun", False).value)
        self.rng = np.random.default_rng(self.seed)
        self.sim_time = 0.0
        self.step_count = 0
        self.finished = False  # a world that ends (a steps limit) sets this; it then never steps
        self._scheduled: list[_Scheduled] = []
        self._last_warning: dict[str, float] = {}
        self._clock_pub = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        self._pacer = None

    # -- for subclasses -------------------------------------------------------------------
    def physics_step(self) -> None:
        """Advance the model by ``physics_dt``; override."""

    def ready_to_step(self) -> bool:
        """Whether the next step may run now; lockstep worlds wait for their controllers."""
        return not self.finished

    def every(self, rate_hz: float, callback: Callable[[], None]) -> None:
        """Run ``callback`` after each physics step at which sim time crosses a multiple of
        ``1/rate_hz`` (rate 0 disables it; rates above the physics rate fire every step)."""
        if not (math.isfinite(rate_hz) and rate_hz >= 0.0):
            raise InputError(f"publish rate must be >= 0 Hz, got {rate_hz!r}")
        if rate_hz > 0.0:
            entry = _Scheduled(callback, min(rate_hz / self.physics_rate, 1.0))
            entry.done = math.floor(self.step_count * entry.ticks_per_step + 1e-9)
            self._scheduled.append(entry)

    def declare_checked(self, name: str, default: Any, check: Callable[[Any], bool], description: str) -> Any:
        """Declare a parameter and return its value, typed like ``default``.

        Whole numbers are accepted where a float is expected (``-p real_time_factor:=0``,
        ``-p initial_pose:=[1,0,0]``); a value of another type, or failing ``check``, raises
        :class:`InputError` naming the parameter, the value and what is expected.
        """
        descriptor = ParameterDescriptor(description=description, dynamic_typing=True)
        given = self.declare_parameter(name, default, descriptor).value
        value = _like(default, given)
        try:
            ok = value is not None and bool(check(value))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(f"parameter '{name}' = {given!r} is invalid: {description}")
        return value

    def stamp(self):
        """Current sim time as a ``builtin_interfaces/Time``."""
        return time_msg(self.sim_time)

    def warn_throttled(self, key: str, text: str, period: float = 2.0) -> None:
        """Log a warning at most once per ``period`` wall seconds per ``key``."""
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

    def start_pacing(self) -> None:
        """Step on a steady wall timer at ``real_time_factor`` (> 0); catches up in bursts."""
        if self.real_time_factor <= 0.0 or self._pacer is not None:
            return
        # At most 10 ms between looks, however long a step is: a lockstep world with 1 s steps
        # must notice its controllers' answers promptly, not at the next 1 s tick.
        period = min(max(self.physics_dt / self.real_time_factor, 0.001), 0.01)
        self._pace_origin = (time.monotonic(), self.sim_time)
        self._pacer = self.create_timer(period, self._pace, clock=RosClock(clock_type=ClockType.STEADY_TIME))

    def _pace(self) -> None:
        wall0, sim0 = self._pace_origin
        target = sim0 + (time.monotonic() - wall0) * self.real_time_factor
        due = int((target - self.sim_time) / self.physics_dt + 1e-9)
        if due > MAX_CATCH_UP_STEPS:
            # Too slow for this rate: run a bounded burst and re-anchor rather than spiral.
            due = MAX_CATCH_UP_STEPS
            self._pace_origin = (time.monotonic(), self.sim_time + due * self.physics_dt)
        for _ in range(due):
            if not self.ready_to_step():
                # Lockstep: the wall clock keeps going, so re-anchor when we resume.
                self._pace_origin = (time.monotonic(), self.sim_time)
                break
            self.step()
