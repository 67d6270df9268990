"""What tells robots apart in the Rerun views, read back from the .rrd: states, colours, labels,
marks, the legend, and the demo's crash."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rerun as rr
from geometry_msgs.msg import Point
from nav_msgs.msg import OccupancyGrid
from rerun_test_helpers import (
    blueprint_views,
    column,
    create_messages,
    load_entities,
    packed,
    robots_outlines,
    simrobot_messages,
    stamp,
    write_bag,
)
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, UInt8
from visualization_msgs.msg import Marker, MarkerArray

from sim_tools.rerun_kit.contract import DEFAULT_LOOK
from sim_tools.rerun_view.convert import bag_to_rerun
from sim_tools.rerun_view.logger import RerunLogger

RED = (1.0, 0.0, 0.0)


def _convert(tmp_path, msgs) -> dict:
    bag = write_bag(tmp_path / "b.mcap", sorted(msgs, key=lambda m: m[2]))
    return load_entities(bag_to_rerun(bag, tmp_path / "b.rrd", progress=False))


def _texts(batches) -> list[str]:
    return [t[0] for t in column(batches, "TextLog:text")]


def _wheel_cmd(left: float, right: float, t: float) -> JointState:
    msg = JointState(name=["left", "right"], velocity=[left, right])
    msg.header.stamp = stamp(t)
    return msg


def test_a_latched_power_is_a_state_in_the_label_and_only_a_switch_is_an_event(tmp_path):
    msgs = [*simrobot_messages(), ("/r1/power", Bool(data=True), 0.0), ("/r1/power", Bool(data=False), 3.0)]
    ents = _convert(tmp_path, msgs)
    assert _texts(ents["/events/r1"]) == ["    3.00 s  r1: power off"]  # not "power on" at the start
    assert [lv[0] for lv in column(ents["/events/r1"], "TextLog:level")] == ["INFO"]
    assert not [e for e in ents if "/power" in e]  # no detector dot hiding the robot
    labels = [t[0] for t in column(ents["/top/map/robots/r1/follow/label"], "Points2D:labels")]
    assert labels == ["r1", "r1 off"]


def test_plots_take_a_robots_world_colour_even_when_its_outline_comes_after_them(tmp_path):
    msgs = [*simrobot_messages(), ("/robots", robots_outlines([(0.1, 0.0, RED)]), 1.0)]
    for k in range(5):  # the obstacle and the wheel commands start before the outline
        msgs += [("/r1/sens1/obstacle", UInt8(data=k % 2), float(k)), ("/r1/wheel_cmd", _wheel_cmd(k, 0.5, k), k)]
    ents = _convert(tmp_path, msgs)
    red = packed((255, 0, 0))
    assert column(ents["/plots/obstacle/r1/sens1"], "SeriesLines:colors") == [[red]]
    assert column(ents["/plots/commands/r1/wheel_left"], "SeriesLines:colors") == [[red]]
    # the right wheel never changes (alg2's is always 0.5 rad/s) and is still plotted, darker
    right = ents["/plots/commands/r1/wheel_right"]
    assert [v[0] for v in column(right, "Scalars:scalars")] == [0.5] * 5
    assert column(right, "SeriesLines:colors") == [[packed((140, 0, 0))]]


def test_each_robot_has_one_label_below_its_body_with_its_obstacle_number(tmp_path):
    msgs = [*simrobot_messages(), ("/robots", robots_outlines([(0.0, 0.0, RED)]), 0.0)]
    ents = _convert(tmp_path, msgs)
    label = ents["/top/map/robots/r1/follow/label"]
    assert [t[0] for t in column(label, "Points2D:labels")] == ["r1", "r1 (#2)"]  # the first robot: #2
    # in the follow frame (the screen's axes, +y down), straight below the robot, clear of its body
    x, y = column(label, "Points2D:positions")[-1][0]
    outline = max(math.hypot(p.x, p.y) for p in robots_outlines([(0.0, 0.0, RED)]).markers[0].points)
    assert x == 0.0 and y == pytest.approx(DEFAULT_LOOK.label_offset_m) and y > outline
    body = [e for e in ents if e.startswith("/top/map/robots/r1/body")]
    assert body and not [e for e in body if column(ents[e], "Points2D:labels")]  # no name on the body
    # the heading reaches 12 cm: ~17 px on a 5 m map 700 px wide, out of the 10 px dot and the outline
    heading = column(ents["/top/map/robots/r1/body/heading"], "Arrows2D:vectors")[-1][0]
    assert heading == pytest.approx([0.12, 0.0]) and heading[0] > 2.5 * outline


def test_the_legend_names_each_robots_colour_and_what_the_marks_mean(tmp_path):
    msgs = [
        *simrobot_messages(),
        ("/robots", robots_outlines([(0.0, 0.0, RED)]), 0.0),
        ("/r1/sens1/obstacle", UInt8(data=1), 1.0),
        ("/r1/crashed", Bool(data=False), 0.0),
    ]
    bag = write_bag(tmp_path / "b.mcap", sorted(msgs, key=lambda m: m[2]))
    out = bag_to_rerun(bag, tmp_path / "b.rrd", progress=False)
    legend = column(load_entities(out)["/legend"], "TextDocument:text")[-1][0]
    assert "r1 red #2" in legend
    assert "dark red x: where a robot crashed" in legend and "1 a wall" in legend
    assert "bumper" not in legend and "LIDAR" not in legend  # a SIMROBOT world has neither
    views = {v["ViewBlueprint:display_name"][0]: v for v in blueprint_views(out)}
    assert views["Legend"]["ViewBlueprint:space_origin"] == ["/legend"]


def test_virtual_wall_fields_are_cut_at_the_outer_walls(tmp_path):
    msgs = create_messages(steps=5)
    field = Marker(ns="virtual_wall_fields", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
    field.header.frame_id = "map"
    field.points = [Point(x=x, y=y) for x, y in ((0.0, 0.0), (5.0, 1.0), (5.0, -1.0), (0.0, 0.0))]
    field.color.g, field.color.a = 1.0, 1.0
    walls = msgs[0][1]  # create_messages' walls: x up to 2 m
    msgs[0] = ("/map_markers", MarkerArray(markers=[*walls.markers, field]), 0.0)
    ents = _convert(tmp_path, msgs)
    outline = np.array(column(ents["/top/map/map_markers/virtual_wall_fields/0"], "LineStrips2D:strips")[0][0])
    assert outline[:, 0].max() == pytest.approx(2.0)  # cut at the wall at x = 2 m…
    assert outline[:, 1].max() == pytest.approx(0.4) and np.allclose(outline[0], outline[-1])  # …still closed


def test_a_live_series_and_the_legend_take_the_robots_colour_when_its_outline_arrives(tmp_path):
    rec = rr.RecordingStream("robot_sims_test")
    out = tmp_path / "live.rrd"
    rec.save(out)
    logger = RerunLogger(rec, {"/r1/pose": "geometry_msgs/msg/PoseStamped", "/robots": "MarkerArray"})
    for topic, msg, t in simrobot_messages()[:2]:  # the map and r1's first pose
        logger.log(topic, msg, int(t * 1e9))
    logger.log("/r1/sens1/obstacle", UInt8(data=1), 1)
    layout = logger.layout_version
    logger.log("/robots", robots_outlines([(0.0, 0.0, RED)]), 2)
    assert logger.layout_version > layout and "r1 red #2" in logger.legend()  # the live view resends both
    rec.disconnect()
    colors = column(load_entities(out)["/plots/obstacle/r1/sens1"], "SeriesLines:colors")
    assert colors[0] != [packed((255, 0, 0))] and colors[-1] == [packed((255, 0, 0))]


def test_the_simrobot_demo_recording_shows_r5_crash_and_every_robot_apart(tmp_path):
    from sim_tools.demo import _Recording
    from simrobot_sim.demo import CRASH_ROBOT, demo_world, run_demo

    recording = _Recording(tmp_path / "bag")
    run_demo(tmp_path, steps=200, extra_nodes=recording)  # r5 crashes at 188 s
    recording.close()
    ents = load_entities(bag_to_rerun(tmp_path / "bag", tmp_path / "demo.rrd", progress=False))
    assert _texts(ents["/events/r5"]) == ["  188.00 s  r5: crashed"]
    assert [lv[0] for lv in column(ents["/events/r5"], "TextLog:level")] == ["WARN"]
    assert len(column(ents["/top/map/marks/r5/crashes"], "LineStrips2D:strips")[-1]) == 2  # one cross
    assert column(ents["/top/map/robots/r5/follow/label"], "Points2D:labels")[-1] == ["r5 (#6) crashed"]
    names = [r.name for r in demo_world().robots]
    assert not [e for e in ents if e.startswith("/events/") and e != "/events/r5"]  # no power lines
    for number, robot in enumerate(demo_world().robots, start=2):
        rgb = tuple(round(255 * c) for c in robot.color)
        assert column(ents[f"/top/map/robots/{robot.name}/body"], "Points2D:colors")[-1] == [packed(rgb)]
        for tab in ("obstacle", "range"):  # a robot whose sonar never saw anything has no series
            if f"/plots/{tab}/{robot.name}/sens1" in ents:
                assert column(ents[f"/plots/{tab}/{robot.name}/sens1"], "SeriesLines:colors") == [[packed(rgb)]]
        assert f"/plots/commands/{robot.name}/wheel_right" in ents
        labels = column(ents[f"/top/map/robots/{robot.name}/follow/label"], "Points2D:labels")
        assert [f"{robot.name} (#{number})"] in labels
    assert names[-1] == CRASH_ROBOT.name
    assert len([e for e in ents if e.startswith("/plots/obstacle/")]) >= 3


def test_every_grid_label_is_inside_the_opening_view_when_the_map_ends_between_whole_metres(tmp_path):
    msgs = create_messages(steps=3)
    for marker in msgs[0][1].markers:  # walls from -2.3 m to 1.7 m: the Create's grid map's margins
        for p in marker.points:
            p.x -= 0.3
            p.y -= 0.3
    bag = write_bag(tmp_path / "b.mcap", msgs)
    out = bag_to_rerun(bag, tmp_path / "b.rrd", progress=False)
    (top,) = [v for v in blueprint_views(out) if v["ViewBlueprint:display_name"] == ["Map (top-down)"]]
    bounds = top["VisualBounds2D:range"][0]
    labels = load_entities(out)["/top/map/grid/labels"]
    assert column(labels, "Points2D:labels")[0][:2] == ["-2 m", "-1 m"]
    for x, y in column(labels, "Points2D:positions")[0]:  # the view draws the map mirrored: -y
        assert bounds["x_range"][0] < x < bounds["x_range"][1] and bounds["y_range"][0] < -y < bounds["y_range"][1]


def test_the_grid_labels_the_last_metre_of_a_map_whose_float32_resolution_falls_short_of_it(tmp_path):
    grid = OccupancyGrid()
    grid.header.frame_id = "map"
    grid.info.resolution, grid.info.width, grid.info.height = 0.01, 500, 100  # 0.01 as float32: 0.0099999998
    grid.data = [0] * (500 * 100)
    ents = _convert(tmp_path, [("/map", grid, 0.0), *simrobot_messages()[1:]])
    labels = column(ents["/top/map/grid/labels"], "Points2D:labels")[0]
    assert labels == ["0 m", "1 m", "2 m", "3 m", "4 m", "5 m", "0 m", "1 m"]
