"""The bag targets: seed bags, damaged copies of them, and the tools that read them (the bag reader,
``draw_tracks``, ``bag_to_rerun``, ``replay``).

A bag is no simulator's input file, so these targets are the fuzzer's own; the seed bags imitate a
Create and a SIMROBOT run only by their topic names and message types, which is what the tools
look at."""

from __future__ import annotations

import contextlib
import random
import shutil
from pathlib import Path
from typing import Any

import yaml

from create_sim.spec import MAP_MARKERS_TOPIC, WALLS_NS
from sim_tools.fuzz.corpus import Seeds
from sim_tools.fuzz.nodes import ensure_ros
from sim_tools.fuzz_kit import Case, Defect, mutated_yaml
from sim_tools.fuzz_kit.mutate import mutate_bytes


# ----------------------------------------------------------------------------------------- seeds
def _pose(x: float, y: float) -> Any:
    from geometry_msgs.msg import PoseStamped

    msg = PoseStamped()
    msg.header.frame_id = "map"
    msg.pose.position.x, msg.pose.position.y = x, y
    msg.pose.orientation.w = 1.0
    return msg


def _seed_messages() -> dict[str, Any]:
    """One message of each kind the seed bags hold (a Create's walls, a SIMROBOT grid, a scan, odometry)."""
    from geometry_msgs.msg import Point
    from nav_msgs.msg import OccupancyGrid, Odometry
    from sensor_msgs.msg import LaserScan
    from visualization_msgs.msg import Marker, MarkerArray

    markers = MarkerArray()
    walls = Marker(ns=WALLS_NS, type=5)
    walls.points = [Point(x=0.0, y=0.0), Point(x=2.0, y=0.0), Point(x=2.0, y=0.0), Point(x=2.0, y=2.0)]
    markers.markers = [walls]
    grid = OccupancyGrid()
    grid.info.width, grid.info.height, grid.info.resolution = 8, 6, 0.1
    grid.data = [0, 100] * 24
    scan = LaserScan(angle_min=-1.0, angle_max=1.0, angle_increment=0.5, range_max=4.0)
    scan.ranges = [1.0, 2.0, 3.0, 4.0, 5.0]
    return {"markers": markers, "grid": grid, "scan": scan, "odom": Odometry()}


def _seed_plans() -> dict[str, list[tuple[str, str, Any, str]]]:
    """Bag name → its topics as (name, type, message or None for a moving pose, QoS)."""
    from sim_runtime.bag.writer import qos_profiles_yaml

    m = _seed_messages()
    qos = qos_profiles_yaml([{}])
    latched = qos_profiles_yaml([{"durability": "transient_local", "history": "keep_last", "depth": 1}])
    return {
        "create_run": [
            ("/" + MAP_MARKERS_TOPIC, "visualization_msgs/msg/MarkerArray", m["markers"], latched),
            ("/create/overhead_pose", "geometry_msgs/msg/PoseStamped", None, qos),
            ("/create/odom", "nav_msgs/msg/Odometry", m["odom"], qos),
            ("/create/scan", "sensor_msgs/msg/LaserScan", m["scan"], qos),
        ],
        "simrobot_run": [
            ("/map", "nav_msgs/msg/OccupancyGrid", m["grid"], latched),
            ("/r1/pose", "geometry_msgs/msg/PoseStamped", None, qos),
            ("/r2/odom", "nav_msgs/msg/Odometry", m["odom"], qos),
        ],
        "wrong_types": [
            ("/map", "nav_msgs/msg/OccupancyGrid", _pose(1, 2), latched),
            ("/r1/pose", "geometry_msgs/msg/PoseStamped", m["grid"], qos),
            ("/x/odom", "no_such_pkg/msg/Thing", m["odom"], qos),
            ("/y/pose", "os/path/join", _pose(0, 0), qos),
            ("/z/map_markers", "visualization_msgs/msg/MarkerArray", m["scan"], qos),
        ],
    }


def write_seed_bags(folder: Path) -> None:
    """Small bags by the project's own writer: a Create-like and a SIMROBOT-like run, and one
    whose declared types do not match the data."""
    from rclpy.serialization import serialize_message

    from sim_runtime.bag.writer import BagWriter

    folder.mkdir(parents=True, exist_ok=True)
    for name, topics in _seed_plans().items():
        with BagWriter(folder / name, compression="zstd" if name == "create_run" else "none") as bag:
            ids = [bag.add_topic(topic, kind, q) for topic, kind, _, q in topics]
            for k in range(20):
                for tid, (_topic, _kind, msg, _q) in zip(ids, topics, strict=True):
                    data = serialize_message(msg if msg is not None else _pose(0.1 * k, 0.05 * k))
                    bag.write(tid, 1_000_000_000 + k * 50_000_000, data)


# ---------------------------------------------------------------------------------------- damage
def mutated_bag(rng: random.Random, seeds: Seeds, folder: Path) -> Path:
    """A copy of a seed bag with one kind of damage; returns the path to hand to the tool."""
    bag = folder / "bag"
    shutil.copytree(rng.choice(seeds.bags), bag)
    mcaps = sorted(bag.glob("*.mcap"))
    kind = rng.randrange(7)
    if kind <= 2:  # corrupted bytes anywhere (chunks, records, summary, footer)
        target = rng.choice(mcaps)
        target.write_bytes(mutate_bytes(rng, target.read_bytes()))
    elif kind == 3:  # cut short
        target = rng.choice(mcaps)
        data = target.read_bytes()
        target.write_bytes(data[: rng.randrange(len(data) + 1)])
    elif kind == 4:  # metadata.yaml gone or damaged
        _damage_metadata(rng, bag / "metadata.yaml")
    elif kind == 5:  # files missing, renamed or added
        _damage_splits(rng, bag, rng.choice(mcaps))
    else:  # a bare .mcap file
        target = rng.choice(mcaps)
        target.write_bytes(mutate_bytes(rng, target.read_bytes(), rounds=rng.choice((0, 1, 2))))
        return target
    return bag


def _damage_metadata(rng: random.Random, meta: Path) -> None:
    if rng.random() < 0.5:
        meta.unlink(missing_ok=True)
    elif meta.exists():
        meta.write_text(mutated_yaml(rng, yaml.safe_load(meta.read_text())))


def _damage_splits(rng: random.Random, bag: Path, target: Path) -> None:
    choice = rng.randrange(3)
    if choice == 0:
        target.unlink()
    elif choice == 1:
        target.rename(bag / "renamed_7.mcap")
    else:
        (bag / "extra_1.mcap").write_bytes(mutate_bytes(rng, target.read_bytes()[:200]))


# --------------------------------------------------------------------------------------- targets
def read_bag(path: Path) -> None:
    from sim_runtime.bag.reader import UnknownMessageType, open_bag

    bag = open_bag(path)
    for m in bag.messages():
        with contextlib.suppress(UnknownMessageType):
            m.msg  # noqa: B018 - deserialising is the point


def bag_reader_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    path = mutated_bag(rng, seeds, folder)
    return Case(folder, lambda: read_bag(path))


def _draw_tracks(path: Path, out: Path, draw: bool) -> None:
    from sim_runtime.track_plot import draw_tracks
    from sim_tools.rerun_view.tracks import tracks_from_bag

    data = tracks_from_bag(path)
    for track in data.tracks.values():
        if track.ndim != 2 or track.shape[1:] != (2,):
            raise Defect(f"track has shape {track.shape}")
    if draw and data.tracks:
        draw_tracks(data.image, data.resolution, data.origin, data.tracks, data.colors, out)


def draw_tracks_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    path = mutated_bag(rng, seeds, folder)
    draw = rng.random() < 0.05
    return Case(folder, lambda: _draw_tracks(path, folder / "tracks.png", draw))


def bag_to_rerun_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    from sim_tools.rerun_view.convert import bag_to_rerun

    path = mutated_bag(rng, seeds, folder)
    return Case(folder, lambda: bag_to_rerun(path, folder / "out.rrd", progress=False))


_OPTION_VALUES = ("0", "-1", "1", "1e300", "-1e300", "nan", "inf", "-inf", "1e-300", "x", "", "9" * 400)


def replay_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """``robot_sims replay BAG [options]``: a damaged bag and random command-line options."""
    path = mutated_bag(rng, seeds, folder) if rng.random() < 0.5 else rng.choice(seeds.bags)
    argv = [str(path)]
    for option in ("--rate", "--start-offset", "--duration"):
        if rng.random() < 0.5:
            argv += [option, rng.choice(_OPTION_VALUES)]
    if rng.random() < 0.3:
        argv += ["--topics", rng.choice(("/map", "x", "", "/r1/pose", "//", "/a b"))]
    if rng.random() < 0.3:
        argv += ["--exclude", rng.choice(("(", ".*", "[", "/map", "a{99999999}"))]
    if rng.random() < 0.3:
        argv += ["--remap", rng.choice(("/map:=/m", "x", ":=", "/map:=", "/map:=bad name", "/r1/pose:=//"))]
    (folder / "argv.txt").write_text("\n".join(argv) + "\n", encoding="utf-8")
    return Case(folder, lambda: _replay(argv))


def _replay(argv: list[str]) -> None:
    """What ``replay`` does before it plays: parse options, open the bag, build the player."""
    from sim_runtime.bag.reader import open_bag
    from sim_runtime.bag.replay import Player, _parse_remaps, parse_args
    from sim_runtime.errors import InputError

    try:
        opts = parse_args(argv)
    except SystemExit as exc:  # argparse's own usage error: a clean exit 2 with a message
        if exc.code != 2:
            raise
        raise InputError(f"command line {argv!r}: usage error") from None
    bag = open_bag(opts.bag)
    remap = _parse_remaps(opts.remap)
    ensure_ros()
    player = Player(
        bag,
        rate=opts.rate,
        start_offset=opts.start_offset,
        duration=opts.duration,
        topics=opts.topics,
        exclude=opts.exclude,
        remap=remap,
        node_name="fuzz_player",
    )
    try:
        for _ in player.bag.messages():
            pass
    finally:
        player.destroy_node()
