"""What the fuzzer feeds and how each input is judged.

Each target makes one input from seeds (files written into a case folder, so a defect can be
saved and replayed) and runs it the way a user's program would: load the file(s); if that
succeeds, build the model and step it a few times with random commands, requiring finite
state. Loading may also fail, but only with :class:`~sim_runtime.errors.InputError`.
"""

from __future__ import annotations

import contextlib
import os
import random
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sim_runtime.paths import config_path
from sim_tools.fuzz.mutate import dump_yaml, mutate_bytes, mutate_text, mutate_tree
from sim_tools.node_help import NODE_EXECUTABLES


class Defect(AssertionError):
    """An input loaded but the model misbehaved (non-finite state, wrong shape)."""


def _finite(values: Any, what: str) -> None:
    arr = np.asarray(values, dtype=float)
    if not np.isfinite(arr).all():
        raise Defect(f"{what} is not finite: {arr.ravel()[:8]}")


# ----------------------------------------------------------------------------------------- seeds
@dataclass
class Seeds:
    """Seed inputs, read once per process from the seed folder."""

    folder: Path
    maps: list[str]
    configs: list[str]
    worlds: list[Any]
    images: list[Path]
    arm_configs: list[Any]
    scenes: list[Any]
    stls: list[bytes]
    bags: list[Path]

    @classmethod
    def load(cls, folder: Path) -> Seeds:
        text = lambda p: p.read_text(encoding="utf-8")  # noqa: E731
        return cls(
            folder=folder,
            maps=[text(p) for p in sorted(folder.glob("maps/*"))],
            configs=[text(p) for p in sorted(folder.glob("configs/*"))],
            worlds=[yaml.safe_load(text(p)) for p in sorted(folder.glob("worlds/*.yaml"))],
            images=sorted(folder.glob("images/*")),
            arm_configs=[yaml.safe_load(text(p)) for p in sorted(folder.glob("arm/*.yaml"))],
            scenes=[yaml.safe_load(text(p)) for p in sorted(folder.glob("scenes/*.yaml"))],
            stls=[p.read_bytes() for p in sorted(folder.glob("stl/*.stl"))],
            bags=sorted(p for p in folder.glob("bags/*") if p.is_dir()),
        )


def prepare_seeds(folder: Path) -> None:
    """Write the seed corpus: the shipped config files plus small generated images, meshes and bags."""
    from PIL import Image

    from arm_sim.stl import write_stl

    folder.mkdir(parents=True, exist_ok=True)
    for sub in ("maps", "configs", "worlds", "images", "arm", "scenes", "stl", "bags"):
        (folder / sub).mkdir(exist_ok=True)
    shutil.copy(config_path("create/example.map"), folder / "maps/example.map")
    (folder / "maps/corner.map").write_text(
        "% a free wall end, a line, a beacon, a virtual wall\n"
        "wall 2.45 0.55 2.45 2.0\nwall -1 -1 3 -1\nline 0 0.3 2 0.3\nbeacon 1 1 [1 0 0] b1\nvirtwall 0 1 0 2\n"
    )
    for name in ("example_config.txt", "ideal_config.txt"):
        shutil.copy(config_path(f"create/{name}"), folder / f"configs/{name}")
    shutil.copy(config_path("simrobot/demo.yaml"), folder / "worlds/demo.yaml")
    shutil.copy(config_path("simrobot/demo_map.png"), folder / "images/demo_map.png")
    (folder / "worlds/small.yaml").write_text(
        "map: small.png\nresolution: 0.01\ndt: 1.0\nsteps_limit: 20\nrobots:\n"
        "  - {name: a, position: [0.2, 0.2], heading: 45, controller: avoid, sensors: "
        "[{name: s, type: laser, range: 0.3, resolution: 5}]}\n"
        "  - {name: b, position: [0.45, 0.45], R: 0.02, la: 0.04, lb: 0.01, scale: 0.5}\n"
    )
    rng = np.random.default_rng(0)
    pixels = np.full((64, 64), 255, np.uint8)  # small.png beside small.yaml is written below
    pixels[0, :] = pixels[-1, :] = pixels[:, 0] = pixels[:, -1] = 0
    pixels[rng.integers(0, 64, 40), rng.integers(0, 64, 40)] = 0
    img = Image.fromarray(pixels)
    img.convert("1").save(folder / "images/small_1bit.bmp")
    img.save(folder / "images/small_grey.png")
    img.save(folder / "worlds/small.png")
    img.convert("P").save(folder / "images/small_palette.png")
    img.convert("RGB").save(folder / "images/small_rgb.bmp")
    Image.fromarray(pixels.astype(np.uint16) * 257).save(folder / "images/small_16bit.png")
    for name in ("irb120.yaml", "csa7.yaml"):
        raw = yaml.safe_load(config_path(f"arm/{name}").read_text())
        raw["mesh_folder"] = str((config_path("arm") / raw.get("mesh_folder", ".")).resolve())
        (folder / f"arm/{name}").write_text(yaml.safe_dump(raw, sort_keys=False))
    scene = yaml.safe_load(config_path("arm/workcell.yaml").read_text())
    for obj in scene.get("objects", []):
        obj["mesh"] = str((config_path("arm") / obj["mesh"]).resolve())
    for arm in scene.get("arms", []):
        arm["config"] = str((folder / "arm" / arm["config"]).resolve())
    (folder / "scenes/workcell.yaml").write_text(yaml.safe_dump(scene, sort_keys=False))
    tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    tris = tetra[np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])]
    write_stl(folder / "stl/tetra_binary.stl", tris)
    write_stl(folder / "stl/tetra_ascii.stl", tris, ascii=True)
    shutil.copy(config_path("arm/meshes/scene/box.stl"), folder / "stl/box.stl")
    shutil.copy(config_path("arm/meshes/irb120/IRB120_base.stl"), folder / "stl/irb120_base.stl")
    _write_seed_bags(folder / "bags")


def _write_seed_bags(folder: Path) -> None:
    """Small bags by the project's own writer: a Create-like and a SIMROBOT-like run, and one
    whose declared types do not match the data."""
    from geometry_msgs.msg import Point, PoseStamped
    from nav_msgs.msg import OccupancyGrid, Odometry
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import LaserScan
    from visualization_msgs.msg import Marker, MarkerArray

    from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml

    def pose(x: float, y: float) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = "map"
        msg.pose.position.x, msg.pose.position.y = x, y
        msg.pose.orientation.w = 1.0
        return msg

    markers = MarkerArray()
    walls = Marker(ns="walls", type=5)
    walls.points = [Point(x=0.0, y=0.0), Point(x=2.0, y=0.0), Point(x=2.0, y=0.0), Point(x=2.0, y=2.0)]
    markers.markers = [walls]
    grid = OccupancyGrid()
    grid.info.width, grid.info.height, grid.info.resolution = 8, 6, 0.1
    grid.data = [0, 100] * 24
    scan = LaserScan(angle_min=-1.0, angle_max=1.0, angle_increment=0.5, range_max=4.0)
    scan.ranges = [1.0, 2.0, 3.0, 4.0, 5.0]
    odom = Odometry()
    qos = qos_profiles_yaml([{}])
    latched = qos_profiles_yaml([{"durability": "transient_local", "history": "keep_last", "depth": 1}])
    plans: dict[str, list[tuple[str, str, Any, str]]] = {
        "create_run": [
            ("/map_markers", "visualization_msgs/msg/MarkerArray", markers, latched),
            ("/create/overhead_pose", "geometry_msgs/msg/PoseStamped", None, qos),
            ("/create/odom", "nav_msgs/msg/Odometry", odom, qos),
            ("/create/scan", "sensor_msgs/msg/LaserScan", scan, qos),
        ],
        "simrobot_run": [
            ("/map", "nav_msgs/msg/OccupancyGrid", grid, latched),
            ("/r1/pose", "geometry_msgs/msg/PoseStamped", None, qos),
            ("/r2/odom", "nav_msgs/msg/Odometry", odom, qos),
        ],
        "wrong_types": [
            ("/map", "nav_msgs/msg/OccupancyGrid", pose(1, 2), latched),
            ("/r1/pose", "geometry_msgs/msg/PoseStamped", grid, qos),
            ("/x/odom", "no_such_pkg/msg/Thing", odom, qos),
            ("/y/pose", "os/path/join", pose(0, 0), qos),
            ("/z/map_markers", "visualization_msgs/msg/MarkerArray", scan, qos),
        ],
    }
    for name, topics in plans.items():
        with BagWriter(folder / name, compression="zstd" if name == "create_run" else "none") as bag:
            ids = [bag.add_topic(topic, kind, q) for topic, kind, _, q in topics]
            for k in range(20):
                for tid, (_topic, _kind, msg, _q) in zip(ids, topics, strict=True):
                    data = serialize_message(msg if msg is not None else pose(0.1 * k, 0.05 * k))
                    bag.write(tid, 1_000_000_000 + k * 50_000_000, data)


# ----------------------------------------------------------------------------------------- cases
@dataclass
class Case:
    """One input: its files in ``folder`` and how to run it."""

    folder: Path
    run: Callable[[], object]  # what it returns is ignored; only how it ends counts
    note: str = ""


def _text(rng: random.Random, seeds: list[str]) -> str:
    return mutate_text(rng, rng.choice(seeds), seeds)


def _yaml_text(rng: random.Random, tree: Any) -> str:
    """A mutated YAML document: tree edits, then (sometimes) text edits of the dump."""
    text = dump_yaml(mutate_tree(rng, tree) if rng.random() < 0.75 else tree)
    if rng.random() < 0.4:
        text = mutate_text(rng, text)
    return text


def _drive_create(rng: random.Random, map_path: Path, config_path_: Path | None) -> None:
    from create_sim.configfile import load_config
    from create_sim.mapfile import load_map
    from create_sim.model import CreateModel
    from sim_runtime.errors import InputError

    world = load_map(map_path)
    noise = load_config(config_path_) if config_path_ is not None else None
    robot = None
    for pose in ((0.0, 0.0, 0.0), (1.0, 0.5, 1.0), (-5.0, 7.0, -2.0), (100.0, 100.0, 0.0)):
        try:
            robot = CreateModel(world, noise, np.random.default_rng(rng.randrange(2**32)), pose=pose)
            break
        except InputError as exc:
            if "inside a wall" not in str(exc):
                raise
    if robot is None:
        return
    for _ in range(5):
        robot.set_velocity(rng.uniform(-1.0, 1.0), rng.uniform(-5.0, 5.0))
        robot.step(rng.choice((0.01, 0.1, 1.0)))
        _finite(robot.pose, "Create pose")
        _finite(robot.odometry_pose, "Create odometry")
        scan = robot.lidar()
        if np.isnan(scan).any() or scan.shape != (681,):
            raise Defect(f"LIDAR scan has NaN or shape {scan.shape}")
        if np.isnan(robot.sonar()).any() or np.isnan(robot.cliff_signals()).any():
            raise Defect("sonar or cliff reading is NaN")
        robot.bumps(), robot.wall_sensor(), robot.virtual_wall()
        for sighting in robot.camera():
            _finite([sighting.distance, sighting.angle], "camera sighting")
        if robot.clearance() < -1e-9:
            raise Defect(f"robot inside a wall at {robot.pose}")


def create_map_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    (folder / "case.map").write_text(_text(rng, seeds.maps), encoding="utf-8")
    config = folder / "case_config.txt"
    config.write_text(rng.choice(seeds.configs), encoding="utf-8")
    return Case(folder, lambda: _drive_create(rng, folder / "case.map", config))


def create_config_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    (folder / "case.map").write_text(rng.choice(seeds.maps), encoding="utf-8")
    (folder / "case_config.txt").write_text(_text(rng, seeds.configs), encoding="utf-8")
    return Case(folder, lambda: _drive_create(rng, folder / "case.map", folder / "case_config.txt"))


def _drive_simrobot(rng: random.Random, world_path: Path) -> None:
    from simrobot_sim.model import SimrobotWorld
    from simrobot_sim.world_file import load_world

    world = SimrobotWorld(load_world(world_path))
    for _ in range(3):
        for i in range(len(world.names)):
            world.set_cmd_vel(i, rng.uniform(-0.2, 0.2), rng.uniform(-2.0, 2.0))
        world.step()
        world.sense()
        _finite(world.poses(), "SIMROBOT poses")


def simrobot_world_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    image = rng.choice(seeds.images)
    tree = rng.choice(seeds.worlds)
    tree = dict(tree) if isinstance(tree, dict) else tree
    if isinstance(tree, dict) and image.name != "demo_map.png":
        tree["map"] = "case_map" + image.suffix
    shutil.copy(image, folder / ("case_map" + image.suffix))
    shutil.copy(seeds.folder / "images/demo_map.png", folder / "demo_map.png")
    shutil.copy(seeds.folder / "images/small_grey.png", folder / "small.png")
    (folder / "case.yaml").write_text(_yaml_text(rng, tree), encoding="utf-8")
    return Case(folder, lambda: _drive_simrobot(rng, folder / "case.yaml"))


def simrobot_bitmap_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    image = rng.choice([p for p in seeds.images if p.name != "demo_map.png"] or seeds.images)
    name = "case_map" + (image.suffix if rng.random() < 0.9 else rng.choice((".png", ".bmp", ".jpg", "")))
    (folder / name).write_bytes(mutate_bytes(rng, image.read_bytes()))
    (folder / "case.yaml").write_text(
        f"map: {name}\nresolution: 0.01\nrobots:\n  - {{name: a, position: [0.2, 0.2], "
        "sensors: [{name: s, type: laser, range: 0.2, resolution: 4}]}\n",
        encoding="utf-8",
    )
    return Case(folder, lambda: _drive_simrobot(rng, folder / "case.yaml"))


def _drive_arm(rng: random.Random, path: Path) -> None:
    from arm_sim.arm import Arm
    from arm_sim.motion import JointMotion

    arm = Arm.from_file(path, load_meshes=rng.random() < 0.3, skip_missing_meshes=rng.random() < 0.5)
    q = arm.mid_range()
    _finite(arm.fkine(q), "forward kinematics")
    _finite(arm.rne(q, np.zeros(arm.n), np.zeros(arm.n)), "inverse dynamics")
    motion = JointMotion(q, arm.lower, arm.upper, arm.velocity_limits)
    motion.move_to(np.array([rng.uniform(lo, hi) for lo, hi in zip(arm.lower, arm.upper, strict=True)]))
    for _ in range(3):
        motion.step(0.05)
        position, _velocity, _ = motion.reference(0.05)
        _finite(position, "joint motion")
    for element in arm.elements:
        _finite(element.triangles, "mesh triangles")


def arm_config_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    (folder / "robot.yaml").write_text(_yaml_text(rng, rng.choice(seeds.arm_configs)), encoding="utf-8")
    return Case(folder, lambda: _drive_arm(rng, folder / "robot.yaml"))


def _load_scene(path: Path) -> None:
    from arm_sim.scene import load_scene

    scene = load_scene(path)
    for obj in scene.objects:
        _finite(obj.triangles, "scene object triangles")
        _finite(obj.pose, "scene object pose")


def scene_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    (folder / "scene.yaml").write_text(_yaml_text(rng, rng.choice(seeds.scenes)), encoding="utf-8")
    return Case(folder, lambda: _load_scene(folder / "scene.yaml"))


def _load_stl(path: Path) -> None:
    from arm_sim.stl import load_stl

    tris = load_stl(path)
    if tris.ndim != 3 or tris.shape[1:] != (3, 3):
        raise Defect(f"STL triangles have shape {tris.shape}")
    _finite(tris, "STL triangles")


def stl_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    data = rng.choice(seeds.stls)
    if data.startswith(b"solid") and rng.random() < 0.5:
        data = mutate_text(rng, data.decode("ascii", "replace")).encode("utf-8", "replace")
    else:
        data = mutate_bytes(rng, data)
    (folder / "mesh.stl").write_bytes(data)
    return Case(folder, lambda: _load_stl(folder / "mesh.stl"))


# ------------------------------------------------------------------------------------------ bags
def _mutated_bag(rng: random.Random, seeds: Seeds, folder: Path) -> Path:
    """A copy of a seed bag with one kind of damage; returns the path to hand to the tool."""
    source = rng.choice(seeds.bags)
    bag = folder / "bag"
    shutil.copytree(source, bag)
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
        meta = bag / "metadata.yaml"
        if rng.random() < 0.5:
            meta.unlink(missing_ok=True)
        elif meta.exists():
            meta.write_text(_yaml_text(rng, yaml.safe_load(meta.read_text())))
    elif kind == 5:  # files missing, renamed or added
        target = rng.choice(mcaps)
        choice = rng.randrange(3)
        if choice == 0:
            target.unlink()
        elif choice == 1:
            target.rename(bag / "renamed_7.mcap")
        else:
            (bag / "extra_1.mcap").write_bytes(mutate_bytes(rng, target.read_bytes()[:200]))
    else:  # a bare .mcap file
        target = rng.choice(mcaps)
        target.write_bytes(mutate_bytes(rng, target.read_bytes(), rounds=rng.choice((0, 1, 2))))
        return target
    return bag


def _read_bag(path: Path) -> None:
    from sim_runtime.bag.reader import UnknownMessageType, open_bag

    bag = open_bag(path)
    for m in bag.messages():
        with contextlib.suppress(UnknownMessageType):
            m.msg  # noqa: B018 - deserialising is the point


def bag_reader_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    path = _mutated_bag(rng, seeds, folder)
    return Case(folder, lambda: _read_bag(path))


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
    path = _mutated_bag(rng, seeds, folder)
    draw = rng.random() < 0.05
    return Case(folder, lambda: _draw_tracks(path, folder / "tracks.png", draw))


def bag_to_rerun_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    from sim_tools.rerun_view.convert import bag_to_rerun

    path = _mutated_bag(rng, seeds, folder)
    return Case(folder, lambda: bag_to_rerun(path, folder / "out.rrd", progress=False))


_OPTION_VALUES = ("0", "-1", "1", "1e300", "-1e300", "nan", "inf", "-inf", "1e-300", "x", "", "9" * 400)


def replay_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """``robot_sims replay BAG [options]``: a damaged bag and random command-line options."""
    path = _mutated_bag(rng, seeds, folder) if rng.random() < 0.5 else rng.choice(seeds.bags)
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
    _ensure_ros()
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


#: Executable → its world node class, as ``module:Class`` (what ``robot_sims <exe>`` builds).
_WORLD_NODES = {exe: NODE_EXECUTABLES[exe][0] for exe in ("create_world", "simrobot_world", "arm")}
_PARAMETER_VALUES = (
    *("0", "-1", "1", "0.5", "1e300", "-1e300", ".nan", ".inf", "-.inf", "1e-300", "9" * 400, "-" + "9" * 30),
    *("true", "false", "''", "abc", "[]", "[1.0, 2.0]", "[.nan, 0.0, 0.0]", "[1e300, 0.0, 0.0]", "[0.0, 0.0, 0.0]"),
    *("[a, b]", "{a: 1}", "'/no/such/file'", "'~'", "'.'", "'config/simrobot/demo_map.png'", "[1, 2, 3]"),
)
_parameter_names: dict[str, list[str]] = {}
#: What a world cannot start without (the fuzzed ``-p`` values come after, so may replace it).
_REQUIRED_ARGS = {"simrobot_world": ["-p", f"world_file:={config_path('simrobot/demo.yaml')}"]}


def node_parameters_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """``robot_sims <world> --ros-args -p name:=value ...``: one to three of the world's own
    parameters set to type-confused, huge, non-finite or missing-file values, parsed by rcl as on
    the command line; the world must build and step with finite state or refuse with InputError."""
    exe = rng.choice(sorted(_WORLD_NODES))
    names = _declared_parameters(exe)
    args = ["--ros-args", *_REQUIRED_ARGS.get(exe, [])]
    for name in rng.sample(names, k=min(len(names), rng.randint(1, 3))):
        args += ["-p", f"{name}:={rng.choice(_PARAMETER_VALUES)}"]
    (folder / "argv.txt").write_text("\n".join([exe, *args]) + "\n", encoding="utf-8")
    return Case(folder, lambda: _run_world_node(exe, args, steps=3))


def _declared_parameters(exe: str) -> list[str]:
    """The parameters a default world of ``exe`` declares (ROS's own use_sim_time excluded)."""
    if exe not in _parameter_names:
        node = _build_world_node(exe, ["--ros-args", *_REQUIRED_ARGS.get(exe, [])])
        try:
            _parameter_names[exe] = sorted(n for n in node._parameters if n != "use_sim_time")
        finally:
            _destroy_world_node(node)
    return _parameter_names[exe]


def _build_world_node(exe: str, args: list[str]):
    """The world node of ``exe`` with ``args`` as its own command-line arguments (rcl parses the
    ``-p`` rules as on the command line), in the worker's one ROS context: a context per input made
    and shut down a DDS participant each time."""
    import importlib

    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    from sim_runtime.errors import InputError

    _ensure_ros()
    module, cls = _WORLD_NODES[exe].split(":")
    try:
        return getattr(importlib.import_module(module), cls)(cli_args=list(args))
    except _rclpy.RCLError as error:  # as init_ros does for the executables
        raise InputError(f"invalid ROS arguments {args!r}: {error}") from None


def _destroy_world_node(node) -> None:
    node.destroy_node()


def _run_world_node(exe: str, args: list[str], steps: int) -> None:
    node = _build_world_node(exe, args)
    try:
        node.step(steps)
        _finite(node.sim_time, f"{exe} sim time")
        model = getattr(node, "model", None)
        pose = getattr(model, "pose", None)
        if pose is not None:
            _finite(pose, f"{exe} pose")
    finally:
        _destroy_world_node(node)


_ROS_READY = False


def _ensure_ros() -> None:
    global _ROS_READY
    if not _ROS_READY:
        import rclpy

        rclpy.init(args=[])
        _ROS_READY = True


# --------------------------------------------------------------------------------- special paths
#: Paths no loader may hang on, read forever, or crash with an OSError over.
SPECIAL_PATHS = (
    "long_name",
    "long_path",
    "nul_name",
    "fifo",
    "directory",
    "dev_zero",
    "zero_link",
    "link_loop",
    "missing",
)


def special_path(kind: str, folder: Path, suffix: str = "") -> Path:
    """A path of ``kind`` (see :data:`SPECIAL_PATHS`) in ``folder``, made on disk where it is a file:
    a name longer than a file name may be, a path longer than a path may be, a name holding a NUL
    (a YAML field can: ``"\\0"``), a FIFO (opening it for reading waits for a writer), a directory,
    ``/dev/zero`` (endless) and a link to it, a link to itself, or nothing."""
    if kind == "long_name":
        return folder / ("n" * 300 + suffix)
    if kind == "long_path":
        return folder.joinpath(*["d" * 200] * 25, "f" + suffix)
    if kind == "dev_zero":
        return Path("/dev/zero")
    if kind == "nul_name":
        return folder / f"nul\0name{suffix}"
    path = folder / f"special_{kind}{suffix}"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    elif kind == "zero_link":
        path.symlink_to("/dev/zero")
    elif kind == "link_loop":
        path.symlink_to(path.name)
    return path


def _bag_with_special_split(rng: random.Random, seeds: Seeds, folder: Path, kind: str) -> Path:
    """A seed bag whose metadata.yaml lists a special split, or holding one named like a split."""
    bag = folder / "bag"
    shutil.copytree(rng.choice(seeds.bags), bag)
    special = special_path(kind, bag, ".mcap")
    meta = bag / "metadata.yaml"
    if rng.random() < 0.5 and meta.exists():
        tree = yaml.safe_load(meta.read_text(encoding="utf-8"))
        with contextlib.suppress(KeyError, TypeError):
            tree["rosbag2_bagfile_information"]["relative_file_paths"].append(os.path.relpath(special, bag))
        meta.write_text(yaml.safe_dump(tree), encoding="utf-8")
    return bag


def _field_cases(rng: random.Random, seeds: Seeds, folder: Path, special: Path) -> dict[str, Callable[[], object]]:
    """Files whose field names ``special``: a world's map, a robot config's mesh folder and mesh, a
    scene's mesh and arm config, a sweep's map file."""
    world = dict(rng.choice(seeds.worlds), map=str(special))
    (folder / "world.yaml").write_text(dump_yaml(world), encoding="utf-8")
    arm = dict(rng.choice(seeds.arm_configs))
    if rng.random() < 0.5:
        arm["mesh_folder"] = str(special)
    else:
        arm["links"] = [{"link": 0, "elements": [{"mesh": str(special)}]}]
    (folder / "arm.yaml").write_text(dump_yaml(arm), encoding="utf-8")
    scene = {"objects": [{"name": "thing", "mesh": str(special)}]}
    if rng.random() < 0.5:
        scene = {"arms": [{"name": "a", "config": str(special)}]}
    (folder / "scene.yaml").write_text(dump_yaml(scene), encoding="utf-8")
    sweep = {"worlds": [{"map": str(special)}], "controllers": ["create_bump_turn"], "duration_s": 1}
    (folder / "sweep.yaml").write_text(dump_yaml(sweep), encoding="utf-8")
    return {
        "world_map": lambda: _drive_simrobot(rng, folder / "world.yaml"),
        "arm_mesh": lambda: _drive_arm(rng, folder / "arm.yaml"),
        "scene_field": lambda: _load_scene(folder / "scene.yaml"),
        "sweep_map": lambda: _load_sweep(folder / "sweep.yaml"),
    }


def _load_sweep(path: Path) -> None:
    from sim_tools.batch.sweep import load_sweep

    load_sweep(path, out=str(path.parent / "sweep_out"))


def _loaders(rng: random.Random, folder: Path) -> dict[str, Callable[[Path], object]]:
    """Each input file kind's loader, as a user's program (or a node) calls it."""
    from create_sim.configfile import load_config
    from create_sim.mapfile import load_map
    from simrobot_sim.world_file import load_bitmap

    return {
        "map": load_map,
        "config": load_config,
        "world": lambda p: _drive_simrobot(rng, p),
        "bitmap": load_bitmap,
        "robot_config": lambda p: _drive_arm(rng, p),
        "scene": _load_scene,
        "stl": _load_stl,
        "trajectory": _load_trajectory,
        "bag": _read_bag,
        "sweep": _load_sweep,
    }


def _load_trajectory(path: Path) -> None:
    from arm_sim.trajectory_file import load_trajectory

    load_trajectory(path)


def special_path_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """A loader handed a special path (:data:`SPECIAL_PATHS`) directly, through a field of a file,
    as a bag's split, or as a world node's file parameter: it must refuse it with InputError, at once."""
    how = rng.choice(("direct", "direct", "field", "bag_split", "parameter"))
    # A command line cannot hold a NUL: rcl would see the name cut short.
    kind = rng.choice([k for k in SPECIAL_PATHS if how != "parameter" or k != "nul_name"])
    special = special_path(kind, folder, rng.choice(("", ".yaml", ".map", ".png", ".stl", ".mcap")))
    note = f"{kind} {how}"
    if how == "field":
        name, run = rng.choice(sorted(_field_cases(rng, seeds, folder, special).items()))
        return Case(folder, run, f"{note} {name}")
    if how == "bag_split":
        bag = _bag_with_special_split(rng, seeds, folder, kind)
        return Case(folder, lambda: _read_bag(bag), note)
    if how == "parameter":
        exe, name = rng.choice(_FILE_PARAMETERS)
        args = ["--ros-args", "-p", f"{name}:={special}"]
        return Case(folder, lambda: _run_world_node(exe, args, steps=1), f"{note} {exe} {name}")
    name, load = rng.choice(sorted(_loaders(rng, folder).items()))
    return Case(folder, lambda: load(special), f"{note} {name}")


#: (world executable, a file parameter of it).
_FILE_PARAMETERS = (
    ("create_world", "map_file"),
    ("create_world", "config_file"),
    ("simrobot_world", "world_file"),
    ("arm", "robot_config_file"),
    ("arm", "scene_file"),
)


# ----------------------------------------------------------------------------------------- table
TARGETS: dict[str, tuple[float, Callable[[random.Random, Seeds, Path], Case]]] = {
    "create_map": (16, create_map_case),
    "create_config": (6, create_config_case),
    "simrobot_world": (10, simrobot_world_case),
    "simrobot_bitmap": (8, simrobot_bitmap_case),
    "arm_config": (12, arm_config_case),
    "scene": (6, scene_case),
    "stl": (10, stl_case),
    "bag_reader": (10, bag_reader_case),
    "draw_tracks": (8, draw_tracks_case),
    "bag_to_rerun": (6, bag_to_rerun_case),
    "replay": (4, replay_case),
    "node_parameters": (4, node_parameters_case),
    "special_paths": (4, special_path_case),
}
"""Target name → (relative weight, case maker)."""


def _selftest_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """Checks the harness itself: every 7th input kills its process (as a segfault would),
    every 5th raises a plain exception, number 33 never returns, number 34 never returns unless it
    is the first input of its process (a stall), the rest load or raise InputError."""
    from sim_runtime.errors import InputError

    number = rng.randrange(35)
    (folder / "number.txt").write_text(str(number), encoding="utf-8")

    def run() -> None:
        global _selftest_runs
        _selftest_runs += 1
        if number % 7 == 0:
            import ctypes

            ctypes.string_at(0)  # SIGSEGV
        if number % 5 == 0:
            raise RuntimeError("selftest defect")
        if number == 33 or (number == 34 and _selftest_runs > 1):
            _selftest_hang()
        if number % 2:
            raise InputError("selftest input error")

    return Case(folder, run)


_selftest_runs = 0


def _selftest_hang() -> None:
    while True:
        time.sleep(1.0)


if os.environ.get("ROBOT_SIMS_FUZZ_SELFTEST"):  # the harness's own test: its workers inherit this
    TARGETS = {"selftest": (1.0, _selftest_case)}


def target_of(index: int, seed: int) -> str:
    """Which target input ``index`` of a campaign exercises (deterministic)."""
    rng = random.Random(f"{seed}/{index}/target")
    names = list(TARGETS)
    return rng.choices(names, weights=[TARGETS[n][0] for n in names])[0]


def make_case(index: int, seed: int, seeds: Seeds, folder: Path) -> tuple[str, Case]:
    """The input ``index`` of a campaign, written into ``folder`` (same index, same input)."""
    name = target_of(index, seed)
    rng = random.Random(f"{seed}/{index}")
    folder.mkdir(parents=True, exist_ok=True)
    return name, TARGETS[name][1](rng, seeds, folder)


__all__ = ["TARGETS", "Case", "Defect", "Seeds", "make_case", "prepare_seeds", "target_of", "warm_up"]


def warm_up(seeds: Seeds, folder: Path) -> None:
    """Import and compile (numba) everything once on the unmutated seeds, before the hang clock runs."""
    if "selftest" in TARGETS:
        return
    rng = random.Random(0)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "w.map").write_text(seeds.maps[0], encoding="utf-8")
    (folder / "w.txt").write_text(seeds.configs[0], encoding="utf-8")
    _drive_create(rng, folder / "w.map", folder / "w.txt")
    _drive_simrobot(rng, seeds.folder / "worlds/small.yaml")
    _drive_arm(rng, seeds.folder / "arm/irb120.yaml")
    _load_scene(seeds.folder / "scenes/workcell.yaml")
    for path in sorted((seeds.folder / "stl").glob("*.stl")):
        _load_stl(path)
    _read_bag(seeds.bags[0])
    shutil.rmtree(folder, ignore_errors=True)
