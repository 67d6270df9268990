"""The studio's logic without a browser: map editing, file round trips, workspace safety, drawing."""

from __future__ import annotations

import math
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from create_sim.configfile import NoiseConfig, parse_config
from create_sim.mapfile import CreateMap, load_map, parse_map
from create_sim.world_node import map_markers
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from studio.create import draw
from studio.create.mapedit import Beacon, MapDocument, Segment, VirtualWall, moved, polyline, rectangle, snap
from studio.create.ros_client import map_from_markers
from studio.shell.app import host_warning, parse_args
from studio.shell.processes import controller_command, parse_controller, world_ros_args
from studio.shell.svg import View, hex_rgb, rgb_hex
from studio.shell.workspace import MAX_UPLOAD_BYTES, Workspace

ROOT = Path(__file__).resolve().parent.parent


def same_map(a: CreateMap, b: CreateMap) -> bool:
    return (
        all(
            np.array_equal(getattr(a, k), getattr(b, k))
            for k in ("walls", "lines", "beacon_xy", "beacon_rgb", "virtwalls")
        )
        and a.beacon_ids == b.beacon_ids
    )


# ---------------------------------------------------------------- map document


def test_a_rectangle_is_four_axis_aligned_walls_sharing_corners():
    walls = rectangle(-2.0, 1.5, 2.0, -1.5)
    assert len(walls) == 4 and all(w.kind == "wall" for w in walls)
    for a, b in zip(walls, walls[1:] + walls[:1], strict=True):
        assert (a.x2, a.y2) == (b.x1, b.y1)
        assert a.x1 == a.x2 or a.y1 == a.y2


def test_a_multi_segment_wall_joins_consecutive_clicks_and_skips_repeated_points():
    walls = polyline([(0, 0), (1, 0), (1, 0), (1, 1)])
    assert [(w.x1, w.y1, w.x2, w.y2) for w in walls] == [(0, 0, 1, 0), (1, 0, 1, 1)]


def test_snapping_lands_exactly_on_the_grid():
    assert snap(0.30000000004, 0.1) == 0.3
    assert snap(-1.26, 0.25) == -1.25
    assert snap(0.123456, 0.0) == 0.123456


def test_undo_and_redo_step_through_every_edit_exactly():
    doc = MapDocument()
    doc.add(*rectangle(0, 0, 1, 1))
    doc.add(Beacon(0.5, 0.5, (1.0, 0.0, 0.0), doc.next_beacon_id()))
    doc.replace(4, moved(doc.elements[4], 0.1, 0.0))
    doc.remove(0)
    states = [list(doc.elements)]
    while doc.undo():
        states.append(list(doc.elements))
    assert [len(s) for s in states] == [4, 5, 5, 4, 0]
    assert states[1][4].x == pytest.approx(0.6) and states[2][4].x == 0.5
    while doc.redo():
        pass
    assert doc.elements == states[0]
    doc.undo()
    doc.add(Segment("line", 0, 0, 1, 1))  # a new edit drops the redo history
    assert not doc.redo()


def test_beacon_ids_default_to_the_first_free_b_number():
    doc = MapDocument()
    assert doc.next_beacon_id() == "b1"
    doc.add(Beacon(0, 0, (0, 0, 0), "b1"), Beacon(1, 0, (0, 0, 0), "b3"))
    assert doc.next_beacon_id() == "b2"


def test_selection_picks_the_nearest_element_within_the_tolerance():
    doc = MapDocument()
    doc.add(Segment("wall", 0, 0, 2, 0), Beacon(1, 1, (0, 0, 0), "b1"), VirtualWall(3, 3, 0.0, 2))
    assert doc.nearest(1.0, 0.05, 0.1) == 0
    assert doc.nearest(1.02, 0.98, 0.1) == 1
    assert doc.nearest(3.0, 3.0, 0.1) == 2
    assert doc.nearest(5.0, 5.0, 0.1) is None


def test_the_shipped_map_round_trips_exactly_through_the_editor(tmp_path):
    original = load_map(config_path("create/example.map"))
    doc = MapDocument()
    doc.load(original)
    saved = tmp_path / "copy.map"
    saved.write_text(doc.to_map().to_text())
    assert same_map(load_map(saved), original)
    again = MapDocument()
    again.load(load_map(saved))
    assert again.to_map().to_text() == saved.read_text()


def test_awkward_numbers_survive_a_save_and_load_bit_for_bit():
    doc = MapDocument()
    doc.add(Segment("wall", 0.1 + 0.2, -1e-7, math.pi, 12345.678901234567), VirtualWall(1 / 3, 2 / 3, -2.725, 3))
    doc.add(Beacon(1.267, -1.31, (1.0, 0.5, 0.0), "beac04"))
    assert same_map(parse_map(doc.to_map().to_text()), doc.to_map())


def test_the_config_form_values_round_trip_through_the_file_format():
    config = NoiseConfig(noise={"lidar": (0.01, 0.05), "odometry": (0.092, 0.05)}, com_delay=0.1)
    back = parse_config(config.to_text())
    assert back.noise == config.noise and back.com_delay == 0.1


# ---------------------------------------------------------------- the world's map seen through its markers


def test_the_map_rebuilt_from_a_worlds_markers_is_the_map_it_loaded():
    world = load_map(config_path("create/example.map"))
    rebuilt = map_from_markers(map_markers(world, None))
    assert rebuilt.beacon_ids == world.beacon_ids
    for key in ("walls", "lines", "beacon_xy", "beacon_rgb"):
        np.testing.assert_allclose(getattr(rebuilt, key), getattr(world, key), atol=1e-6)
    np.testing.assert_allclose(rebuilt.virtwalls, world.virtwalls, atol=1e-6)


# ---------------------------------------------------------------- workspace safety


def test_the_workspace_refuses_paths_outside_it(tmp_path):
    (tmp_path / "ws").mkdir()
    (tmp_path / "secret.txt").write_text("x")
    os.symlink(tmp_path / "secret.txt", tmp_path / "ws" / "link.map")
    ws = Workspace(tmp_path / "ws")
    for name in ("../secret.txt", "/etc/passwd", "a/../../secret.txt", "link.map", ""):
        with pytest.raises(InputError):
            ws.read_text(name, "map")
    assert ws.path("maps/room.map") == (tmp_path / "ws" / "maps" / "room.map").resolve()


def test_the_workspace_never_overwrites_unless_asked_and_limits_sizes(tmp_path):
    ws = Workspace(tmp_path)
    ws.write_text("a.map", "wall 0 0 1 1\n")
    with pytest.raises(InputError, match="exists"):
        ws.write_text("a.map", "")
    ws.write_text("a.map", "line 0 0 1 1\n", overwrite=True)
    assert ws.read_text("a.map", "map")[0] == "line 0 0 1 1\n"
    (tmp_path / "big.map").write_text("%" * (MAX_UPLOAD_BYTES + 1))
    with pytest.raises(InputError, match="limit"):
        ws.read_text("big.map", "map")


def test_new_data_folders_count_up_and_never_reuse_a_name(tmp_path):
    ws = Workspace(tmp_path)
    assert ws.new_folder_name("data/run") == "data/run_1"
    (tmp_path / "data" / "run_1").mkdir(parents=True)
    assert ws.new_folder_name("data/run") == "data/run_2"


# ---------------------------------------------------------------- command line, processes


def test_the_studio_listens_on_loopback_unless_told_and_then_warns():
    assert parse_args([]).host == "127.0.0.1"
    assert host_warning("127.0.0.1") is None and host_warning("localhost") is None and host_warning("::1") is None
    assert "anyone who can reach" in host_warning("0.0.0.0")


def test_a_bad_workspace_is_one_error_line_and_status_2(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "studio", "--workspace", str(tmp_path / "missing")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
    )
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [f"error: workspace {str(tmp_path / 'missing')!r} is not a folder"]


def test_controllers_run_executables_functions_or_commands_never_files_from_the_browser():
    exe = controller_command("create_bump_turn", ["-r", "__ns:=/r1"])
    assert exe[0] == sys.executable and exe[3:] == ["create_bump_turn", "--ros-args", "-r", "__ns:=/r1"]
    fn = controller_command("mypkg.ctrl:main", [])
    assert fn[3:] == ["mypkg.ctrl:main", "--ros-args"]
    cmd = controller_command("/opt/bin/my_ctrl --fast", [])
    assert cmd == ["/opt/bin/my_ctrl", "--fast", "--ros-args"]
    assert parse_controller("wander=mypkg.ctrl:main") == ("wander", "mypkg.ctrl:main")
    with pytest.raises(InputError):
        parse_controller("no_equals_sign")


def test_a_world_started_by_the_studio_gets_its_files_and_pose_verbatim():
    args = world_ros_args("/r2", "/ws/it's.map", "", (1.0, -0.5, 0.25))
    assert "map_file:='/ws/it''s.map'" in args and "config_file:=''" in args
    assert "initial_pose:=[1.0, -0.5, 0.25]" in args
    assert args[-4:] == ["-r", "__ns:=/r2", "-r", "/clock:=/r2/clock"]


# ---------------------------------------------------------------- drawing


def test_a_scan_is_drawn_as_one_polyline_of_every_beam():
    view = View()
    readings = draw.Readings(pose=(0.0, 0.0, 0.0), scan=(-2.0, 4.0 / 680, np.full(681, 1.0, dtype=np.float32)))
    svg = draw.sensors_svg(view, readings, {"lidar"})
    assert svg.count("<polyline") == 1
    points = svg.split('points="')[1].split('"')[0].split()
    assert len(points) == 681


def test_beacon_ids_are_escaped_in_the_drawing():
    world = parse_map("beacon 0 0 [1 0 0] <script>alert(1)</script>")
    svg = draw.map_svg(View(), world)
    assert "<script>" not in svg and "&lt;script&gt;" in svg


def test_the_view_maps_pixels_back_to_the_same_world_point():
    view = View(centre_x=1.5, centre_y=-2.0, scale=73.0)
    px, py = view.to_px(0.3, 0.7)
    assert view.to_world(float(px), float(py)) == (pytest.approx(0.3), pytest.approx(0.7))
    assert hex_rgb(rgb_hex((1.0, 0.5, 0.0))) == (1.0, 0.502, 0.0)


def test_a_taken_port_is_one_error_line_and_status_2(tmp_path):
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        result = subprocess.run(
            [sys.executable, "-m", "studio", "--workspace", str(tmp_path), "--port", str(port)],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=60,
        )
    assert result.returncode == 2
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith(f"error: cannot listen on 127.0.0.1:{port}: ")


def test_zooming_at_a_pixel_keeps_the_world_point_under_it():
    view = View(centre_x=1.0, centre_y=2.0, scale=50.0)
    before = view.to_world(620.0, 130.0)
    view.zoom_at(620.0, 130.0, 1.2)
    assert view.scale == 60.0
    assert view.to_world(620.0, 130.0) == (pytest.approx(before[0]), pytest.approx(before[1]))


def test_dragging_the_view_keeps_the_grabbed_world_point_under_the_mouse():
    view = View(centre_x=1.0, centre_y=2.0, scale=50.0)
    grabbed = view.to_world(300.0, 200.0)
    view.pan((1.0, 2.0), 40.0, -25.0)  # the mouse went 40 px right and 25 px up
    assert view.to_world(340.0, 175.0) == (pytest.approx(grabbed[0]), pytest.approx(grabbed[1]))


def test_a_world_is_followed_only_once_its_node_name_is_known(monkeypatch):
    """DDS can report a topic before the name of the node publishing it; parameter clients made
    for ``_NODE_NAME_UNKNOWN_`` would never reach the world, so the studio waits for the name."""
    from rclpy.topic_endpoint_info import TopicEndpointInfo

    from studio.create.ros_client import POSE_TYPE, CreateRos
    from studio.shell.ros import UNKNOWN_NODE_NAME, StudioRos

    def endpoint(name: str, namespace: str) -> TopicEndpointInfo:
        return TopicEndpointInfo(node_name=name, node_namespace=namespace, topic_type=POSE_TYPE)

    shared = StudioRos()  # not spun: this test runs the discovery rounds itself
    ros = CreateRos(shared)
    try:
        for timer in list(ros.node.timers):  # this test runs the discovery rounds itself
            ros.node.destroy_timer(timer)
        graph = [endpoint(UNKNOWN_NODE_NAME, "_NODE_NAMESPACE_UNKNOWN_")]
        monkeypatch.setattr(ros.node, "get_topic_names_and_types", lambda: [("/box/overhead_pose", [POSE_TYPE])])
        monkeypatch.setattr(ros.node, "get_publishers_info_by_topic", lambda topic: graph)
        monkeypatch.setattr(ros.node, "count_publishers", lambda topic: len(graph))
        ros._discover()
        assert ros.namespaces() == []
        graph[:] = [endpoint("create_world", "/box")]
        ros._discover()
        assert ros.namespaces() == ["/box"] and ros.robots["/box"].node_name == "/box/create_world"
        assert ros._robots["/box"].set_params.srv_name == "/box/create_world/set_parameters"
    finally:
        shared.shutdown()


# ---------------------------------------------------------------- namespaces, clocks, recording, stopping


class FakeGraph:
    """The two graph questions the studio asks about worlds: ``(clock topic, node namespace)``."""

    def __init__(self, clocks: list[tuple[str, str]]) -> None:
        self.clocks = clocks

    def clock_publishers(self) -> list[tuple[str, str]]:
        return self.clocks


def sleeper(tmp_path: Path, label: str, exit_after_s: float, clock: str = ""):
    """A child that takes ``exit_after_s`` to finish after SIGINT (a world closing down)."""
    from studio.shell.processes import Child

    code = (
        "import signal, sys, time\n"
        # Its stop's start and end on the machine-wide monotonic clock: tests compare children.
        "def stop(*a):\n"
        "    print('stopping', time.monotonic(), flush=True)\n"
        f"    time.sleep({exit_after_s!r})\n"
        "    print('stopped', time.monotonic(), flush=True)\n"
        "    sys.exit(0)\n"
        "signal.signal(signal.SIGINT, stop)\n"
        "print('ready', flush=True)\n"
        "while True: time.sleep(0.05)\n"
    )
    child = Child(label, [sys.executable, "-c", code], cwd=tmp_path, clock=clock)
    deadline = time.monotonic() + 30.0
    while "ready" not in child.output:  # its SIGINT handler is in place
        assert time.monotonic() < deadline and child.running
        time.sleep(0.01)
    return child


def test_each_new_world_defaults_to_a_free_namespace_and_an_occupied_one_is_refused_with_the_reason(tmp_path):
    from studio.create.family import CreateFamily
    from studio.shell.app import Studio

    studio = Studio(workspace=Workspace(tmp_path), controllers={}, families=(CreateFamily(),))
    studio.ros = FakeGraph([("/clock", "/create1"), ("/arm1/clock", "/arm1")])  # one world owns /clock
    assert studio.free_namespace("create") == "/create2"
    assert studio.free_namespace("arm") == "/arm2"
    assert studio.free_namespace("simrobot") == "/simrobot1"
    assert "already runs in /create1" in studio.namespace_refusal("/create1")
    assert "already runs in /arm1" in studio.namespace_refusal("/arm1")  # any kind of world
    assert "a world in / would publish a second one" in studio.namespace_refusal("")
    assert studio.namespace_refusal("/create2") is None
    for bad, why in (
        ("/bad name!", "it holds ' ', '!'"),
        ("/a//b", "it has an empty part"),
        ("/2nd", "its part '2nd' starts"),
    ):
        assert f"namespace {bad!r} is not a ROS name ({why}" in studio.namespace_refusal(bad)  # not rcl's C path
    assert studio.clock_owner() == "/create1"
    assert (studio.clock_of("/create1"), studio.clock_of("/arm1")) == ("/clock", "/arm1/clock")  # for controllers
    studio.ros = FakeGraph([])
    started = sleeper(tmp_path, "create_world /mine", 0.0, clock="/clock")
    studio.family(CreateFamily).worlds["/mine"] = started  # started a moment ago: not on the graph yet
    try:
        assert "create_world /mine already runs in /mine" in studio.namespace_refusal("/mine")
        assert studio.clock_owner() == "/mine"
    finally:
        started.stop()
    assert studio.namespace_refusal("/mine") is None and studio.clock_owner() is None


def test_only_a_world_owning_the_clock_publishes_clock_the_others_and_their_controllers_use_theirs():
    from studio.shell.processes import clock_topic, namespace_args

    assert namespace_args("/create1", owns_clock=True) == ["-r", "__ns:=/create1"]
    assert namespace_args("/arm1") == ["-r", "__ns:=/arm1", "-r", "/clock:=/arm1/clock"]
    assert namespace_args("") == []
    assert (clock_topic("/create1", True), clock_topic("/arm1", False), clock_topic("", False)) == (
        "/clock",
        "/arm1/clock",
        "/clock",
    )


def test_a_recording_of_one_world_is_on_its_sim_time_and_of_several_on_wall_time():
    from studio.shell.app import recording_clock, world_namespaces

    one = [("/clock", "/create1")]
    assert recording_clock(one) == ("sim", "sim time of the world in /create1")
    several = [("/clock", "/create1"), ("/arm1/clock", "/arm1"), ("/simrobot1/clock", "/simrobot1")]
    assert world_namespaces(several) == {"/create1", "/arm1", "/simrobot1"}
    clock, why = recording_clock(several)
    assert clock == "wall" and why == "wall time: 3 worlds, each with its own sim time"
    assert recording_clock([("/arm1/clock", "/arm1")])[0] == "wall"  # its clock is not /clock
    assert recording_clock([])[0] == "auto"


def test_children_are_stopped_together_within_one_timeout(tmp_path):
    from studio.shell.processes import stop_all

    children = [sleeper(tmp_path, f"world {i}", 1.0) for i in range(5)]
    stop_all(children, timeout=10.0)  # one after another would still end in time: the stamps tell
    assert [c.process.returncode for c in children] == [0] * 5  # none killed: each ended in the timeout
    for child in children:
        child.error_line()  # its last lines read
    stamps = {what: [float(line.split()[1]) for c in children for line in c.output if line.startswith(what)]
              for what in ("stopping ", "stopped ")}  # fmt: skip
    # Together: every child had its SIGINT (and began its 1 s stop) before any had finished.
    assert len(stamps["stopping "]) == len(stamps["stopped "]) == 5
    assert max(stamps["stopping "]) < min(stamps["stopped "]), stamps


def test_a_stuck_child_is_killed_when_the_timeout_runs_out(tmp_path):
    from studio.shell.processes import stop_all

    stuck = sleeper(tmp_path, "stuck", 60.0)
    started = time.monotonic()
    stop_all([stuck], timeout=0.5)
    assert not stuck.running and time.monotonic() - started < 3.0


def test_key_presses_step_from_the_worlds_last_command_whoever_sent_it():
    from create_sim.teleop import ANGULAR_STEP, LINEAR_STEP
    from studio.create.sim_drive import command_steps

    assert command_steps((0.0, 0.0)) == [0, 0]
    assert command_steps((3 * LINEAR_STEP, -2 * ANGULAR_STEP)) == [3, -2]
    assert command_steps((0.30000000000000004, 0.0)) == [3, 0]  # float noise of 3 × 0.1


def test_the_view_fits_again_when_the_map_arrives_after_the_first_fit():
    from studio.create.sim_view import fit_due

    assert fit_due(None, 0)  # first shown, no map yet: fit to the robot
    assert fit_due(0, 1)  # then its map arrives: fit to the map
    assert not fit_due(1, 1) and not fit_due(1, 2)  # later map changes keep the user's zoom
    assert not fit_due(0, 0)


def test_the_live_view_sends_only_what_changed_and_each_track_point_once():
    from types import SimpleNamespace

    from studio.create.ros_client import RobotState
    from studio.create.sim_view import SimView

    st = RobotState(ns="/r", pose=(1.0, 2.0, 0.5))
    st.scan, st.scan_stamp = (-2.0, 4.0 / 680, np.array([1.0, np.inf, 0.25])), 3.5
    st.track.extend([(0.0, 0.0), (0.5, 0.0)])
    tab = SimpleNamespace(selected="/r", ros=SimpleNamespace(robots={"/r": st}))
    view = SimView(tab)
    first = view.live_message(st, "/r")
    assert first["pose"] == [1.0, 2.0, 0.5] and first["label"] == "/r" and first["track_reset"]
    assert first["scan"] == [-2.0, 4.0 / 680, [1000, -1, 250], "3.500000000"]  # -1: nothing in range
    assert first["track"] == [[0.0, 0.0], [0.5, 0.0]]
    assert view.live_message(st, "/r") == {}  # nothing new: nothing sent
    st.pose = (1.1, 2.0, 0.5)
    st.track.append((1.0, 0.0))
    assert view.live_message(st, "/r") == {"pose": [1.1, 2.0, 0.5], "track": [[1.0, 0.0]]}
    st.track.clear()  # Set position: the track starts again
    st.track.append((5.0, 5.0))
    assert view.live_message(st, "/r") == {"track_reset": True, "track": [[5.0, 5.0]]}
    view.zoom(2.0)
    assert set(view.live_message(st, "/r")) == {"view"}


def test_the_live_view_s_style_names_every_mount_the_page_draws():
    js = (ROOT / "studio" / "create" / "static" / "sim_view.js").read_text()
    style = draw.live_style((800, 600), 2000)
    for name in re.findall(r"mount\(pose, \"(\w+)\"\)", js):
        assert name in style["mounts"]
    for key in set(re.findall(r"\bst\.(\w+)", js)):
        assert key in style, key  # the page draws with the studio's colours and facts, none of its own


def test_an_upload_that_is_not_text_or_too_large_is_an_error_naming_the_file():
    from studio.shell.workspace import upload_text

    assert upload_text("lab.map", "wall 0 0 1 1 % é\n".encode(), "map") == "wall 0 0 1 1 % é\n"
    with pytest.raises(InputError, match=r"photo.png: not a text file \(byte 0 is not UTF-8\)"):
        upload_text("photo.png", b"\x89PNG\r\n\x1a\n", "map")
    with pytest.raises(InputError, match="NUL"):
        upload_text("a.bin", b"wall\x00", "map")
    with pytest.raises(InputError, match=f"more than the limit {MAX_UPLOAD_BYTES}"):
        upload_text("big.map", b"%" * (MAX_UPLOAD_BYTES + 1), "map")


def test_a_number_below_its_minimum_is_flagged_not_clamped():
    from studio.shell.kit import at_least

    ((message, ok),) = at_least(0.0).items()
    assert message == "must be ≥ 0" and ok(0.0) and ok(None) and not ok(-1.0)


def test_an_empty_or_non_numeric_pose_field_is_an_error_not_zero():
    from studio.create.sim_runs import initial_pose

    assert initial_pose(1.0, -0.5, 0.25) == (1.0, -0.5, 0.25)
    with pytest.raises(InputError, match="initial pose y: a number is needed"):
        initial_pose(1.0, None, 0.0)


def test_studio_help_names_every_familys_pages_and_their_addresses():
    from studio.shell.kit import PAGES

    shown = subprocess.run(
        [sys.executable, "-m", "studio", "--help"], capture_output=True, text=True, timeout=60, check=True
    ).stdout
    for target, text, _what in PAGES:
        assert re.search(rf"^  {re.escape(text)} +{re.escape(target)} ", shown, re.MULTILINE), shown
    for window in ("SimulatorGUI", "MapMakerGUI", "ConfigMakerGUI", "ReplayGUI", "SIMROBOT editor", "Arm"):
        assert window in shown


def test_the_lidar_plot_draws_each_beam_at_its_angle_and_range_and_no_return_at_the_top():
    from studio.create.lidar_plot import RANGE_TOP_M, beam_px, lidar_plot_svg, plot_area

    left, top, width, height = plot_area()
    px, py = beam_px(np.radians([-120.0, 0.0, 120.0]), np.array([2.0, np.inf, np.nan]))
    assert px.tolist() == pytest.approx([left, left + width / 2, left + width])  # right-most beam on the left
    assert py.tolist() == pytest.approx([top + height * (1 - 2.0 / RANGE_TOP_M), top, top])
    svg = lidar_plot_svg((math.radians(-120), math.radians(240) / 680, np.full(681, 1.5, np.float32)))
    assert svg.count(",") == 681 and "lidar-ranges" in svg
    assert "lidar-ranges" not in lidar_plot_svg(None)  # the axes only, until a scan arrives


def test_stopping_a_controller_waits_off_the_event_loop_showing_it_stopping_until_it_has_ended(tmp_path):
    """A controller takes seconds to end after SIGINT (up to 7 s before it is killed): the page's
    Stop must not freeze the event loop every tab is served from meanwhile."""
    import asyncio

    from studio.create.family import CreateFamily
    from studio.create.sim_runs import stop_controller
    from studio.shell.app import Studio

    create = CreateFamily()
    studio = Studio(workspace=Workspace(tmp_path), controllers={}, families=(create,))
    child = create.controllers["/r1"] = sleeper(tmp_path, "slow_controller", 1.0)
    stops: list[bool] = []  # per robot stop: was the controller still running then?

    async def run() -> list[str]:
        seen = []
        stopping = asyncio.create_task(stop_controller(studio, "/r1", lambda: stops.append(child.running)))
        await asyncio.sleep(0)  # the task runs up to its wait
        while not stopping.done():  # the loop runs on while the controller ends
            if child.running:
                seen.append(f"{'/r1' in create.stopping} {'/r1' in create.controllers}")
            await asyncio.sleep(0.01)
        assert await stopping is child
        return seen

    seen = asyncio.run(run())
    assert seen and set(seen) == {"True False"}  # shown as stopping, no longer the namespace's controller
    assert not child.running and child.process.returncode == 0 and create.stopping == {}
    assert stops == [True, False]  # the robot stopped at once and again once its controller had ended
    assert "stopped" in " ".join(child.output)


def test_stopping_a_world_waits_off_the_event_loop_and_keeps_its_namespace_until_it_has_ended(tmp_path, monkeypatch):
    """Stop world waits up to 5 s (then SIGKILL) for the world to end: the event loop every tab is
    served from runs on meanwhile, the namespace stays taken until the world is gone, and a
    second click while it stops starts no second stop."""
    import asyncio

    from nicegui import ui

    from studio.shell.kit import stop_started_world

    notes: list[str] = []
    monkeypatch.setattr(ui, "notify", lambda text, **_kw: notes.append(text))
    child = sleeper(tmp_path, "slow_world", 1.0, clock="/r1/clock")
    worlds = {"/r1": child}

    async def run() -> list[bool]:
        seen = []
        stopping = asyncio.create_task(stop_started_world(worlds, "/r1"))
        await asyncio.sleep(0)  # the task runs up to its wait
        await stop_started_world(worlds, "/r1")  # a second click meanwhile
        while not stopping.done():
            if child.running:
                seen.append("/r1" in worlds)
            await asyncio.sleep(0.01)
        await stopping
        return seen

    seen = asyncio.run(run())
    assert seen and set(seen) == {True}  # still its namespace's world while it ends
    assert worlds == {} and not child.running and child.process.returncode == 0
    assert notes == ["stopping slow_world…", "slow_world is stopping", "slow_world stopped"]
