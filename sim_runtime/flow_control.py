"""A world at ``real_time_factor`` 0 never outruns a recorder attached to it.

A recorder (:class:`sim_runtime.bag.record.Recorder`) reports on :data:`PROGRESS_TOPIC` the sim
time of the newest ``/clock`` it has handled, every :data:`REPORT_EVERY` clock ticks. A world at
real_time_factor 0 does not take its next step while an attached recorder is more than
:data:`WINDOW_STEPS` steps behind (:meth:`RecorderGate.holds`, part of ``ready_to_step``), so at
most that many steps of messages are ever in flight to the recorder: far below what the transport
buffers (Fast DDS's shared-memory port: 512 messages) and each publisher keeps for resending (100
samples), so nothing is dropped on the way and a lost packet is resent. Without the gate a
world at 20x real time on a loaded machine filled those buffers and 0.2-1 % of its messages were
missing from the bag.

A recorder that reports nothing for :data:`STALL_SECONDS` while the world waits (stopped with
SIGSTOP, hung, killed without saying goodbye) is not waited for again until it reports: the world
logs a warning and steps on. At real_time_factor > 0 the world keeps real time and never waits;
a recorder that falls behind then says so (lost samples in its log and the bag's metadata).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from builtin_interfaces.msg import Time
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import TimeReference

#: Hidden (a token starting with "_"): recorders leave it out of bags unless asked for it.
PROGRESS_TOPIC = "/_robot_sims/recorded_clock"
PROGRESS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
#: How far (physics steps) a world may run ahead of the slowest attached recorder.
WINDOW_STEPS = 20
#: A recorder reports every this many /clock ticks (a quarter of the window: the world rarely waits).
REPORT_EVERY = 5
#: Wall seconds without a report, while the world waits, after which the recorder is not waited for.
STALL_SECONDS = 2.0
#: Wall seconds between two looks at the reporters matched: a world takes a few steps at most
#: in that time (far fewer than WINDOW_STEPS), so it holds for a new recorder before it is a window ahead.
POLL_SECONDS = 0.0005


def _ns(stamp: Time) -> int:
    ns: int = stamp.sec * 1_000_000_000 + stamp.nanosec  # Time is untyped (a ROS message)
    return ns


@dataclass
class _Progress:
    sim_ns: int
    wall: float  # time.monotonic() of the last report
    ignored: bool = False


class RecorderGate:
    """The world's side: follows every recorder's reports; :meth:`holds` says whether to wait."""

    def __init__(self, node: Node, physics_dt: float) -> None:
        self._node = node
        self._window_ns = round(WINDOW_STEPS * physics_dt * 1e9)
        self._recorders: dict[str, _Progress] = {}
        self._matched = 0  # recorders whose reporter matched us, reporting or not yet
        self._matched_at = 0.0
        self._polled_at = -math.inf
        # The matched count is polled, not taken from a "matched" event callback: rclpy's
        # EventsExecutor can crash the process later when an entity with event callbacks is
        # destroyed while it goes on spinning (worlds are, in sweeps, the studio and tests).
        self._subscription = node.create_subscription(TimeReference, PROGRESS_TOPIC, self._on_progress, PROGRESS_QOS)

    def _poll_matched(self) -> None:
        """At most every :data:`POLL_SECONDS`: has a recorder come or gone?"""
        now = time.monotonic()
        if now - self._polled_at < POLL_SECONDS:
            return
        self._polled_at = now
        count = self._subscription.get_publisher_count()
        # A recorder announces itself as it subscribes to /clock, before its first report.
        if count > self._matched:
            self._matched_at = now
        elif count < self._matched:  # a recorder stopped: forget it at once
            present = self._present()
            for name in [n for n in self._recorders if n not in present]:
                del self._recorders[name]
        self._matched = count

    def _present(self) -> set[str]:
        """Fully qualified names of the recorders now on the graph."""
        return {
            f"{p.node_namespace.rstrip('/')}/{p.node_name}"
            for p in self._node.get_publishers_info_by_topic(PROGRESS_TOPIC)
        }

    def _on_progress(self, msg: TimeReference) -> None:
        entry = self._recorders.get(msg.source)
        if entry is None:
            self._recorders[msg.source] = _Progress(_ns(msg.time_ref), time.monotonic())
            self._node.get_logger().info(
                f"recorder {msg.source} attached: at real_time_factor 0 "
                f"the world stays within {WINDOW_STEPS} steps of it"
            )
            return
        if entry.ignored:
            self._node.get_logger().info(f"recorder {msg.source} reports again: waiting for it at real_time_factor 0")
        entry.sim_ns, entry.wall, entry.ignored = _ns(msg.time_ref), time.monotonic(), False

    @property
    def attached(self) -> bool:
        """Whether any recorder is attached (a cheap test before :meth:`holds`)."""
        self._poll_matched()
        return bool(self._matched or self._recorders)

    def holds(self, sim_time: float) -> bool:
        """True while an attached recorder is more than the window behind ``sim_time`` (s)."""
        sim_ns = round(sim_time * 1e9)
        if self._matched > len(self._recorders) and time.monotonic() - self._matched_at < STALL_SECONDS:
            return True  # a recorder attached and has not reported yet
        for name, entry in list(self._recorders.items()):
            if entry.ignored or sim_ns - entry.sim_ns <= self._window_ns:
                continue
            if time.monotonic() - entry.wall < STALL_SECONDS:
                return True
            self._give_up(name, entry)
        return False

    def _give_up(self, name: str, entry: _Progress) -> None:
        """A recorder gone (its node left the graph) is forgotten; one still there is not waited for."""
        if name not in self._present():
            del self._recorders[name]
            return
        entry.ignored = True
        self._node.get_logger().warning(
            f"recorder {name} has recorded nothing for {STALL_SECONDS:g} s (stopped or hung?): stepping on "
            "without waiting for it until it reports again; its bag may miss messages"
        )


class ProgressReporter:
    """The recorder's side: reports the newest /clock it handled, every :data:`REPORT_EVERY` ticks.

    Made when the recorder subscribes to /clock: a world then waits for its first report."""

    def __init__(self, node: Node) -> None:
        self._publisher = node.create_publisher(TimeReference, PROGRESS_TOPIC, PROGRESS_QOS)
        self._msg = TimeReference(source=node.get_fully_qualified_name())
        self._ticks = 0

    def handled(self, clock_ns: int) -> None:
        """Note a handled /clock tick (its sim time in ns)."""
        self._ticks += 1
        if self._ticks % REPORT_EVERY != 1:  # the first tick reports at once: the world learns of us
            return
        self._msg.time_ref.sec, self._msg.time_ref.nanosec = divmod(clock_ns, 1_000_000_000)
        self._publisher.publish(self._msg)
