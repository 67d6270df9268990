"""``robot_sims record``: record topics into a rosbag2-compatible MCAP bag.

Usage::

    robot_sims record                        # every topic, now and later, into rosbag2_<date-time>/
    robot_sims record -o run1 /scan /odom    # only these topics, into run1/ (never overwritten)
    robot_sims record '/robot\\d+/.*' --exclude '.*/image'  # regular expressions
    robot_sims record --compression lz4 --max-bag-size 100000000 --max-bag-duration 60
    ros2 run robot_sims record -o run1 --ros-args -r __node:=rec

Stop with Ctrl-C (or SIGTERM): the bag is finished cleanly (MCAP summary, metadata.yaml).
The bag opens in `ros2 bag info/play`, Foxglove, the `rosbags` library, `robot_sims replay` and
`robot_sims bag_to_rerun`. If the recorder is killed, the .mcap files hold everything up to
the last second; `robot_sims record --reindex BAG` rewrites unfinished splits with what is
intact and writes the missing metadata.yaml, so every bag reader opens it.

Topics are matched by exact name or by regular expression (full match); topics that
appear after the start are picked up within a fraction of a second. Each subscription adapts
to the publishers' QoS (best effort if any publisher is, transient local if all are, so latched
maps are recorded). Message times are sim time (from ``/clock``) when a clock is published
as recording starts, so the world may be started before or after the recorder
(``--clock auto``, default; ``--clock sim`` / ``--clock wall`` force one), else wall time.
"""

from __future__ import annotations

import argparse
import math
import re
import shutil
import struct
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import rclpy
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future

from sim_runtime.bag.reader import UnknownMessageType, message_class
from sim_runtime.bag.writer import BagWriteError, BagWriter, qos_profiles_yaml
from sim_runtime.errors import InputError
from sim_runtime.flow_control import ProgressReporter
from sim_runtime.run import init_ros, make_executor, split_ros_args

__all__ = ["Recorder", "default_bag_name", "main", "offered_qos_dict", "parse_args"]

CLOCK_TOPIC = "/clock"
_GRAPH_TOPICS = frozenset({"/rosout", "/parameter_events"})
#: Subscription queue: deep enough to ride out CPU contention at 20k msg/s (DDS allocates
#: samples only when they queue up).
RECORD_DEPTH = 10_000
_PENDING_LIMIT = 100_000
#: Prefix of the ``custom_data`` keys in metadata.yaml counting a topic's lost messages.
LOST_KEY = "robot_sims.lost_messages"


def offered_qos_dict(qos: QoSProfile) -> dict[str, Any]:
    """A publisher's offered QoS as the dict `qos_profiles_yaml` takes (rosbag2 field names)."""
    return {
        "history": qos.history.name.lower(),
        "depth": qos.depth,
        "reliability": qos.reliability.name.lower(),
        "durability": qos.durability.name.lower(),
        "deadline": qos.deadline.nanoseconds,
        "lifespan": qos.lifespan.nanoseconds,
        "liveliness": qos.liveliness.name.lower(),
        "liveliness_lease_duration": qos.liveliness_lease_duration.nanoseconds,
        "avoid_ros_namespace_conventions": qos.avoid_ros_namespace_conventions,
    }


def adapted_qos(offered: Sequence[QoSProfile]) -> QoSProfile:
    """Subscription QoS that matches every offering publisher (rosbag2's adaptation)."""
    best_effort = any(q.reliability == ReliabilityPolicy.BEST_EFFORT for q in offered)
    latched = bool(offered) and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=RECORD_DEPTH,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def clock_ns(cdr: bytes) -> int:
    """Time in a serialised rosgraph_msgs/Clock, in ns (CDR: 4-byte header, int32, uint32)."""
    sec: int
    nanosec: int
    sec, nanosec = struct.unpack_from("<iI" if cdr[1] == 1 else ">iI", cdr, 4)
    return sec * 1_000_000_000 + nanosec


@dataclass
class _Subscribed:
    subscription: Any
    msg_type: Any
    topic_id: int  # -1: /clock followed for sim time only
    qos: QoSProfile
    publisher_count: int


def _ignore(_data: bytes) -> None:
    """The callback of a retired subscription."""


def _is_hidden(topic: str) -> bool:
    return any(part.startswith("_") for part in topic.split("/"))


class Recorder(Node):
    """Subscribes raw to matching topics (including ones appearing later) and writes a bag.

    `topics`: exact names or regular expressions (full match); empty = every topic.
    `clock`: 'auto' (sim time if /clock has a publisher when the first data message comes
    in), 'sim' or 'wall'.
    After a write failure (disk full) the recorder stops: `error` holds it and `done`
    (a Future) completes; `close()` finishes the bag either way.
    """

    def __init__(
        self,
        writer: BagWriter,
        topics: Sequence[str] = (),
        *,
        exclude: str | None = None,
        clock: str = "auto",
        discovery_period: float = 0.2,
        node_name: str = "recorder",
        count_lost: bool = False,
        **node_kwargs: Any,
    ) -> None:
        super().__init__(node_name, **node_kwargs)
        #: Count the messages DDS reports lost (QoS event callbacks). Only for a recorder in a
        #: process of its own (``robot_sims record``): rclpy's EventsExecutor can crash the process
        #: later when an entity with event callbacks is destroyed while it goes on spinning, as a
        #: recorder inside a sweep, the demo or a test is.
        self._count_lost = count_lost
        self._retired: list[Any] = []  # subscriptions with event callbacks, muted, kept until exit
        if clock not in ("auto", "sim", "wall"):
            raise InputError(f"--clock {clock!r}: expected auto, sim or wall")
        self.writer = writer
        self._names = {t if t.startswith("/") else "/" + t for t in topics}
        try:
            self._patterns = [re.compile(t) for t in topics]
            self._exclude = re.compile(exclude) if exclude else None
        except re.error as exc:
            raise InputError(f"bad topic regular expression {exc.pattern!r}: {exc}") from None
        self._clock_mode = clock
        self._sim: bool | None = None if clock == "auto" else clock == "sim"
        self._sim_ns: int | None = None
        self._pending: list[tuple[int, bytes, int]] = []  # held until the time source is known
        self._graph_topic_ids: set[int] = set()
        self._clock_sub: Any = None
        self._subs: dict[str, _Subscribed] = {}
        self._latched_heard: set[str] = set()  # latched topics whose message has arrived
        self._ignored: set[str] = set()
        self._progress: ProgressReporter | None = None  # made when /clock is subscribed
        #: Messages per topic that DDS reports lost on the way to us (a publisher's history moved on
        #: before we took them: the recorder fell behind at real time); also in metadata.yaml.
        self.lost: dict[str, int] = {}
        self.error: BagWriteError | None = None
        self.done = Future()
        self.topic_ids: dict[str, int] = {}
        self._lost_warned = -math.inf
        self._discover_timer = self.create_timer(discovery_period, self.discover)
        self._flush_timer = self.create_timer(0.2, self._flush_tick)
        self.discover()

    # -- topic discovery -----------------------------------------------------------------

    def wanted(self, topic: str) -> bool:
        """Whether `topic` is to be recorded under the include/exclude rules."""
        if self._exclude is not None and self._exclude.fullmatch(topic):
            return False
        if not self._patterns:
            return not _is_hidden(topic)
        return topic in self._names or any(p.fullmatch(topic) for p in self._patterns)

    def wait_until_recording(self, executor: Any, topics: Iterable[str], timeout_sec: float = 10.0) -> bool:
        """Spin ``executor`` until every wanted topic of ``topics`` is subscribed and matched with
        its publishers, and every latched one has delivered its message: a world at
        real_time_factor 0 runs a second of sim time in milliseconds, so a run recorded in the
        same process starts stepping only then. False if ``timeout_sec`` ran out."""
        from sim_runtime.testing import spin_until

        wanted = [t for t in topics if self.wanted(t)]

        def recording() -> bool:
            self.discover()
            return all(
                t in self._subs
                and self._subs[t].subscription.get_publisher_count() > 0
                and (self._subs[t].qos.durability != DurabilityPolicy.TRANSIENT_LOCAL or t in self._latched_heard)
                for t in wanted
            )

        return spin_until(executor, recording, timeout=timeout_sec)

    def discover(self) -> None:
        """Subscribe to matching topics that have publishers and are not yet recorded."""
        if self.error is not None:
            return
        for name, types in self.get_topic_names_and_types():
            if name in self._subs:
                self._readapt(name)
                continue
            if name in self._ignored:
                continue
            recorded = self.wanted(name)
            if not recorded and not (name == CLOCK_TOPIC and self._sim is not False):
                continue
            publishers = self._offering_publishers(name)
            if not publishers:
                continue
            type_name = types[0]
            if len(types) > 1:
                self.get_logger().warning(f"topic {name} has several types {types}; recording {type_name}")
            try:
                msg_type = message_class(type_name, name)
            except UnknownMessageType as exc:
                self.get_logger().warning(f"not recording: {exc}")
                self._ignored.add(name)
                continue
            offered = [p.qos_profile for p in publishers]
            if recorded:
                tid = self.writer.add_topic(
                    name,
                    type_name,
                    qos_profiles_yaml([offered_qos_dict(q) for q in offered]),
                    str(publishers[0].topic_type_hash),
                )
                missing = self.writer.missing_definitions(tid)
                if missing:
                    self.get_logger().warning(
                        f"topic {name}: no .msg installed for {', '.join(missing)}; "
                        "their definitions are rebuilt from the Python types where installed"
                    )
                self.topic_ids[name] = tid
                if name in _GRAPH_TOPICS:
                    self._graph_topic_ids.add(tid)
            else:
                tid = -1
            qos = adapted_qos(offered)
            self._subs[name] = _Subscribed(
                self._subscribe(msg_type, name, tid, qos),
                msg_type,
                tid,
                qos,
                self.count_publishers(name),
            )
            self.get_logger().info(f"recording {name} [{type_name}]" if recorded else f"following {name} for sim time")

    def _offering_publishers(self, name: str) -> list[Any]:
        return [
            p
            for p in self.get_publishers_info_by_topic(name)
            if p.node_name != self.get_name() or p.node_namespace != self.get_namespace()
        ]

    def _readapt(self, name: str) -> None:
        """Resubscribe if a publisher that joined later needs a laxer QoS (best effort,
        volatile) than the subscription has: it would not be matched otherwise."""
        sub = self._subs[name]
        count = self.count_publishers(name)
        if count == sub.publisher_count:
            return
        sub.publisher_count = count
        offered = [p.qos_profile for p in self._offering_publishers(name)]
        if not offered:
            return
        qos = adapted_qos(offered)
        if (qos.reliability, qos.durability) == (sub.qos.reliability, sub.qos.durability):
            return
        self.get_logger().warning(
            f"{name}: a new publisher offers {qos.reliability.name.lower()}/"
            f"{qos.durability.name.lower()}; resubscribing to receive from it"
        )
        old = sub.subscription
        # Subscribe anew before dropping the old one: nothing falls in between (a message
        # sent in that instant may be recorded twice).
        sub.subscription = self._subscribe(sub.msg_type, name, sub.topic_id, qos)
        sub.qos = qos
        self._retire(old)

    def _retire(self, old: Any) -> None:
        """Drop a subscription; one with event callbacks is muted instead, and lives on until the
        process ends (destroying it under a spinning EventsExecutor can crash the process)."""
        if not self._count_lost:
            self.destroy_subscription(old)
            return
        old.callback = _ignore
        self._retired.append(old)

    def _subscribe(self, msg_type: Any, name: str, tid: int, qos: QoSProfile) -> Any:
        """A raw subscription to ``name``; with ``count_lost``, counting the messages DDS reports lost."""
        callback = self._latched_or_plain(name, tid, qos)
        if not self._count_lost:
            return self.create_subscription(msg_type, name, callback, qos, raw=True)

        def lost(status: Any) -> None:  # rmw_message_lost_status_t (rclpy's stub types it loosely)
            self._on_lost(name, status.total_count_change)

        events = SubscriptionEventCallbacks(message_lost=lost)
        return self.create_subscription(msg_type, name, callback, qos, raw=True, event_callbacks=events)

    def _on_lost(self, name: str, count: int) -> None:
        self.lost[name] = self.lost.get(name, 0) + count
        now = time.monotonic()
        if now - self._lost_warned >= 2.0:  # a recorder falling behind loses many: say so every 2 s
            self._lost_warned = now
            self.get_logger().warning(
                f"{name}: {self.lost[name]} messages lost so far: the recorder fell behind its publisher "
                "(a busy machine?); the counts go into the bag's metadata.yaml"
            )

    # -- messages ------------------------------------------------------------------------

    def _latched_or_plain(self, name: str, tid: int, qos: QoSProfile) -> Callable[[bytes], None]:
        """The topic's callback; for a latched topic it also notes that its message arrived."""
        callback = self._callback(name, tid)
        if qos.durability != DurabilityPolicy.TRANSIENT_LOCAL:
            return callback

        def heard(data: bytes) -> None:
            self._latched_heard.add(name)
            callback(data)

        return heard

    def _callback(self, name: str, tid: int) -> Callable[[bytes], None]:
        write = self._write
        if name != CLOCK_TOPIC:
            return lambda data: write(tid, data)

        progress = self._progress = self._progress or ProgressReporter(self)

        def on_clock(data: bytes) -> None:
            self._sim_ns = clock_ns(data)
            if self._pending and self._sim:
                self._release()
            if tid >= 0:
                write(tid, data)
            progress.handled(self._sim_ns)  # after writing: a world at real_time_factor 0 waits for this

        return on_clock

    def _decide_time_source(self) -> bool:
        """Sim time if a /clock publisher exists when the first data message arrives."""
        self._sim = self.count_publishers(CLOCK_TOPIC) > 0
        self.get_logger().info("recording with sim time from /clock" if self._sim else "recording with wall time")
        return self._sim

    def _write(self, tid: int, data: bytes) -> None:
        if self.error is not None:
            return
        sim = self._sim
        if sim is None:
            # Every node has /rosout and /parameter_events (we do too): their messages say
            # nothing about a simulation running, so they wait for the decision.
            if tid in self._graph_topic_ids:
                self._hold(tid, data)
                return
            sim = self._decide_time_source()
            if self._pending and (not sim or self._sim_ns is not None):
                self._release()
        if sim:
            t = self._sim_ns
            if t is None:  # sim time not known yet: keep until the first /clock
                self._hold(tid, data)
                return
        else:
            t = time.time_ns()
        self._put(tid, t, data)

    def _hold(self, tid: int, data: bytes) -> None:
        if len(self._pending) < _PENDING_LIMIT:
            self._pending.append((tid, data, time.time_ns()))

    def _release(self) -> None:
        """Write held messages: at the current sim time, or at their arrival wall time."""
        pending, self._pending = self._pending, []
        for tid, data, wall_ns in pending:
            self._put(tid, self._sim_ns if self._sim and self._sim_ns is not None else wall_ns, data)

    def _put(self, tid: int, t: int, data: bytes) -> None:
        try:
            self.writer.write(tid, t, data, t)
        except BagWriteError as exc:
            self._fail(exc)

    def _flush_tick(self) -> None:
        if self.error is not None:
            return
        try:
            self.writer.maybe_flush()
        except BagWriteError as exc:
            self._fail(exc)

    def _fail(self, exc: BagWriteError) -> None:
        self.error = exc
        self.get_logger().error(f"{exc}; recording stopped")
        for sub in self._subs.values():
            self.destroy_subscription(sub.subscription)
        self._subs.clear()
        if not self.done.done():
            self.done.set_result(exc)

    def close(self) -> None:
        """Finish the bag (footer, summary, metadata.yaml); safe to call twice."""
        if self._pending and self.error is None:
            # No time source ever showed up for these (no data, or a /clock that never
            # ticked): keep them at their arrival wall time rather than lose them.
            if self._sim_ns is None:
                self._sim = False
            self._release()
        self.writer.close()
        if self.error is None and self.writer.error is not None:
            self.error = self.writer.error
        if self.lost and self.error is None:
            note_lost_messages(self.writer.folder, self.lost)


def note_lost_messages(folder: Path, lost: dict[str, int]) -> None:
    """Put the lost-message counts into a finished bag's metadata.yaml, as rosbag2's
    ``custom_data`` (string to string): ``robot_sims.lost_messages./scan: '12'``."""
    import yaml

    path = Path(folder) / "metadata.yaml"
    info = yaml.safe_load(path.read_text())
    custom = info["rosbag2_bagfile_information"].get("custom_data") or {}
    custom.update({f"{LOST_KEY}.{topic}": str(count) for topic, count in sorted(lost.items())})
    info["rosbag2_bagfile_information"]["custom_data"] = custom
    path.write_text(yaml.safe_dump(info, sort_keys=False, default_flow_style=False))


def wait_for_recorders(executor: Any, nodes: Iterable[Any], world: Any) -> None:
    """Let every :class:`Recorder` among ``nodes`` subscribe to what ``world`` publishes before a
    demo steps it (see :meth:`Recorder.wait_until_recording`)."""
    topics = [publisher.topic_name for publisher in world.publishers]
    for node in nodes:
        if isinstance(node, Recorder):
            node.wait_until_recording(executor, topics)


def default_bag_name(now: datetime | None = None) -> str:
    """`rosbag2_YYYY_MM_DD-HH_MM_SS` (local time), as ros2 bag record names bags."""
    return (now or datetime.now()).strftime("rosbag2_%Y_%m_%d-%H_%M_%S")


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Our command-line flags (ROS arguments already removed)."""
    parser = argparse.ArgumentParser(prog="robot_sims record", description="Record topics into a rosbag2 MCAP bag.")
    parser.add_argument("topics", nargs="*", help="topic names or regular expressions (default: all)")
    parser.add_argument("-o", "--output", help="bag folder to create (default rosbag2_<date-time>)")
    parser.add_argument("-e", "--exclude", help="regular expression of topics not to record")
    parser.add_argument(
        "--compression", choices=("zstd", "lz4", "none"), default="zstd", help="MCAP chunk compression (default zstd)"
    )
    parser.add_argument(
        "-b", "--max-bag-size", type=int, default=0, help="start a new .mcap split after this many bytes (0 = never)"
    )
    parser.add_argument(
        "-d",
        "--max-bag-duration",
        type=float,
        default=0.0,
        help="start a new .mcap split after this many seconds (0 = never)",
    )
    parser.add_argument(
        "--clock",
        choices=("auto", "sim", "wall"),
        default="auto",
        help="message times: sim time from /clock, wall time, or auto (default)",
    )
    parser.add_argument(
        "--reindex",
        metavar="BAG",
        help="recover BAG after a crash (rewrite unfinished .mcap splits, rebuild metadata.yaml) and exit",
    )
    return parser.parse_args(list(argv))


def _output_folder(output: str | None) -> Path:
    if output:
        return Path(output)
    base = default_bag_name()
    folder, n = Path(base), 1
    while folder.exists():  # two recordings started within one second
        folder, n = Path(f"{base}-{n}"), n + 1
    return folder


def main(args: Sequence[str] | None = None) -> int:
    """Entry point; `args` is a full argv (program name first), default sys.argv."""
    ours, ros_argv = split_ros_args(sys.argv if args is None else args)
    opts = parse_args(ours)
    if opts.reindex:
        from sim_runtime.bag.writer import reindex

        print(f"recovered {opts.reindex}: wrote {reindex(opts.reindex)}")
        return 0
    try:
        writer = BagWriter(
            _output_folder(opts.output),
            compression=opts.compression,
            max_bag_size=opts.max_bag_size,
            max_bag_duration_ns=int(opts.max_bag_duration * 1e9),
        )
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        stop = init_ros(ros_argv)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        writer.close()
        shutil.rmtree(writer.folder)  # created a moment ago and empty: leave nothing behind
        return 2
    recorder = None
    try:
        recorder = Recorder(writer, opts.topics, exclude=opts.exclude, clock=opts.clock, count_lost=True)
        executor = make_executor()
        executor.add_node(recorder)
        print(f"recording to {writer.folder} (Ctrl-C to stop)", file=sys.stderr)
        # With no timeout the events executor never returns to Python to see Ctrl-C.
        while stop.running and not recorder.done.done():
            executor.spin_until_future_complete(recorder.done, timeout_sec=0.5)
    except ExternalShutdownException:
        pass
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        writer.close()
        return 2
    finally:
        if recorder is not None:
            recorder.close()
            recorder.destroy_node()
        else:
            writer.close()
        if rclpy.ok():
            rclpy.shutdown()
    if recorder is not None and recorder.error is not None:
        print(f"error: {recorder.error}; the bag holds what was written before", file=sys.stderr)
        return 1
    print(f"wrote {writer.message_count} messages to {writer.folder}", file=sys.stderr)
    if recorder is not None and recorder.lost:
        print(f"warning: {sum(recorder.lost.values())} messages lost on the way (see metadata.yaml)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
