"""Hostile YAML in every loader (world files, robot configs, scenes): only InputError, naming file and field."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from arm_sim.robot_config import load_robot_config
from arm_sim.scene import load_scene
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_runtime.yamlfile import FieldReader, evaluate_expression
from simrobot_sim.world_file import load_world

HUGE = 10**400  # a YAML integer no float can hold


def write(tmp_path: Path, name: str, data) -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def world(**robot) -> dict:
    return {
        "map": str(config_path("simrobot/demo_map.png")),
        "robots": [{"name": "a", "position": [0.5, 0.5], **robot}],
    }


@pytest.mark.parametrize(
    ("data", "where"),
    [
        (world(position=[HUGE, 0.5]), r"robots\[0\] \('a'\)\.position\[0\]: number out of range"),
        (world(heading=-HUGE), r"robots\[0\] \('a'\)\.heading: number out of range"),
        ({**world(), "dt": HUGE}, r"dt: number out of range"),
        ({**world(), 7: 1}, r"field names must be text, got 7"),
        (world(sensors=[{"name": "s", None: 2}]), r"sensors\[0\]: field names must be text, got None"),
        ({**world(), "origin": [0, [1, 2]]}, r"origin\[1\]: expected a number"),
        (world(sensors=[{"name": "s", "resolution": 2**31}]), r"sensors\[0\]\.resolution: .*at most 100000"),
        (world(scale=1e300), r"robots\[0\] \('a'\)\.scale: beyond ±1e\+06, got 1e\+300"),
        (world(scale=1e5), r"robots\[0\] \('a'\)\.shape: the robot .* is larger than the map"),
    ],
)
def test_a_world_file_with_hostile_values_names_file_and_field(tmp_path, data, where):
    with pytest.raises(InputError, match=rf"world\.yaml: .*{where}"):
        load_world(write(tmp_path, "world.yaml", data))


def irb120(edit) -> dict:
    raw = yaml.safe_load(config_path("arm/irb120.yaml").read_text())
    raw["mesh_folder"] = str(config_path("arm/meshes/irb120"))
    edit(raw)
    return raw


@pytest.mark.parametrize(
    ("edit", "where"),
    [
        (lambda r: r["dh"]["theta"].__setitem__(0, HUGE), r"dh\.theta\[0\]: number out of range"),
        (lambda r: r["dh"].__setitem__(3, [0] * 6), r"dh: field names must be text, got 3"),
        (lambda r: r.__setitem__(None, 1), r"<top level>: field names must be text, got None"),
        (lambda r: r.update(base={1: [0, 0, 0]}), r"base: field names must be text"),
        (lambda r: r.update(joint_types=[1, 2, 3, 4, 5, 6]), r"joint_types\[0\]: expected text, got 1"),
        (lambda r: r.update(dof=HUGE), r"dof: must be in 1\.\.100"),
        (lambda r: r["dh"]["d"].__setitem__(1, "-" * 5000 + "1"), r"dh\.d\[1\]: expected a number or an expression"),
        (lambda r: r["dh"]["d"].__setitem__(1, "9" * 400), r"dh\.d\[1\]: expected a number or an expression"),
        (lambda r: r["dh"]["d"].__setitem__(1, "1e200 * 1e200"), r"dh\.d\[1\]: must be finite"),
        (lambda r: r["dh"]["a"].__setitem__(2, "1e308*10"), r"dh\.a\[2\]: must be finite"),
        (lambda r: r["limits"]["velocity"].__setitem__(1, 1e-320), r"limits\.velocity\[1\]: must be within"),
        (
            lambda r: r["limits"]["position"].__setitem__(0, [-1e300, 1e300]),
            r"limits\.position\[0\]\[0\]: beyond ±1e\+06",
        ),
    ],
)
def test_a_robot_config_with_hostile_values_names_file_and_field(tmp_path, edit, where):
    with pytest.raises(InputError, match=rf"robot\.yaml: {where}"):
        load_robot_config(write(tmp_path, "robot.yaml", irb120(edit)))


@pytest.mark.parametrize(
    ("data", "where"),
    [
        ({"objects": [{"name": "a", "mesh": "x.stl", 5: 1}]}, r"objects\[0\]: field names must be text, got 5"),
        ({1: []}, r"scene\.yaml: <top level>: field names must be text"),
        (
            {"objects": [{"name": "a", "mesh": str(config_path("arm/meshes/scene/box.stl")), "scale": HUGE}]},
            r"objects\[0\]\.scale: number out of range",
        ),
        ({"arms": [{"name": "b", "config": "irb120.yaml", "base": {"xyz": [0, 0, HUGE]}}]}, r"base\.xyz\[2\]"),
    ],
)
def test_a_scene_with_hostile_values_names_file_and_field(tmp_path, data, where):
    (tmp_path / "irb120.yaml").write_text(yaml.safe_dump(irb120(lambda r: None)))
    with pytest.raises(InputError, match=rf"scene\.yaml: .*{where}|{where}"):
        load_scene(write(tmp_path, "scene.yaml", data))


@pytest.mark.parametrize("text", ["2024-13-45", "[" * 20000, "a: !!binary 'not base64 ~'"])
def test_yaml_the_parser_itself_rejects_is_an_input_error(tmp_path, text):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=r"robot\.yaml"):
        load_robot_config(path)


def test_the_field_reader_evaluates_the_formulas_people_write():
    reader = FieldReader("f.yaml", expressions=True)
    assert reader.number("-pi/2", "x") == pytest.approx(-1.5707963267948966)
    assert reader.number("165*deg", "x") == pytest.approx(2.8797932657906435)
    assert evaluate_expression("(1 + 2) * 3") == 9.0
    with pytest.raises(InputError, match=r"^f\.yaml: x: expected a number"):
        FieldReader("f.yaml").number("pi", "x")
    with pytest.raises(ValueError, match="unsupported expression"):
        evaluate_expression("__import__('os')")
