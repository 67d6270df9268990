"""``robot_sims replay``: play a bag back with its original timing.

Usage::

    robot_sims replay run1                   # a bag folder (or one .mcap file), real time
    robot_sims replay run1 --rate 2 --loop   # twice as fast, over and over
    robot_sims replay run1 --start-offset 10 --duration 5   # bag seconds 10..15
    robot_sims replay run1 --topics /scan /odom --exclude '.*image.*' --remap /scan:=/scan_old
    robot_sims replay run1 --start-paused    # wait for ~/resume or ~/step

Messages are published as recorded (CDR bytes, no re-serialisation) on publishers with the
QoS the original publishers offered (from the bag's ``offered_qos_profiles``: latched maps
stay transient local). Unless the bag holds ``/clock`` itself, the player publishes
``/clock`` from the recorded times (before each message, and every 10 ms of bag time in
gaps), so nodes started with ``use_sim_time:=true`` run against the replay.

Services (relative to the node, default name ``player``): ``~/pause``, ``~/resume``
(std_srvs/Trigger), ``~/set_paused`` (std_srvs/SetBool), ``~/step`` (Trigger: publish the
next message now, while paused). Topics whose type is not installed are skipped with a
warning. From Python, `play_bag(...)` plays a bag in-process (tests use it).
"""

from __future__ import annotations

import argparse
import math
import queue
import re
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from statistics import median
from typing import Any

import rclpy
from rclpy.exceptions import InvalidTopicNameException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rclpy.validate_topic_name import validate_topic_name
from rosgraph_msgs.msg import Clock
from std_srvs.srv import SetBool, Trigger

from sim_runtime.bag.reader import Bag, BagMessage, UnknownMessageType, message_class, open_bag
from sim_runtime.errors import InputError
from sim_runtime.run import init_ros, make_executor, split_ros_args
from sim_runtime.yamlfile import parse_yaml

__all__ = ["PlayStats", "Player", "main", "play_bag", "replay_qos"]

CLOCK_TOPIC = "/clock"
_CLOCK_TICK_NS = 10_000_000
_BATCH = 64  # messages handed from the reading thread to the playing thread at a time
_READ_AHEAD = 64  # batches
#: GIL switch interval main() sets so the timing thread wakes promptly while the reading
#: thread decodes chunks (Python's default 5 ms would be the worst-case lateness).
SWITCH_INTERVAL = 0.0005
# Within this of a deadline, time.sleep (precise) instead of a condition wait (wakeable).
_FINE_NS = 2_000_000
# How long stop() waits for the playing thread (its waits are bounded at 0.1 s: this is a ceiling).
_STOP_JOIN_S = 5.0


def replay_qos(offered_yaml: str) -> QoSProfile:
    """Publisher QoS from a topic's recorded offered_qos_profiles (rosbag2 YAML)."""
    try:  # a bag is a file like any other: an alias bomb here is refused, not expanded
        profiles = parse_yaml(offered_yaml, "offered_qos_profiles") or []
    except InputError:
        profiles = []
    if not isinstance(profiles, list):
        profiles = []
    profiles = [p for p in profiles if isinstance(p, dict)]

    def all_are(key: str, value: str) -> bool:
        return bool(profiles) and all(str(p.get(key, "")).lower() == value for p in profiles)

    latched = all_are("durability", "transient_local")
    depths = [int(p.get("depth") or 0) for p in profiles if p.get("history") == "keep_last"]
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=max(depths) if depths and max(depths) > 0 else (1 if latched else 10),
        reliability=(
            ReliabilityPolicy.BEST_EFFORT if all_are("reliability", "best_effort") else ReliabilityPolicy.RELIABLE
        ),
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


@dataclass
class PlayStats:
    """What a replay did: messages published and how late each was against its schedule."""

    published: int = 0
    lateness_ns: list[int] = field(default_factory=list)

    @property
    def median_lateness_ms(self) -> float:
        """Median of how late messages went out against their scheduled wall time, in ms."""
        return median(self.lateness_ns) / 1e6 if self.lateness_ns else 0.0


class Player(Node):
    """Publishes a bag's messages from a timing thread; services pause/resume/step it.

    Call `start()` after adding the node to a spinning executor; `finished` (a Future)
    completes when the last message is out (never, with `loop`), `stop()` ends early.
    """

    def __init__(
        self,
        bag: Bag,
        *,
        rate: float = 1.0,
        loop: bool = False,
        start_offset: float = 0.0,
        duration: float | None = None,
        topics: Sequence[str] | None = None,
        exclude: str | None = None,
        remap: dict[str, str] | None = None,
        start_paused: bool = False,
        node_name: str = "player",
        **node_kwargs: Any,
    ) -> None:
        # Options are checked before the node exists: a refused player leaves nothing in the graph.
        if not rate > 0:
            raise InputError(f"--rate {rate}: must be > 0")
        if not (0 <= start_offset * 1e9 < math.inf) or (duration is not None and not duration >= 0):
            raise InputError(f"--start-offset {start_offset} / --duration {duration}: must be ≥ 0 (offset finite)")
        try:
            excluded = re.compile(exclude) if exclude else None
        except re.error as exc:
            raise InputError(f"--exclude {exclude!r}: {exc}") from None
        super().__init__(node_name, **node_kwargs)
        self.bag = bag
        self.rate = rate
        self.loop = loop
        self._begin = bag.start_ns + int(start_offset * 1e9)
        endless = duration is None or math.isinf(duration * 1e9)
        self._end = None if duration is None or endless else self._begin + int(duration * 1e9)
        try:
            self._make_publishers(bag, topics, excluded, remap or {})
        except BaseException:
            self.destroy_node()  # e.g. a remapped name rcl refuses: no half-built node lingers
            raise
        self.stats = PlayStats()
        self.finished = Future()
        self._cond = threading.Condition()
        self._paused = start_paused
        self._steps = 0
        self._stop = False
        self._thread: threading.Thread | None = None
        self.create_service(Trigger, "~/pause", self._srv_pause)
        self.create_service(Trigger, "~/resume", self._srv_resume)
        self.create_service(SetBool, "~/set_paused", self._srv_set_paused)
        self.create_service(Trigger, "~/step", self._srv_step)

    def _make_publishers(
        self, bag: Bag, topics: Sequence[str] | None, excluded: re.Pattern[str] | None, remap: dict[str, str]
    ) -> None:
        wanted = None if not topics else {t if t.startswith("/") else "/" + t for t in topics}
        self._publishers_by_topic: dict[str, Any] = {}
        for topic, type_name in sorted(bag.topics.items()):
            if (wanted is not None and topic not in wanted) or (excluded is not None and excluded.fullmatch(topic)):
                continue
            try:
                msg_type = message_class(type_name, topic)
            except UnknownMessageType as exc:
                self.get_logger().warning(f"skipping topic: {exc}")
                continue
            qos = replay_qos(bag.topic_metadata.get(topic, {}).get("offered_qos_profiles", ""))
            self._publishers_by_topic[topic] = self.create_publisher(msg_type, remap.get(topic, topic), qos)
        self._clock_pub = (
            None if CLOCK_TOPIC in self._publishers_by_topic else self.create_publisher(Clock, CLOCK_TOPIC, 10)
        )

    @property
    def topic_publishers(self) -> dict[str, Any]:
        """Bag topic → publisher (tests wait for these to be matched)."""
        return dict(self._publishers_by_topic)

    @property
    def paused(self) -> bool:
        """Whether playback is paused."""
        return self._paused

    # -- control -------------------------------------------------------------------------

    def set_paused(self, paused: bool) -> None:
        """Pause or resume; on resume the timeline continues where it stopped."""
        with self._cond:
            self._paused = paused
            self._cond.notify_all()

    def step(self) -> None:
        """Publish the next message now (meant for a paused player)."""
        with self._cond:
            self._steps += 1
            self._cond.notify_all()

    def stop(self) -> None:
        """Stop playback and wait for the player thread to end."""
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            # Every wait of the playing thread is bounded (≤ 0.1 s) and looks at `_stop`.
            self._thread.join(timeout=_STOP_JOIN_S)
            if self._thread.is_alive():
                self.get_logger().error(f"replay: the player thread did not end within {_STOP_JOIN_S} s of stop()")

    def _srv_pause(self, _req: Any, res: Any) -> Any:
        self.set_paused(True)
        res.success, res.message = True, "paused"
        return res

    def _srv_resume(self, _req: Any, res: Any) -> Any:
        self.set_paused(False)
        res.success, res.message = True, "playing"
        return res

    def _srv_set_paused(self, req: Any, res: Any) -> Any:
        self.set_paused(bool(req.data))
        res.success, res.message = True, "paused" if req.data else "playing"
        return res

    def _srv_step(self, _req: Any, res: Any) -> Any:
        self.step()
        res.success, res.message = True, "stepped"
        return res

    # -- playback ------------------------------------------------------------------------

    def start(self) -> None:
        """Start playing in a background thread (``finished`` completes at the end)."""
        self._thread = threading.Thread(target=self._run, name="bag-player", daemon=True)
        self._thread.start()

    def _messages(self) -> Iterator[BagMessage]:
        """The messages to play, read ahead by a thread so chunk decoding never delays one.

        Neither side waits without a timeout: either may see `stop()` first (the reader may
        return without its end mark), and a pass abandoned early (stop, an error) ends its reader.
        """
        batches: queue.Queue[list[BagMessage] | BaseException | None] = queue.Queue(maxsize=_READ_AHEAD)
        abandoned = threading.Event()

        def put(item: list[BagMessage] | BaseException | None) -> bool:
            while not (self._stop or abandoned.is_set()):
                try:
                    batches.put(item, timeout=0.1)
                    return True
                except queue.Full:
                    continue
            return False

        def read() -> None:
            batch: list[BagMessage] = []
            try:
                for m in self.bag.messages(topics=list(self._publishers_by_topic), start=self._begin, end=self._end):
                    batch.append(m)
                    if len(batch) >= _BATCH:
                        if not put(batch):
                            return
                        batch = []
                if put(batch):
                    put(None)
            except BaseException as exc:
                put(exc)

        threading.Thread(target=read, name="bag-reader", daemon=True).start()
        try:
            while True:
                try:
                    item = batches.get(timeout=0.1)
                except queue.Empty:
                    if self._stop:
                        return
                    continue
                if item is None:
                    return
                if isinstance(item, BaseException):
                    raise item
                yield from item
        finally:
            abandoned.set()

    def _wait(self, bag_ns: int, consume_step: bool = True) -> str:
        """Sleep until bag time `bag_ns` is due, unless paused, stepped or stopped.

        Returns 'due', 'step' or 'stop'; pausing shifts the schedule by the pause length.
        """
        while True:
            with self._cond:
                if self._stop:
                    return "stop"
                if self._steps:
                    self._steps -= consume_step
                    return "step"
                if self._paused:
                    paused_at = time.perf_counter_ns()
                    while self._paused and not self._stop and not self._steps:
                        self._cond.wait(0.1)
                    self._origin_wall += time.perf_counter_ns() - paused_at
                    continue
            now = time.perf_counter_ns()
            target = self._wall(bag_ns)
            remaining = target - now
            if remaining <= 0:
                return "due"
            if remaining > _FINE_NS:
                # Coarse: wake early, or at once on pause/step/stop.
                with self._cond:
                    self._cond.wait(min(remaining - _FINE_NS, 50_000_000) / 1e9)
            else:
                # Fine: a plain sleep overshoots ~0.1 ms, a condition wait several times that.
                time.sleep(remaining / 1e9)

    def _wall(self, bag_ns: int) -> int:
        return self._origin_wall + int((bag_ns - self._origin_bag) / self.rate)

    def _publish_clock(self, bag_ns: int) -> None:
        if self._clock_pub is not None and bag_ns > self._last_clock:
            msg = Clock()
            msg.clock.sec, msg.clock.nanosec = divmod(bag_ns, 1_000_000_000)
            self._clock_pub.publish(msg)
            self._last_clock: int = bag_ns  # bag time of the last /clock sent (-1: none yet)

    def _run(self) -> None:
        try:
            while True:
                self._origin_bag = self._begin
                self._origin_wall = time.perf_counter_ns()
                self._last_clock = -1
                self._publish_clock(self._begin)
                for m in self._messages():
                    # /clock ticks through gaps so sim-time timers keep firing
                    while self._clock_pub is not None and self._last_clock + _CLOCK_TICK_NS < m.log_time_ns:
                        tick = self._last_clock + _CLOCK_TICK_NS
                        how = self._wait(tick, consume_step=False)
                        if how == "stop":
                            return
                        if how == "step":  # a step goes straight to the next message
                            break
                        self._publish_clock(tick)
                    how = self._wait(m.log_time_ns)
                    if how == "stop":
                        return
                    if how == "step":  # continue the schedule from this message
                        self._origin_bag = m.log_time_ns
                        self._origin_wall = time.perf_counter_ns()
                    self._publish_clock(m.log_time_ns)
                    self._publishers_by_topic[m.topic].publish(m.data)
                    self.stats.published += 1
                    if how == "due":
                        self.stats.lateness_ns.append(time.perf_counter_ns() - self._wall(m.log_time_ns))
                if not self.loop or self._stop:  # a pass may end on stop() without a _wait seeing it
                    return
        except Exception as exc:
            self.get_logger().error(f"replay failed: {exc!r}")
            if not self.finished.done():
                self.finished.set_exception(exc)
        finally:
            if not self.finished.done():
                self.finished.set_result(self.stats)


def play_bag(
    bag: str | Path | Bag,
    executor: Any = None,
    *,
    wait_for_subscribers: int = 0,
    match_timeout: float = 10.0,
    **options: Any,
) -> PlayStats:
    """Play `bag` to the end in this process and return its PlayStats.

    `executor`: a (spinning-by-us) rclpy executor to add the player to (default: a new one;
    rclpy must be initialised). `wait_for_subscribers`: before starting, wait until every
    replayed topic has that many subscribers (so nothing is lost to discovery).
    `options` go to `Player` (rate, loop, start_offset, duration, topics, exclude, remap, …).
    """
    bag = bag if isinstance(bag, Bag) else open_bag(bag)
    own_executor = executor is None
    executor = executor or make_executor()
    player = Player(bag, **options)
    executor.add_node(player)
    try:
        if wait_for_subscribers:
            deadline = time.monotonic() + match_timeout
            while not subscribed(player, wait_for_subscribers):
                if time.monotonic() > deadline:
                    raise TimeoutError(f"replay: subscribers did not match within {match_timeout} s")
                executor.spin_once(timeout_sec=0.01)
        player.start()
        while not player.finished.done():
            executor.spin_until_future_complete(player.finished, timeout_sec=0.1)
        stats: PlayStats = player.finished.result()  # rclpy's Future is not generic
        return stats
    finally:
        player.stop()
        executor.remove_node(player)
        player.destroy_node()
        if own_executor:
            executor.shutdown()


def _parse_remaps(items: Sequence[str]) -> dict[str, str]:
    remap = {}
    for item in items:
        old, sep, new = item.partition(":=")
        if not sep or not old or not new:
            raise InputError(f"--remap {item!r}: expected OLD:=NEW")
        try:
            validate_topic_name(new)
        except InvalidTopicNameException as exc:
            raise InputError(
                f"--remap {item!r}: {new!r} is not a valid topic name ({str(exc).splitlines()[0]})"
            ) from None
        remap[old if old.startswith("/") else "/" + old] = new
    return remap


def subscribed(player: Player, count: int) -> bool:
    """Whether each of the player's topics has ``count`` subscriptions matched by its publisher
    (the publisher's own view: a subscriber that already sees the publisher may not yet be seen
    by it, and what it publishes meanwhile reaches no one)."""
    return all(p.get_subscription_count() >= count for p in player.topic_publishers.values())


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="robot_sims replay", description="Play back a bag.")
    parser.add_argument("bag", help="bag folder or .mcap file")
    parser.add_argument("-r", "--rate", type=float, default=1.0, help="playback speed factor")
    parser.add_argument("-l", "--loop", action="store_true", help="play again and again")
    parser.add_argument("--start-offset", type=float, default=0.0, metavar="S", help="start S seconds into the bag")
    parser.add_argument("--duration", type=float, default=None, metavar="D", help="play only D seconds of the bag")
    parser.add_argument("--topics", nargs="+", default=None, help="only these topics")
    parser.add_argument("--exclude", help="regular expression of topics not to play")
    parser.add_argument("--remap", nargs="+", default=[], metavar="OLD:=NEW", help="publish topic OLD as NEW")
    parser.add_argument(
        "--start-paused", action="store_true", help="start paused (use the ~/resume or ~/step services)"
    )
    parser.add_argument(
        "--wait-for-subscribers",
        type=int,
        default=0,
        metavar="N",
        help="before playing, wait (Ctrl-C stops it) until every topic's publisher has matched N subscribers",
    )
    return parser.parse_args(list(argv))


def main(args: Sequence[str] | None = None) -> int:
    """Entry point; `args` is a full argv (program name first), default sys.argv."""
    ours, ros_argv = split_ros_args(sys.argv if args is None else args)
    opts = parse_args(ours)
    try:
        bag = open_bag(opts.bag)
        remap = _parse_remaps(opts.remap)
        stop = init_ros(ros_argv)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    sys.setswitchinterval(SWITCH_INTERVAL)
    player = None
    try:
        player = Player(
            bag,
            rate=opts.rate,
            loop=opts.loop,
            start_offset=opts.start_offset,
            duration=opts.duration,
            topics=opts.topics,
            exclude=opts.exclude,
            remap=remap,
            start_paused=opts.start_paused,
        )
        executor = make_executor()
        executor.add_node(player)
        if opts.wait_for_subscribers > 0:
            print(f"waiting for {opts.wait_for_subscribers} subscriber(s) on every topic", file=sys.stderr)
            while stop.running and not subscribed(player, opts.wait_for_subscribers):
                executor.spin_once(timeout_sec=0.05)
        print(f"playing {bag}", file=sys.stderr)
        player.start()
        # A timeout lets the events executor return to Python so Ctrl-C is seen.
        while stop.running and not player.finished.done():
            executor.spin_until_future_complete(player.finished, timeout_sec=0.5)
    except ExternalShutdownException:
        pass
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    finally:
        if player is not None:
            player.stop()
            stats = player.stats
            print(
                f"published {stats.published} messages, median lateness {stats.median_lateness_ms:.3f} ms",
                file=sys.stderr,
            )
            player.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
