"""End to end: a world recorded into a bag by the recorder, converted to .rrd and drawn as tracks."""

from __future__ import annotations

import copy
import subprocess

import numpy as np
import pytest
import rerun as rr
import rerun.chunk as rrc
from geometry_msgs.msg import Twist
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy
from rerun_test_helpers import column, load_entities, world_file_colors

from arm_sim import arm_node
from create_sim import spec as mounts
from create_sim import world_node as create_world
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.paths import config_path
from sim_runtime.qos import COMMAND_PUBLISHER_QOS
from sim_runtime.run import drain
from sim_runtime.testing import spin_until, wait_for_match
from sim_tools.adapters.create.rerun import OCCUPIED_UNDER_LINES
from sim_tools.rerun_kit.ros import type_name
from sim_tools.rerun_view.analytics import private_rerun_env, rerun_cli
from sim_tools.rerun_view.convert import bag_to_rerun
from sim_tools.rerun_view.live import attach_live_view
from sim_tools.rerun_view.tracks import tracks_from_bag
from simrobot_sim import world_node as simrobot


def record_world(executor, world, bag_dir, steps: int, chunk: int = 10, before_step=None) -> None:
    """Record every topic the world publishes (raw CDR, its own QoS) into a rosbag2 folder."""
    writer = BagWriter(bag_dir)
    recorder = Node("test_recorder")
    executor.add_node(recorder)
    subs = []
    received: dict[str, int] = {}

    def write(topic: str, tid: int, data: bytes) -> None:
        received[topic] = received.get(topic, 0) + 1
        writer.write(tid, round(world.sim_time * 1e9), data)

    latched = []
    for pub in world.publishers:
        tid = writer.add_topic(pub.topic_name, type_name(pub.msg_type), qos_profiles_yaml([{}]))
        qos = copy.copy(pub.qos_profile)
        qos.depth = 200
        if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL and pub.topic_name != "/clock":
            latched.append(pub.topic_name)
        subs.append(
            recorder.create_subscription(
                pub.msg_type, pub.topic_name, lambda data, t=pub.topic_name, tid=tid: write(t, tid, data), qos, raw=True
            )
        )
    for sub in subs:
        assert wait_for_match(executor, sub)
    # maps published before the recorder existed arrive a little later: wait for them
    assert spin_until(executor, lambda: all(received.get(t) for t in latched), 10.0)
    for k in range(0, steps, chunk):
        if before_step is not None:
            before_step(k)
        world.step(chunk)
        drain(executor)
    drain(executor)
    executor.remove_node(recorder)
    recorder.destroy_node()
    writer.close()


def test_create_world_bag_converts_with_everything_drawn(executor, make_node, tmp_path):
    world = create_world.CreateWorldNode()
    executor.add_node(world)
    driver = make_node("driver")
    cmd = driver.create_publisher(Twist, "/cmd_vel", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, cmd)

    def drive(k: int) -> None:
        msg = Twist()
        msg.linear.x, msg.angular.z = 0.3, 0.4
        cmd.publish(msg)

    bag = tmp_path / "create_bag"
    record_world(executor, world, bag, steps=200, before_step=drive)  # 2 s of sim time

    out = bag_to_rerun(bag, tmp_path / "create.rrd", progress=False)
    env = private_rerun_env(tmp_path / "rerun_home")
    verify = subprocess.run(
        [rerun_cli(), "rrd", "verify", str(out)], env=env, capture_output=True, text=True, timeout=120
    )
    assert verify.returncode == 0, verify.stderr
    ents = load_entities(out)
    walls = column(ents["/top/map/map_markers/walls/0"], "LineStrips2D:strips")[0]
    assert len(walls) == len(world.map.walls)
    assert column(ents["/top/map/map_markers/beacon_ids/0"], "Points2D:labels") == [["Red1"]]
    # its latched OccupancyGrid drawn as SIMROBOT's, an image of its cells, lighter under the wall lines
    fmt = column(ents["/top/map/map"], "Image:format")[0][0]
    pixels = np.frombuffer(bytes(column(ents["/top/map/map"], "Image:buffer")[0][0]), dtype=np.uint8)
    assert len(pixels) == fmt["width"] * fmt["height"] and {OCCUPIED_UNDER_LINES, 255} <= set(pixels.tolist())
    poses = column(ents["/top/map/robots/robot"], "Transform3D:translation")
    assert len(poses) >= 90  # 50 Hz for 2 s, a few may be in flight when recording starts
    x, y, _ = world.model.pose
    assert poses[-1][0][:2] == pytest.approx([x, y], abs=0.02)
    scans = column(ents["/top/map/robots/robot/laser/scan"], "Points2D:positions")
    assert len(scans) >= 18 and 300 < len(scans[-1]) <= 681
    for sensor in ("laser", "sonar_left", "bump_right", "cliff_front_left", "wall_ir"):  # at the model's mounts
        mount = mounts.SENSOR_MOUNTS[sensor]
        translation = column(ents[f"/top/map/robots/robot/{sensor}"], "Transform3D:translation")
        assert translation == [[pytest.approx([mount.x_m, mount.y_m, 0.0])]]
    assert "/top/map/tracks/robot/truth/0" in ents and "/top/map/tracks/robot/odom/0" in ents

    data = tracks_from_bag(bag)
    assert data.image is not None and data.image.any()
    assert data.tracks["robot"][-1] == pytest.approx([x, y], abs=0.02)


def test_simrobot_world_bag_converts_with_map_robots_and_sonar(executor, tmp_path):
    world = simrobot.SimrobotWorldNode(
        parameter_overrides=[Parameter("world_file", value=str(config_path("simrobot/demo.yaml")))]
    )
    executor.add_node(world)
    bag = tmp_path / "simrobot_bag"
    record_world(executor, world, bag, steps=20, chunk=1)  # 20 steps of 1 s, in-process avoid controllers

    ents = load_entities(bag_to_rerun(bag, tmp_path / "simrobot.rrd", progress=False))
    fmt = column(ents["/top/map/map"], "Image:format")[0][0]
    assert (fmt["width"], fmt["height"]) == world.spec.walls.shape
    colors = world_file_colors(config_path("simrobot/demo.yaml"))
    for name in world.model.names:
        poses = column(ents[f"/top/map/robots/{name}"], "Transform3D:translation")
        assert len(poses) >= 15
        # the world file's colour, as the outline and the tracks PNG have it
        track_colors = column(ents[f"/top/map/tracks/{name}/truth/0"], "LineStrips2D:colors")
        assert track_colors[-1] == [_packed(colors[name])]
        assert column(ents[f"/top/map/robots/{name}/body"], "Points2D:colors")[-1] == [_packed(colors[name])]
    outlines = [e for e in ents if e.startswith("/top/map/markers/robots/robots/")]
    assert len(outlines) == len(world.model.names)  # the /robots shapes
    assert "/top/map/robots/r1/sens1/beam" in ents  # the ultrasonic sensor's cone

    data = tracks_from_bag(bag)
    assert sorted(data.tracks) == sorted(world.model.names)
    # draw_tracks' PNG uses the same colours as the Rerun views: the world file's
    assert {n: tuple(round(255 * c) for c in rgb) for n, rgb in data.colors.items()} == colors
    assert data.image.shape == (world.spec.walls.shape[1], world.spec.walls.shape[0])


def test_arm_bag_logs_each_mesh_once_then_transforms(executor, tmp_path):
    world = arm_node.ArmNode(parameter_overrides=[Parameter("publish_rate", value=20.0)])
    executor.add_node(world)
    bag = tmp_path / "arm_bag"
    record_world(executor, world, bag, steps=100)  # 1 s at 20 Hz: 20 marker arrays

    ents = load_entities(bag_to_rerun(bag, tmp_path / "arm.rrd", progress=False))
    meshes = [e for e in ents if e.startswith("/world/markers/robot_markers/") and column(ents[e], "Asset3D:blob")]
    assert len(meshes) >= len(world.arms[0].arm.elements) - 1  # every STL element (axes are not meshes)
    for entity in meshes:
        assert len(column(ents[entity], "Asset3D:blob")) == 1  # logged once
        assert len(column(ents[entity], "Transform3D:translation")) >= 18  # moved each publication
    joints = [e for e in ents if e.startswith("/plots/joint_position/")]
    assert not joints  # the arm stayed parked: values that never change are not plotted


def test_live_view_of_the_create_world(executor, tmp_path):
    world = create_world.CreateWorldNode()
    executor.add_node(world)
    rec = rr.RecordingStream("robot_sims_test")
    out = tmp_path / "live.rrd"
    rec.save(out)
    view = attach_live_view(world, recording=rec, discover=False)
    assert "/tf_static" in view.subscriptions  # sensor mounts from TF, as RViz gets them
    for _ in range(10):  # 1 s, as run_nodes does at real_time_factor 0: step, then handle callbacks
        world.step(10)
        drain(executor)
    view.close()
    rec.disconnect()
    ents = load_entities(out)
    assert "/top/map/map_markers/walls/0" in ents
    assert len(column(ents["/top/map/robots/robot/laser/scan"], "Points2D:positions")) >= 9
    assert len(column(ents["/top/map/robots/robot"], "Transform3D:translation")) >= 45
    assert len(rrc.RrdReader(out).blueprints()) == 1


def _packed(rgb: tuple[int, int, int]) -> int:
    """An rgb colour as Rerun stores it (0xRRGGBBAA)."""
    return (rgb[0] << 24) | (rgb[1] << 16) | (rgb[2] << 8) | 0xFF
