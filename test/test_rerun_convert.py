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
    column,
    create_messages,
    load_entities,
    quat,
    simrobot_messages,
    stamp,
    write_bag,
)
from std_msgs.msg import String

from sim_runtime.bag.reader import BagWarning
from sim_runtime.errors import InputError
from sim_runtime.rerun_view.analytics import analytics_disabled, private_rerun_env, rerun_cli
from sim_runtime.rerun_view.analytics import main as analytics_main
from sim_runtime.rerun_view.convert import bag_to_rerun, main
from sim_runtime.rerun_view.logger import TRACK_SEGMENT_POINTS


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
    walls = column(ents["/world/map_markers/walls/0"], "LineStrips3D:strips")
    assert len(walls[0]) == 2  # LINE_LIST of 4 points = 2 segments
    assert column(ents["/world/map_markers/beacons/0"], "Points3D:labels") == [["7"]]
    assert len(column(ents["/world/robots/robot/body"], "LineStrips3D:strips")[0]) == 2  # circle + heading

    poses = column(ents["/world/robots/robot"], "Transform3D:translation")
    assert len(poses) == 50 + 0  # one transform per ground-truth pose; odom does not move it
    assert poses[-1][0][0] == pytest.approx(math.sin(0.5 * math.pi * 49 / 50), abs=1e-6)

    track = column(ents["/world/tracks/robot/truth/0"], "LineStrips3D:strips")
    assert len(track[-1][0]) == 50  # the last strip holds the whole quarter circle
    assert track[-1][0][-1] == pytest.approx(poses[-1][0], abs=1e-6)

    scans = column(ents["/world/robots/robot/laser/scan"], "Points3D:positions")
    assert len(scans) == 10 and all(len(s) == 581 for s in scans)  # 681 beams, 100 without return
    assert scans[0][-1] == pytest.approx(
        [2.0 * math.cos(2 * math.pi / 3), 2.0 * math.sin(2 * math.pi / 3), 0.0], abs=1e-5
    )  # in the laser frame, left-most beam
    laser_mount = column(ents["/world/robots/robot/laser"], "Transform3D:translation")
    assert laser_mount == [[pytest.approx([0.16, 0.0, 0.0])]]

    sonar = column(ents["/world/robots/robot/sonar_front/ray"], "LineStrips3D:strips")
    assert sonar[0][0][1] == pytest.approx([1.25, 0.0, 0.0])

    bump_on = column(ents["/world/robots/robot/bump_left/detection"], "Points3D:positions")
    assert len(bump_on) == 1  # drawn once when pressed (then cleared), not 50 times
    events = column(ents["/events/robot"], "TextLog:text")
    assert events == [["bump_left on (/bump/left)"], ["cliff_left on (/cliff/left)"]]

    errors = column(ents["/plots/robot/odom_error/position_m"], "Scalars:scalars")
    assert len(errors) == 50
    assert errors[-1][0] == pytest.approx(
        0.02 * math.hypot(math.sin(0.5 * math.pi * 49 / 50), 1 - math.cos(0.5 * math.pi * 49 / 50)), rel=1e-3
    )


def test_long_track_is_split_into_continuous_segments(tmp_path):
    bag = write_bag(tmp_path / "long.mcap", create_messages(steps=TRACK_SEGMENT_POINTS + 40))
    ents = load_entities(bag_to_rerun(bag, tmp_path / "long.rrd", progress=False))
    first = column(ents["/world/tracks/robot/truth/0"], "LineStrips3D:strips")[-1][0]
    second = column(ents["/world/tracks/robot/truth/1"], "LineStrips3D:strips")[-1][0]
    assert len(first) == TRACK_SEGMENT_POINTS
    assert second[0] == first[-1]  # no gap between segments
    assert len(first) + len(second) - 1 == TRACK_SEGMENT_POINTS + 40


def test_namespaced_robot_is_named_by_its_namespace(tmp_path):
    bag = write_bag(tmp_path / "ns.mcap", create_messages(steps=10, ns="robot1"))
    ents = load_entities(bag_to_rerun(bag, tmp_path / "ns.rrd", progress=False))
    assert "/world/robots/robot1/laser/scan" in ents
    assert "/world/tracks/robot1/truth/0" in ents
    assert "/world/robots/robot" not in ents


def test_arm_meshes_logged_once_then_only_transforms(tmp_path):
    stl = tmp_path / "link1.stl"
    trimesh.creation.box(extents=[0.1, 0.1, 0.3]).export(stl)
    bag = write_bag(tmp_path / "arm.mcap", arm_messages(stl))
    ents = load_entities(bag_to_rerun(bag, tmp_path / "arm.rrd", progress=False))
    link = ents["/world/markers/robot_markers/links/1"]
    assert len(column(link, "Asset3D:blob")) == 1
    assert column(link, "Asset3D:media_type") == [["model/stl"]]
    assert len(column(link, "Transform3D:translation")) == 10
    q1 = column(ents["/plots/joint_states/position/q1"], "Scalars:scalars")
    assert [v[0] for v in q1] == pytest.approx([0.1 * k for k in range(10)])
    assert "/plots/joint_states/effort/q1" not in ents  # empty effort array: nothing plotted


def test_occupancy_grid_draws_obstacle_outline_in_world_coordinates(tmp_path):
    bag = write_bag(tmp_path / "simrobot.mcap", simrobot_messages())
    ents = load_entities(bag_to_rerun(bag, tmp_path / "simrobot.rrd", progress=False))
    cells = np.array(column(ents["/world/map/obstacles"], "Points3D:positions")[0])
    assert len(cells) == 10 + 8  # the block's interior cell is not drawn
    assert column(ents["/world/map"], "Transform3D:translation") == [[pytest.approx([-1.0, 0.0, 0.0])]]
    assert "/world/robots/r1" in ents and "/world/tracks/r1/truth/0" in ents


def test_unknown_type_is_skipped_with_a_warning(tmp_path):
    msgs = create_messages(steps=5) + [("/chatter", String(data="hi"), 0.05)]
    bag = write_bag(tmp_path / "unknown.mcap", sorted(msgs, key=lambda m: m[2]))
    with pytest.warns(UserWarning, match=r"/chatter of type std_msgs/msg/String is not drawn"):
        out = bag_to_rerun(bag, tmp_path / "unknown.rrd", progress=False)
    assert "/world/robots/robot" in load_entities(out)


def test_uninstalled_type_is_skipped_with_a_warning(tmp_path):
    bag = write_bag(tmp_path / "x.mcap", create_messages(steps=3))
    # Rename a supported type's schema to a package that is not installed.
    data = bag.read_bytes().replace(b"sensor_msgs/msg/Illuminance", b"nosuch_pkgs/msg/Illuminance")
    bag.write_bytes(data)
    with pytest.warns(UserWarning, match="nosuch_pkgs/msg/Illuminance"):
        out = bag_to_rerun(bag, tmp_path / "x.rrd", progress=False)
    assert "/world/robots/robot/cliff_left/detection" not in load_entities(out)


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
    errors = [v[0] for v in column(ents["/plots/robot/odom_error/position_m"], "Scalars:scalars")]
    assert len(errors) == 10 and max(errors) < 1e-6  # each odometry pose waits for the truth of its instant
    odom_track = column(ents["/world/tracks/robot/odom/0"], "LineStrips3D:strips")[-1][0]
    assert odom_track[-1] == pytest.approx([1.0, 2.9, 0.0], abs=1e-5)
