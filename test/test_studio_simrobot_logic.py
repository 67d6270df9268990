"""The SIMROBOT editor's world in memory, without a browser: what it saves is what
``simrobot_world`` loads, and it refuses what the command line refuses, with the same words."""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pytest

from sim_runtime.errors import InputError
from simrobot_sim.world_file import RobotSpec, WorldSpec, load_bitmap, load_world
from studio.shell.svg import View
from studio.shell.workspace import Workspace
from studio.simrobot import fields
from studio.simrobot.doc import WorldDraft, blank_walls, map_image, new_sensor, paint_disc, parse_vertices
from studio.simrobot.draw import MIN_ROBOT_PX, hit_radius_m, robot_svg
from studio.simrobot.editor_algorithms import ALGORITHM_PREFIX, editable_algorithm, new_algorithm


def test_a_saved_bitmap_loads_back_as_the_same_obstacles(tmp_path):
    walls = blank_walls(0.5, 0.3, 0.01)
    walls[10:20, 5:8] = True
    map_image(walls).save(tmp_path / "m.png")
    assert np.array_equal(load_bitmap(tmp_path / "m.png"), walls)


def test_the_brush_paints_and_erases_a_disc_of_cells():
    walls = np.zeros((50, 50), dtype=bool)
    assert paint_disc(walls, 25.0, 25.0, 3.0, True)
    assert walls[25, 25] and walls[23, 25] and not walls[20, 25]
    assert not paint_disc(walls, 25.0, 25.0, 3.0, True)  # nothing new
    assert paint_disc(walls, 25.0, 25.0, 1.0, False)
    assert not walls[25, 25] and walls[22, 25]
    assert not paint_disc(walls, -10.0, -10.0, 2.0, True)  # off the map: ignored


def test_a_new_sensor_has_the_manuals_defaults():
    s = new_sensor("sens1")
    assert (s.kind, s.position, s.axis, s.rays, s.range) == ("ultrasonic", (0.05, 0.0), 0.0, 30, 0.30)
    assert math.isclose(math.degrees(s.beamwidth), 60.0)


def test_a_world_saved_by_the_editor_loads_in_simrobot_world_as_edited(tmp_path):
    doc = WorldDraft(walls=blank_walls(1.0, 0.6, 0.01), dt=0.1)
    a = doc.add_robot(0.3, 0.3)
    b = doc.add_robot(0.7, 0.3)
    doc.robots[0] = replace(a, heading=math.radians(30), sensors=(new_sensor("front", "laser"),), scale=1.5)
    doc.robots[1] = replace(b, power=False, shape=((-0.03, -0.03), (0.03, -0.03), (0.0, 0.04)), controller=None)
    map_image(doc.walls).save(tmp_path / "map.png")
    (tmp_path / "w.yaml").write_text(doc.world_yaml("map.png"))
    spec = load_world(tmp_path / "w.yaml")
    assert spec.robots == tuple(doc.robots)
    assert np.array_equal(spec.walls, doc.walls) and spec.dt == 0.1
    assert doc.check("w.yaml").robots == spec.robots


def test_a_world_opened_and_saved_again_keeps_the_keys_the_editor_has_no_field_for(tmp_path):
    doc = WorldDraft(walls=blank_walls(1.0, 0.6, 0.01), dt=0.1)
    doc.add_robot(0.3, 0.3)
    map_image(doc.walls).save(tmp_path / "map.png")
    text = doc.world_yaml("map.png") + "steps_limit: 50\nsensor_model: original\nthreads: 1\n"
    (tmp_path / "w.yaml").write_text(text)
    opened = WorldDraft.from_spec(load_world(tmp_path / "w.yaml"))
    (tmp_path / "again.yaml").write_text(opened.world_yaml("map.png"))
    again = load_world(tmp_path / "again.yaml")
    assert (again.steps_limit, again.sensor_model, again.threads) == (50, "original", 1)
    assert again.history_steps == 10000  # untouched keys stay out of the file


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.robots.__setitem__(1, replace(d.robots[1], name="r1")), "duplicate robot name 'r1'"),
        (lambda d: d.robots.__setitem__(1, replace(d.robots[1], position=(0.31, 0.3))), "overlaps robot 'r1'"),
        (lambda d: d.walls.__setitem__((slice(60, 80), slice(20, 40)), True), "placed on an obstacle (wall)"),
    ],
)
def test_validation_gives_the_command_lines_message(edit, message):
    doc = WorldDraft(walls=blank_walls(1.0, 0.6, 0.01))
    doc.add_robot(0.3, 0.3)
    doc.add_robot(0.7, 0.3)
    edit(doc)
    with pytest.raises(InputError, match="^w.yaml: robots\\[1\\].*" + message.replace("(", "\\(").replace(")", "\\)")):
        doc.check("w.yaml")


def test_shape_vertices_are_read_from_lines_and_bad_lines_are_named():
    assert parse_vertices("-0.02, 0.03\n0 0.04\n\n0.04,0\n") == ((-0.02, 0.03), (0.0, 0.04), (0.04, 0.0))
    with pytest.raises(InputError, match="shape line 2"):
        parse_vertices("0, 0\nx, 1\n1, 1")
    with pytest.raises(InputError, match="at least 3"):
        parse_vertices("0, 0\n1, 1")


def test_importing_a_colour_bitmap_gives_simrobot_worlds_error(tmp_path):
    from PIL import Image

    Image.new("RGB", (10, 10), (255, 0, 0)).save(tmp_path / "red.png")
    with pytest.raises(InputError, match=r"red\.png.*colour image"):
        WorldDraft.from_image(tmp_path / "red.png")


def test_the_world_s_resolution_steps_limit_and_step_time_are_saved_and_read_back(tmp_path):
    doc = WorldDraft(walls=blank_walls(1.0, 0.6, 0.01), resolution=0.02, steps_limit=300.0, replay_step_time=0.05)
    doc.add_robot(0.3, 0.3)
    map_image(doc.walls).save(tmp_path / "map.png")
    (tmp_path / "w.yaml").write_text(doc.world_yaml("map.png"))
    spec = load_world(tmp_path / "w.yaml")
    assert (spec.resolution, spec.steps_limit, spec.replay_step_time) == (0.02, 300, 0.05)
    again = WorldDraft.from_spec(spec)
    assert (again.resolution, again.steps_limit, again.replay_step_time) == (0.02, 300, 0.05)
    unlimited = WorldDraft(walls=doc.walls, robots=doc.robots)
    assert "steps_limit" not in unlimited.world_yaml("map.png") and "replay_step_time" not in unlimited.world_yaml("m")


@pytest.mark.parametrize(
    ("quantity", "typed", "said"),
    [
        (fields.RESOLUTION, -0.01, "m per cell: -0.01 is not above 0: type the size of one map cell in metres"),
        (fields.RESOLUTION, None, "m per cell: empty: type the size of one map cell in metres"),
        (fields.RAYS, 2.5, "rays: 2.5 is not a whole number: type the number of rays"),
        (fields.BEAMWIDTH, 400, "beamwidth (°): 400 is above 360: type the beam's width in degrees, 0 to 360"),
        (fields.STEPS_LIMIT, "0", "steps limit: 0 is below 1: type the number of steps"),
        (fields.STEPS_LIMIT, "many", "steps limit: 'many' is not a number: type the number of steps"),
        (fields.STEP_TIME, -1, "step time (s): -1 is below 0: type the least wall seconds"),
        (fields.X, math.inf, "x (m): inf is not a finite number: type the robot's x in metres"),
    ],
)
def test_a_field_refuses_a_value_outside_its_limits_with_its_unit_and_what_to_type(quantity, typed, said):
    with pytest.raises(InputError, match="^" + re.escape(said)):
        quantity.read(typed)
    assert quantity.problem(typed).startswith(said.split(": ", 1)[1])  # beside the field, without its label


def test_a_steps_limit_may_be_none_and_a_step_time_may_take_a_comma():
    assert fields.STEPS_LIMIT.read("") == fields.STEPS_LIMIT.read("inf") == math.inf
    assert fields.STEPS_LIMIT.read("300") == 300 and fields.steps_text(math.inf) == ""
    assert fields.STEP_TIME.read("0,5") == 0.5  # the original took either fraction mark
    assert fields.RESOLUTION.problem(0.02) is None


def test_a_new_algorithm_is_the_original_template_and_never_overwrites_a_file(tmp_path):
    ws = Workspace(tmp_path)
    assert new_algorithm(ws, "alg_r1") == "alg_r1.m"
    text = (tmp_path / "alg_r1.m").read_text()
    assert text.startswith("function new = alg_r1(simrobot, matrix, step)\n") and text.endswith("new = simrobot;\n")
    with pytest.raises(InputError, match=r"alg_r1\.m: the file exists: choose it in the controller list"):
        new_algorithm(ws, "alg_r1.m")
    with pytest.raises(InputError, match="not an m-file named as a MATLAB function"):
        new_algorithm(ws, "2nd try.m")
    with pytest.raises(InputError, match="type its file name first"):
        new_algorithm(ws, " ")
    assert editable_algorithm(f"{ALGORITHM_PREFIX}alg_r1.m", ws) == "alg_r1.m"
    with pytest.raises(InputError, match="choose an algorithm m-file in the controller list first"):
        editable_algorithm("avoid", ws)
    with pytest.raises(InputError, match=r"is outside the workspace .*: copy it into the workspace"):
        editable_algorithm(f"{ALGORITHM_PREFIX}/etc/alg.m", ws)


def test_a_robot_drawn_smaller_than_a_click_takes_clicks_within_the_least_radius():
    view = View(800, 600, scale=250.0)
    robot = RobotSpec(name="r1", position=(0.0, 0.0))
    assert hit_radius_m(view, robot) == pytest.approx(MIN_ROBOT_PX / 250.0)  # 4 cm reach = 10 px < 16 px
    big = RobotSpec(name="big", position=(0.0, 0.0), scale=10.0)
    assert hit_radius_m(view, big) == pytest.approx(0.4)
    assert 'class="robot-ring"' in robot_svg(view, robot, (0.0, 0.0, 0.0))
    assert 'class="robot-ring"' not in robot_svg(view, big, (0.0, 0.0, 0.0))
    doc = WorldDraft(robots=[robot])
    assert doc.robot_at(0.06, 0.0) is None and doc.robot_at(0.06, 0.0, least_m=0.064) == 0


def test_a_file_that_is_no_image_is_refused_in_a_sentence_not_an_object_repr(tmp_path):
    (tmp_path / "notes.png").write_text("my notes\n")
    with pytest.raises(InputError) as refused:
        WorldDraft.from_image(tmp_path / "notes.png")
    assert str(refused.value).endswith("the file is not an image; save the map as a 1-bit or greyscale PNG or BMP")
    assert "BytesIO" not in str(refused.value)


def test_the_step_counter_counts_steps_of_dt_and_says_when_the_limit_stopped_the_world():
    from studio.simrobot.ros_client import WorldState
    from studio.simrobot.view import steps_text

    spec = WorldSpec(walls=np.zeros((3, 3), dtype=bool), dt=0.1, steps_limit=300.0)
    st = WorldState(ns="/w", node_name="/w/simrobot_world", sim_time=3.7)
    assert steps_text(st, spec) == "step 37 of 300 · sim time 3.70 s"
    st.sim_time = 30.0
    assert steps_text(st, spec) == "step 300 of 300 · sim time 30.00 s (steps limit reached: the world stopped)"
    assert steps_text(st, replace(spec, steps_limit=math.inf)) == "step 300 · sim time 30.00 s"
