"""What the replay page shows at an instant (studio.replay.frames, no browser): the bag's own values."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import OccupancyGrid
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from create_sim.synthetic_run import write_create_run
from sim_runtime.bag.reader import open_bag
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.msgs import pose_msg, yaw_from_quaternion
from studio.replay.draw import grid_image_svg, panel_html
from studio.replay.frames import Replay
from studio.replay.page import bag_names
from studio.shell.svg import View
from studio.shell.workspace import Workspace

S = 1_000_000_000


@pytest.fixture(scope="module")
def create_bag(tmp_path_factory) -> Path:
    return write_create_run(tmp_path_factory.mktemp("replay") / "run", 3.0, start_s=50.0)


def latest(bag_path: Path, topic: str, t_ns: int):
    """The last message of ``topic`` at or before ``t_ns``, found by reading the bag from its start."""
    found = None
    for m in open_bag(bag_path).messages(topics=[topic], end=t_ns):
        found = m
    return found


def test_a_frame_shows_the_pose_scan_and_commands_the_bag_holds_at_that_instant(create_bag):
    replay = Replay.open(create_bag)
    assert [(r.ns, r.kind) for r in replay.robots] == [("", "create")]
    t = replay.start_ns + 1_234_567_890
    frame = replay.frame(t)
    assert frame.elapsed_s == pytest.approx(1.23456789)
    pose = latest(create_bag, "/overhead_pose", t).msg.pose
    rf = frame.robots[0]
    assert rf.pose == (pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation))
    scan = latest(create_bag, "/scan", t).msg
    np.testing.assert_array_equal(rf.scan[2], np.asarray(scan.ranges, dtype=np.float32))
    assert rf.sonar["front"] == latest(create_bag, "/sonar/front", t).msg.range
    assert np.allclose(rf.track[-1], (pose.position.x, pose.position.y), atol=0.02)  # drawn up to the robot
    assert frame.commands[0][1:] == ("/cmd_vel", "v 0.300 m/s, ω 0.000 rad/s")
    assert {topic for topic, _age, _text in frame.latest} == set(open_bag(create_bag).topics)
    assert len(frame.map.walls) == 5
    html = panel_html(frame)
    assert f"{pose.position.x:.3f} {pose.position.y:.3f}" in html


def test_steps_go_from_one_pose_to_the_next_and_stop_at_the_ends(create_bag):
    replay = Replay.open(create_bag)
    frames = replay.frames
    assert len(frames) == 151 and frames[0] == replay.start_ns  # 3 s of 50 Hz poses
    assert replay.step(frames[0], 1) == frames[1]
    assert replay.step(frames[5] + 1, 1) == frames[6]  # between two poses
    assert replay.step(frames[5] + 1, -1) == frames[5]
    assert replay.step(frames[5], -1) == frames[4]
    assert replay.step(frames[0], -1) == frames[0]
    assert replay.step(frames[-1], 3) == frames[-1]


def test_simrobot_robots_and_arm_joints_are_found_and_read(tmp_path):
    qos = qos_profiles_yaml([{}])
    grid = OccupancyGrid()
    grid.info.width, grid.info.height, grid.info.resolution = 4, 2, 0.5
    grid.data = [0, 0, 0, 100, 0, 0, -1, 0]
    with BagWriter(tmp_path / "mixed") as bag:
        ids = {
            name: bag.add_topic(name, kind, qos)
            for name, kind in [
                ("/map", "nav_msgs/msg/OccupancyGrid"),
                ("/r1/pose", "geometry_msgs/msg/PoseStamped"),
                ("/r1/crashed", "std_msgs/msg/Bool"),
                ("/r1/cmd_vel", "geometry_msgs/msg/Twist"),
                ("/arm/joint_states", "sensor_msgs/msg/JointState"),
            ]
        }
        bag.write(ids["/map"], 0, serialize_message(grid))
        for k in range(5):
            bag.write(ids["/r1/pose"], k * S, serialize_message(PoseStamped(pose=pose_msg(0.1 * k, 0.0, 0.2))))
            bag.write(ids["/arm/joint_states"], k * S, serialize_message(JointState(name=["j1"], position=[k * 0.5])))
        bag.write(ids["/r1/cmd_vel"], 2 * S, serialize_message(Twist()))
        bag.write(ids["/r1/crashed"], 3 * S, serialize_message(Bool(data=True)))
    replay = Replay.open(tmp_path / "mixed")
    assert [(r.ns, r.kind) for r in replay.robots] == [("/r1", "simrobot")]
    assert replay.arms == ["/arm"] and replay.frame_topic == "/r1/pose"
    before, after = replay.frame(2 * S + 1), replay.frame(3 * S)
    assert before.robots[0].pose == pytest.approx((0.2, 0.0, 0.2)) and not before.robots[0].crashed
    assert after.robots[0].crashed and after.joints["/arm"] == [("j1", 1.5)]
    assert [c[1] for c in before.commands] == ["/r1/cmd_vel"]
    svg = grid_image_svg(View(800, 600, scale=100.0), after.grid)
    assert 'x="400.0" y="200.0" width="200.0" height="100.0"' in svg  # 2 m × 1 m from (0, 0), y up


def test_the_bag_list_names_bag_folders_and_lone_mcap_files(create_bag, tmp_path):
    (tmp_path / "run").symlink_to(create_bag, target_is_directory=True)
    (tmp_path / "other.mcap").write_bytes((next(create_bag.glob("*.mcap"))).read_bytes())
    assert bag_names(Workspace(tmp_path)) == ["other.mcap"]  # a symlink out of the workspace is not followed
    write_create_run(tmp_path / "runs" / "b", 0.1)
    assert bag_names(Workspace(tmp_path)) == ["other.mcap", "runs/b"]
    assert math.isfinite(Replay.open(tmp_path / "other.mcap").duration_s)


def test_a_recorded_demo_run_replays_with_its_controller_commands(tmp_path):
    """A real recording (world, controller and recorder in one process), not a written one."""
    from create_sim.bump_turn import demo
    from sim_tools.demo import _Recording

    recording = _Recording(tmp_path / "demo")
    demo(1.0, extra_nodes=recording)
    recording.close()
    replay = Replay.open(tmp_path / "demo")
    assert [r.kind for r in replay.robots] == ["create"] and len(replay.frames) >= 40
    frame = replay.frame(replay.end_ns)
    assert frame.robots[0].pose[0] > 0.1 and frame.map is not None
    assert frame.commands and all(topic == "/cmd_vel" for _t, topic, _text in frame.commands)


def test_an_empty_bag_and_a_type_that_is_not_installed_replay_without_failing(tmp_path):
    with BagWriter(tmp_path / "empty"):
        pass
    empty = Replay.open(tmp_path / "empty")
    assert empty.robots == [] and empty.duration_s == 0.0
    assert empty.frame(empty.start_ns).latest == [] and empty.step(0, 1) == 0
    qos = qos_profiles_yaml([{}])
    with BagWriter(tmp_path / "unknown") as bag:
        thing = bag.add_topic("/thing", "no_such_pkg/msg/Thing", qos)
        pose = bag.add_topic("/overhead_pose", "geometry_msgs/msg/PoseStamped", qos)
        bag.write(thing, 0, b"\x00\x01\x00\x00abcd")
        bag.write(pose, S, serialize_message(PoseStamped(pose=pose_msg(1.0, 2.0, 0.5))))
    replay = Replay.open(tmp_path / "unknown")
    with pytest.warns(UserWarning, match="no_such_pkg/msg/Thing"):
        frame = replay.frame(replay.end_ns)
    assert ("/thing", 1.0, "(no_such_pkg/msg/Thing, not decoded)") in frame.latest
    assert frame.robots[0].pose == pytest.approx((1.0, 2.0, 0.5))


def test_a_recorded_arm_run_is_drawn_with_its_meshes_posed_as_the_bag_has_them(tmp_path):
    """The arm demo recorded for real: each frame gives the Arm page's 3D view what it draws live."""
    from arm_sim.demo import run_demo
    from sim_runtime.paths import mesh_path
    from sim_tools.demo import _Recording
    from studio.arm.ros_client import drawables

    recording = _Recording(tmp_path / "arm")
    summary = run_demo(None, extra_nodes=recording)
    recording.close()
    replay = Replay.open(tmp_path / "arm")
    assert replay.robots == [] and not replay.has_plan_view  # nothing for the map view: the 3D view only
    assert replay.arms == [""] and replay.arm_marker_topics == ["/robot_markers", "/scene_markers"]
    first, last = replay.frame(replay.frames[0]), replay.frame(replay.end_ns)
    (arm,) = [g for g in last.arm_groups if g.owner == ""]
    assert [d.mesh_uri.rsplit("/", 1)[-1] for d in arm.look] == ["IRB120_base.stl"] + [
        f"IRB120_link{k}.stl" for k in range(1, 7)
    ]
    assert all(mesh_path(d.mesh_uri).is_file() for d in arm.look)  # what the page loads
    recorded = latest(tmp_path / "arm", "/robot_markers", replay.end_ns)
    np.testing.assert_array_equal(arm.poses, drawables(recorded.msg)[1])  # the bag's own poses, untouched
    (arm_then,) = [g for g in first.arm_groups if g.owner == ""]
    assert np.abs(arm.poses[1:, :3] - arm_then.poses[1:, :3]).max() > 0.05  # the links moved; the base did not
    np.testing.assert_array_equal(arm.poses[0], arm_then.poses[0])
    assert [g.owner for g in last.arm_groups] == ["", "scene:"] and last.arm_groups[1].look == ()
    assert [round(p, 4) for _name, p in last.joints[""]] == summary["final_q"]
    end = latest(tmp_path / "arm", "/end_effector_pose", replay.end_ns).msg.pose
    assert last.end_effectors[""] == (
        end.position.x, end.position.y, end.position.z,
        end.orientation.x, end.orientation.y, end.orientation.z, end.orientation.w,
    )  # fmt: skip
    assert replay.frame(replay.end_ns).arm_groups[0] is arm  # a frame shown again is not rebuilt


def test_the_age_of_each_topics_message_is_how_long_before_the_instant_never_negative(create_bag):
    import re

    replay = Replay.open(create_bag)
    t = replay.start_ns + 1_234_567_890
    frame = replay.frame(t)
    scan = latest(create_bag, "/scan", t)
    ages = {topic: age for topic, age, _text in frame.latest}
    assert ages["/scan"] == pytest.approx((t - scan.log_time_ns) / S) and all(age >= 0 for age in ages.values())
    shown = re.findall(r"<td class='pr-2 font-mono text-gray-500'>([^<]*)</td>", panel_html(frame))
    assert shown and all(float(cell) >= 0 and not cell.startswith("-") for cell in shown)


def write_two_world_bag(path: Path) -> Path:
    """A bag of a Create world in /create1 (a wall, its robot 1 s apart) and a SIMROBOT world in
    /simrobot1 (an occupancy grid, robots r1 and r2 0.5 s apart), as the studio records them."""
    from builtin_interfaces.msg import Time

    from create_sim.mapfile import parse_map
    from create_sim.world_node import map_markers

    qos = qos_profiles_yaml([{}])
    grid = OccupancyGrid()
    grid.info.width, grid.info.height, grid.info.resolution = 4, 2, 0.5
    grid.data = [100] * 8
    walls = map_markers(parse_map("wall -1 -1 1 -1\n", "box.map"), Time())
    with BagWriter(path) as bag:
        ids = {
            name: bag.add_topic(name, kind, qos)
            for name, kind in [
                ("/create1/map_markers", "visualization_msgs/msg/MarkerArray"),
                ("/create1/overhead_pose", "geometry_msgs/msg/PoseStamped"),
                ("/simrobot1/map", "nav_msgs/msg/OccupancyGrid"),
                ("/simrobot1/r1/pose", "geometry_msgs/msg/PoseStamped"),
                ("/simrobot1/r2/pose", "geometry_msgs/msg/PoseStamped"),
            ]
        }
        bag.write(ids["/create1/map_markers"], 0, serialize_message(walls))
        bag.write(ids["/simrobot1/map"], 0, serialize_message(grid))
        for k in range(4):
            bag.write(ids["/create1/overhead_pose"], k * S, serialize_message(PoseStamped(pose=pose_msg(k, 0.0, 0.0))))
            for i, name in enumerate(("r1", "r2")):
                pose = PoseStamped(pose=pose_msg(0.5 + i, 0.5, 0.0))
                bag.write(ids[f"/simrobot1/{name}/pose"], k * S // 2 + 1, serialize_message(pose))
    return path


def test_a_bag_of_a_create_and_a_simrobot_world_replays_each_world_alone_in_its_own_frame(tmp_path):
    replay = Replay.open(write_two_world_bag(tmp_path / "two_worlds"))
    assert list(replay.worlds) == ["/create1", "/simrobot1"]
    assert [replay.world_kind(w) for w in replay.worlds] == ["create", "simrobot"]
    create, simrobot = replay.frame(3 * S, "/create1"), replay.frame(3 * S, "/simrobot1")
    assert [rf.robot.ns for rf in create.robots] == ["/create1"] and create.grid is None
    assert len(create.map.walls) == 1 and create.robots[0].pose == pytest.approx((3.0, 0.0, 0.0))
    assert [rf.robot.ns for rf in simrobot.robots] == ["/simrobot1/r1", "/simrobot1/r2"]
    assert simrobot.map is None and simrobot.grid is not None
    assert replay.step(S, 1, "/create1") == 2 * S  # each world steps through its own frames
    assert replay.step(S // 2 + 1, 1, "/simrobot1") == S + 1
    assert (replay.first_frame_of("/create1"), replay.first_frame_of("/simrobot1")) == (0, 1)
