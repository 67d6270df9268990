"""bag_to_rerun: synthetic bags of the worlds' topic types → .rrd with the expected entities and data."""

from __future__ import annotations

import json
import math
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
import rerun.chunk as rrc
import trimesh
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rerun_test_helpers import (
    arm_messages,
    blueprint_views,
    column,
    create_messages,
    load_entities,
    quat,
    simrobot_messages,
    stamp,
    tf_message,
    write_bag,
)
from sensor_msgs.msg import Range
from std_msgs.msg import Bool, String

from create_sim import spec as mounts
from sim_runtime.bag.reader import BagWarning
from sim_runtime.errors import InputError
from sim_tools.rerun_kit.style import LIDAR_COLOR, TRACK_SEGMENT_POINTS
from sim_tools.rerun_view.analytics import analytics_disabled, private_rerun_env, rerun_cli
from sim_tools.rerun_view.analytics import main as analytics_main
from sim_tools.rerun_view.convert import bag_to_rerun, main


@pytest.fixture(scope="module")
def rerun_env(tmp_path_factory) -> dict[str, str]:
    return private_rerun_env(tmp_path_factory.mktemp("rerun_home"))


def test_private_env_has_analytics_disabled(rerun_env, tmp_path):
    assert rerun_env["HOME"] != str(Path.home())
    assert rerun_env["XDG_CONFIG_HOME"].startswith(rerun_env["HOME"])
    assert analytics_disabled(rerun_env)


def test_create_bag_draws_map_robot_track_scan_sonar_and_events(tmp_path, rerun_env, capsys):
    bag = write_bag(tmp_path / "create.mcap", create_messages())
    out = tmp_path / "create.rrd"
    main([str(bag), "-o", str(out)])
    printed = capsys.readouterr()
    assert f"rerun {out}" in printed.out
    assert "100.0%" in printed.err  # the progress bar reached the end

    verify = subprocess.run(
        [rerun_cli(), "rrd", "verify", str(out)], env=rerun_env, capture_output=True, text=True, timeout=120
    )
    assert verify.returncode == 0, verify.stderr

    assert len(rrc.RrdReader(out).blueprints()) == 1  # the layout opens with the file
    ents = load_entities(out)
    walls = column(ents["/top/map/map_markers/walls/0"], "LineStrips2D:strips")
    assert len(walls[0]) == 2  # LINE_LIST of 4 points = 2 segments
    assert column(ents["/top/map/map_markers/beacons/0"], "Points2D:positions") == [[[0.0, 0.0]]]
    assert column(ents["/top/map/robots/robot/follow/label"], "Points2D:labels") == [["robot"]]
    assert column(ents["/top/map/robots/robot/body/heading"], "Arrows2D:vectors")[0][0] == pytest.approx(
        [mounts.RADIUS_M, 0.0]
    )

    poses = column(ents["/top/map/robots/robot"], "Transform3D:translation")
    assert len(poses) == 50 + 0  # one transform per ground-truth pose; odom does not move it
    assert poses[-1][0][0] == pytest.approx(math.sin(0.5 * math.pi * 49 / 50), abs=1e-6)

    track = column(ents["/top/map/tracks/robot/truth/0"], "LineStrips2D:strips")
    assert len(track[-1][0]) == 50  # the last strip holds the whole quarter circle
    assert track[-1][0][-1] == pytest.approx(poses[-1][0][:2], abs=1e-6)
    body_color = column(ents["/top/map/robots/robot/body"], "LineStrips2D:colors")[0]
    assert column(ents["/top/map/tracks/robot/truth/0"], "LineStrips2D:colors")[-1] == body_color

    scans = column(ents["/top/map/robots/robot/laser/scan"], "Points2D:positions")
    assert len(scans) == 10 and all(len(s) == 581 for s in scans)  # 681 beams, 100 without return
    assert scans[0][-1] == pytest.approx(
        [2.0 * math.cos(2 * math.pi / 3), 2.0 * math.sin(2 * math.pi / 3)], abs=1e-5
    )  # in the laser frame, left-most beam

    sonar = column(ents["/top/map/robots/robot/sonar_front/hit"], "LineStrips2D:strips")
    assert sonar[0][0][1] == pytest.approx([1.25, 0.0])  # a single-ray sonar: the ray to its hit

    bump_on = column(ents["/top/map/robots/robot/bump_left/detection"], "Points2D:positions")
    assert len(bump_on) == 1  # drawn once when pressed (then cleared), not 50 times

    errors = column(ents["/plots/odom_error/robot/position_m"], "Scalars:scalars")
    assert len(errors) == 50
    assert errors[-1][0] == pytest.approx(
        0.02 * math.hypot(math.sin(0.5 * math.pi * 49 / 50), 1 - math.cos(0.5 * math.pi * 49 / 50)), rel=1e-3
    )


def test_create_sensors_are_drawn_at_their_mounts(tmp_path):
    ents = load_entities(bag_to_rerun(write_bag(tmp_path / "c.mcap", create_messages()), tmp_path / "c.rrd"))
    for sensor in ("laser", "sonar_front", "bump_left", "cliff_left"):
        mount = mounts.SENSOR_MOUNTS[sensor]
        frame = ents[f"/top/map/robots/robot/{sensor}"]
        assert column(frame, "Transform3D:translation") == [[pytest.approx([mount.x_m, mount.y_m, 0.0])]]
        q = column(frame, "Transform3D:quaternion")[0][0]
        assert 2 * math.atan2(q[2], q[3]) == pytest.approx(mount.yaw_rad, abs=1e-6)


def test_events_have_levels_and_are_logged_on_and_off(tmp_path):
    ents = load_entities(bag_to_rerun(write_bag(tmp_path / "c.mcap", create_messages()), tmp_path / "c.rrd"))
    events = list(
        zip(
            [t[0] for t in column(ents["/events/robot"], "TextLog:text")],
            [lv[0] for lv in column(ents["/events/robot"], "TextLog:level")],
            strict=True,
        )
    )
    assert events == [
        ("    0.40 s  robot: bump_left on", "INFO"),
        ("    0.60 s  robot: bump_left off", "INFO"),
        ("    0.80 s  robot: cliff_left on", "INFO"),
        ("    0.82 s  robot: cliff_left off", "INFO"),
    ]


def _crosses(batches) -> list[list[float]]:
    """The centres of the crosses in the last logged marks (two strokes each)."""
    strokes = column(batches, "LineStrips2D:strips")[-1]
    return [np.mean(stroke, axis=0).tolist() for stroke in strokes[::2]]


def test_a_bump_leaves_an_unlabelled_mark_where_it_happened(tmp_path):
    ents = load_entities(bag_to_rerun(write_bag(tmp_path / "c.mcap", create_messages()), tmp_path / "c.rrd"))
    marks = ents["/top/map/marks/robot/contacts"]
    assert column(marks, "Points2D:labels") == []  # where a robot keeps bumping, labels would pile up
    assert "    0.40 s  robot: bump_left on" in [t[0] for t in column(ents["/events/robot"], "TextLog:text")]
    # the left bumper's place on the map at that instant: the robot's pose plus the mount
    yaw = 0.5 * math.pi * 20 / 50
    x, y = math.sin(yaw), 1.0 - math.cos(yaw)
    m = mounts.SENSOR_MOUNTS["bump_left"]
    expected = [x + math.cos(yaw) * m.x_m - math.sin(yaw) * m.y_m, y + math.sin(yaw) * m.x_m + math.cos(yaw) * m.y_m]
    assert _crosses(marks) == [pytest.approx(expected, abs=1e-5)]
    assert column(marks, "LineStrips2D:colors")[0] != [LIDAR_COLOR]


def test_maps_are_drawn_top_down_in_two_d_with_a_view_following_each_robot(tmp_path):
    out = bag_to_rerun(write_bag(tmp_path / "c.mcap", create_messages(ns="robot1")), tmp_path / "c.rrd")
    views = {v["ViewBlueprint:display_name"][0]: v for v in blueprint_views(out)}
    top = views["Map (top-down)"]
    assert top["ViewBlueprint:class_identifier"] == ["2D"]  # orthographic, not a perspective 3-D view
    follow = views["robot1 (follows)"]
    assert follow["ViewBlueprint:class_identifier"] == ["2D"]
    assert follow["ViewBlueprint:space_origin"] == ["/top/map/robots/robot1/follow"]
    ents = load_entities(out)
    # +y up on screen: the map frame is mirrored in y (2-D views draw y downwards)
    assert column(ents["/top/map"], "Transform3D:mat3x3")[0][0] == [1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0]
    assert column(ents["/top/map/grid/labels"], "Points2D:labels")[0][:2] == ["-2 m", "-1 m"]


def test_noise_only_and_constant_series_are_not_plotted(tmp_path):
    """Odometry equal to the truth but for rounding (1e-16 m) draws no error plot."""
    msgs = [(topic, m, t) for topic, m, t in create_messages(steps=50) if not isinstance(m, Odometry)]
    for _, msg, t in list(msgs):
        if isinstance(msg, PoseStamped):
            odom = Odometry(child_frame_id="base_link")
            odom.header.stamp, odom.header.frame_id = msg.header.stamp, "odom"
            odom.pose.pose.position.x = msg.pose.position.x + 1e-16
            odom.pose.pose.position.y = msg.pose.position.y
            odom.pose.pose.orientation = msg.pose.orientation
            msgs.append(("/odom", odom, t))
    out = bag_to_rerun(write_bag(tmp_path / "n.mcap", sorted(msgs, key=lambda m: m[2])), tmp_path / "n.rrd")
    ents = load_entities(out)
    assert not [e for e in ents if e.startswith("/plots/odom_error")]
    assert "/plots/cliff/robot/cliff_left" in ents  # it changes
    names = [v["ViewBlueprint:display_name"][0] for v in blueprint_views(out)]
    assert "Odometry error (m, rad)" not in names and "Cliff signal (%)" in names


def test_long_track_is_split_into_continuous_segments(tmp_path):
    bag = write_bag(tmp_path / "long.mcap", create_messages(steps=TRACK_SEGMENT_POINTS + 40))
    ents = load_entities(bag_to_rerun(bag, tmp_path / "long.rrd", progress=False))
    first = column(ents["/top/map/tracks/robot/truth/0"], "LineStrips2D:strips")[-1][0]
    second = column(ents["/top/map/tracks/robot/truth/1"], "LineStrips2D:strips")[-1][0]
    assert len(first) == TRACK_SEGMENT_POINTS
    assert second[0] == first[-1]  # no gap between segments
    assert len(first) + len(second) - 1 == TRACK_SEGMENT_POINTS + 40


def test_namespaced_robot_is_named_by_its_namespace(tmp_path):
    bag = write_bag(tmp_path / "ns.mcap", create_messages(steps=10, ns="robot1"))
    ents = load_entities(bag_to_rerun(bag, tmp_path / "ns.rrd", progress=False))
    assert "/top/map/robots/robot1/laser/scan" in ents
    assert "/top/map/tracks/robot1/truth/0" in ents
    assert "/top/map/robots/robot" not in ents


def test_arm_meshes_logged_once_then_only_transforms(tmp_path):
    stl = tmp_path / "link1.stl"
    trimesh.creation.box(extents=[0.1, 0.1, 0.3]).export(stl)
    bag = write_bag(tmp_path / "arm.mcap", arm_messages(stl))
    out = bag_to_rerun(bag, tmp_path / "arm.rrd", progress=False)
    ents = load_entities(out)
    link = ents["/world/markers/robot_markers/links/1"]
    assert len(column(link, "Asset3D:blob")) == 1
    assert column(link, "Asset3D:media_type") == [["model/stl"]]
    assert len(column(link, "Transform3D:translation")) == 10
    q1 = column(ents["/plots/joint_position/arm/q1"], "Scalars:scalars")
    assert [v[0] for v in q1] == pytest.approx([0.1 * k for k in range(10)])
    assert "/plots/joint_effort/arm/q1" not in ents  # empty effort array: nothing plotted
    assert "/plots/joint_velocity/arm/q1" not in ents  # constant: nothing to see
    (view,) = [v for v in blueprint_views(out) if v["ViewBlueprint:class_identifier"] == ["3D"]]
    assert view["EyeControls3D:look_target"][0][2] == pytest.approx(0.3)  # looks at the arm


def test_occupancy_grid_is_an_image_placed_at_its_origin_and_resolution(tmp_path):
    bag = write_bag(tmp_path / "simrobot.mcap", simrobot_messages())
    ents = load_entities(bag_to_rerun(bag, tmp_path / "simrobot.rrd", progress=False))
    grid = ents["/top/map/map"]
    assert column(grid, "Transform3D:translation") == [[pytest.approx([-1.0, 0.0, 0.0])]]
    assert column(grid, "Transform3D:scale") == [[pytest.approx([0.1, 0.1, 1.0])]]
    fmt = column(grid, "Image:format")[0][0]
    assert (fmt["width"], fmt["height"]) == (20, 10)
    pixels = np.frombuffer(bytes(column(grid, "Image:buffer")[0][0]), dtype=np.uint8).reshape(10, 20)
    assert (pixels[:, 0] < 128).all() and (pixels[4:7, 10:13] < 128).all()  # walls dark, row 0 = lowest y
    assert (pixels[:, 1:10] == 255).all()
    assert "/top/map/robots/r1" in ents and "/top/map/tracks/r1/truth/0" in ents


def test_sensor_mounts_come_from_the_bags_tf_without_tf2_msgs(tmp_path):
    """A SIMROBOT-like robot whose sonar sits 5 cm ahead, turned 0.3 rad: its beam starts there."""
    tf = tf_message([("r1/base_link", "r1/sens1", 0.05, 0.0, 0.0, 0.3)])
    sonar = Range(radiation_type=Range.ULTRASOUND, field_of_view=math.pi / 3, min_range=0.0, max_range=0.3, range=0.2)
    sonar.header.stamp, sonar.header.frame_id = stamp(1.0), "r1/sens1"
    msgs = [*simrobot_messages(), ("/tf_static", tf, 0.0), ("/r1/sens1", sonar, 1.0)]
    ents = load_entities(
        bag_to_rerun(write_bag(tmp_path / "tf.mcap", sorted(msgs, key=lambda m: m[2])), tmp_path / "tf.rrd")
    )
    frame = ents["/top/map/robots/r1/sens1"]
    assert column(frame, "Transform3D:translation")[-1] == [pytest.approx([0.05, 0.0, 0.0])]
    q = column(frame, "Transform3D:quaternion")[-1][0]
    assert 2 * math.atan2(q[2], q[3]) == pytest.approx(0.3, abs=1e-6)
    cone = column(ents["/top/map/robots/r1/sens1/beam"], "LineStrips2D:strips")[0][0]
    assert cone[0] == [0.0, 0.0]  # from the mount…
    assert max(math.atan2(p[1], p[0]) for p in cone) == pytest.approx(math.pi / 6, abs=1e-6)  # …across its cone
    arc = column(ents["/top/map/robots/r1/sens1/hit"], "LineStrips2D:strips")[0][0]
    assert [math.hypot(*p) for p in arc] == pytest.approx([0.2] * len(arc), abs=1e-6)  # the echo's range


def test_unknown_type_is_skipped_with_a_warning(tmp_path):
    msgs = [*create_messages(steps=5), ("/chatter", String(data="hi"), 0.05)]
    bag = write_bag(tmp_path / "unknown.mcap", sorted(msgs, key=lambda m: m[2]))
    with pytest.warns(UserWarning, match=r"/chatter of type std_msgs/msg/String is not drawn"):
        out = bag_to_rerun(bag, tmp_path / "unknown.rrd", progress=False)
    assert "/top/map/robots/robot" in load_entities(out)


def test_uninstalled_type_is_skipped_with_a_warning(tmp_path):
    bag = write_bag(tmp_path / "x.mcap", create_messages(steps=3))
    # Rename a supported type's schema to a package that is not installed.
    data = bag.read_bytes().replace(b"sensor_msgs/msg/Illuminance", b"nosuch_pkgs/msg/Illuminance")
    bag.write_bytes(data)
    with pytest.warns(UserWarning, match="nosuch_pkgs/msg/Illuminance"):
        out = bag_to_rerun(bag, tmp_path / "x.rrd", progress=False)
    assert "/top/map/robots/robot/cliff_left/detection" not in load_entities(out)


def test_truncated_bag_converts_what_is_intact(tmp_path, rerun_env):
    full = write_bag(tmp_path / "full.mcap", create_messages(steps=50))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full.read_bytes()[: full.stat().st_size * 2 // 3])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = bag_to_rerun(cut, tmp_path / "cut.rrd", progress=False)
    assert any("cut.mcap" in str(w.message) for w in caught)
    verify = subprocess.run(
        [rerun_cli(), "rrd", "verify", str(out)], env=rerun_env, capture_output=True, text=True, timeout=120
    )
    assert verify.returncode == 0, verify.stderr


def test_garbage_file_and_missing_output_folder_are_clear_errors(tmp_path, capsys):
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not an mcap file at all" * 10)
    with pytest.raises(SystemExit) as exit_info, pytest.warns(BagWarning, match="junk.mcap"):
        main([str(junk), "-o", str(tmp_path / "j.rrd")])
    assert exit_info.value.code == 2
    assert "junk.mcap: no readable messages" in capsys.readouterr().err
    assert not (tmp_path / "j.rrd").exists()
    bag = write_bag(tmp_path / "ok.mcap", create_messages(steps=2))
    with pytest.raises(InputError, match="does not exist"):
        bag_to_rerun(bag, tmp_path / "no" / "such" / "out.rrd")
    with pytest.raises(InputError, match="no such bag"):
        bag_to_rerun(tmp_path / "missing_bag")


def test_cli_wrapper_runs_rerun_with_analytics_off(capfd):
    assert analytics_main(["analytics", "config"]) == 0
    config = json.loads(capfd.readouterr().out)
    assert config["analytics_enabled"] is False
    assert not config["config_file_path"].startswith(str(Path.home()))


def test_odometry_is_aligned_with_truth_even_when_it_comes_first(tmp_path):
    """Odometry starting at (0, 0) while the robot starts at (1, 2) facing +y: aligned, no error."""
    msgs = []
    for k in range(10):
        t = 0.1 * k
        odom = Odometry(child_frame_id="base_link")
        odom.header.stamp, odom.header.frame_id = stamp(t), "odom"
        odom.pose.pose.position.x = 0.1 * k  # forward in the odom frame
        odom.pose.pose.orientation.w = 1.0
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = stamp(t), "map"
        pose.pose.position.x, pose.pose.position.y = 1.0, 2.0 + 0.1 * k  # forward = +y in the map
        pose.pose.orientation = quat(math.pi / 2)
        msgs += [("/odom", odom, t), ("/overhead_pose", pose, t)]  # odometry first at each instant
    ents = load_entities(bag_to_rerun(write_bag(tmp_path / "o.mcap", msgs), tmp_path / "o.rrd", progress=False))
    assert not [e for e in ents if e.startswith("/plots/odom_error")]  # no error at all: nothing plotted
    odom_track = column(ents["/top/map/tracks/robot/odom/0"], "LineStrips2D:strips")[-1][0]
    assert odom_track[-1] == pytest.approx([1.0, 2.9], abs=1e-5)  # each odometry pose waited for its truth


def test_a_crash_is_a_warning_a_mark_at_the_robot_and_a_word_in_its_label(tmp_path):
    msgs = [
        *simrobot_messages(),
        ("/r1/crashed", Bool(data=False), 0.0),
        ("/r1/crashed", Bool(data=True), 3.0),
        ("/r1/crashed", Bool(data=False), 4.5),
    ]
    ents = load_entities(
        bag_to_rerun(write_bag(tmp_path / "s.mcap", sorted(msgs, key=lambda m: m[2])), tmp_path / "s.rrd")
    )
    events = ents["/events/r1"]
    assert [t[0] for t in column(events, "TextLog:text")] == [
        "    3.00 s  r1: crashed",
        "    4.50 s  r1: crash cleared",
    ]
    assert [lv[0] for lv in column(events, "TextLog:level")] == ["WARN", "INFO"]
    assert _crosses(ents["/top/map/marks/r1/crashes"]) == [pytest.approx([0.3, 0.0])]  # r1's pose at 3 s
    labels = [t[0] for t in column(ents["/top/map/robots/r1/follow/label"], "Points2D:labels")]
    assert labels == ["r1", "r1 crashed", "r1"]  # from 3 s until it is cleared at 4.5 s


def test_a_frontal_hit_pressing_both_bumpers_leaves_one_mark(tmp_path):
    msgs = create_messages()
    for topic, msg, t in list(msgs):
        if topic == "/bump/left":
            right = Range(radiation_type=msg.radiation_type, min_range=0.0, max_range=0.0, range=msg.range)
            right.header.stamp, right.header.frame_id = msg.header.stamp, "bump_right"
            msgs.append(("/bump/right", right, t))
    ents = load_entities(
        bag_to_rerun(write_bag(tmp_path / "b.mcap", sorted(msgs, key=lambda m: m[2])), tmp_path / "b.rrd")
    )
    assert len(_crosses(ents["/top/map/marks/robot/contacts"])) == 1
    texts = [t[0] for t in column(ents["/events/robot"], "TextLog:text")]
    assert sum("on" in t.split(": ")[1] for t in texts) == 3  # both bumpers (and the cliff) still in the log


def test_converting_bag_after_bag_in_one_process_releases_each_recordings_threads(tmp_path):
    """The studio or a script converting many bags must not gather Rerun's threads: only the
    blueprint recording Rerun makes for ``send_blueprint`` stays (2 threads, rerun-sdk's own)."""
    import os

    def threads() -> int:
        return len(os.listdir("/proc/self/task"))

    bag = write_bag(tmp_path / "c.mcap", create_messages())
    bag_to_rerun(bag, tmp_path / "warm.rrd")  # Rerun's own runtime threads start once
    before = threads()
    for k in range(5):
        assert bag_to_rerun(bag, tmp_path / f"c{k}.rrd").stat().st_size > 1000
    assert threads() - before <= 2 * 5  # 4 per conversion before the sweep
