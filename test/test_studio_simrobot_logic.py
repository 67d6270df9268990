"""The SIMROBOT editor's world in memory, without a browser: what it saves is what
``simrobot_world`` loads, and it refuses what the command line refuses, with the same words."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sim_runtime.errors import InputError
from simrobot_sim.world_file import load_bitmap, load_world
from studio.simrobot.doc import WorldDraft, blank_walls, map_image, new_sensor, paint_disc, parse_vertices


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
