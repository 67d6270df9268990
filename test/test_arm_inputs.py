"""Robot config, scene file and STL input: good files load exactly, bad ones name the culprit."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from arm_sim.arm import Arm
from arm_sim.motion import JointMotion
from arm_sim.robot_config import load_robot_config
from arm_sim.scene import load_scene
from arm_sim.stl import load_stl, parse_stl, write_stl
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path

IRB120 = config_path("arm/irb120.yaml")


def irb120_raw() -> dict:
    return yaml.safe_load(IRB120.read_text())


def write_irb120(tmp_path: Path, edit) -> Path:
    """A copy of the shipped IRB120 config (meshes from the shipped folder) after ``edit(raw)``."""
    raw = irb120_raw()
    raw["mesh_folder"] = str(config_path("arm/meshes/irb120"))
    edit(raw)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def tetrahedron() -> np.ndarray:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    return v[np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])]


# --- robot config ----------------------------------------------------------------------------
def test_expressions_and_degrees_are_evaluated():
    cfg = load_robot_config(IRB120)
    np.testing.assert_allclose(cfg.theta, [0, -math.pi / 2, 0, 0, 0, 0])
    np.testing.assert_allclose(cfg.position_limits[0], np.radians([-165, 165]))
    assert cfg.view.limits == (-0.4, 1.0, -0.8, 1.8, -0.4, 1.0) and cfg.view.azimuth == 40


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda r: r["dh"].update(d=[0.29, 0, 0, 0.30, 0]), "dh.d"),
        (lambda r: r.update(joint_types="rrxrrr"), "joint_types[2]"),
        (lambda r: r.update(joint_types="rrr"), "joint_types"),
        (lambda r: r["dh"].update(alpha=[0, 0, "pi/q", 0, 0, 0]), "dh.alpha[2]"),
        (lambda r: r["dh"].update(a=[0, 0, ".nan", 0, 0, 0]), "dh.a[2]"),
        (lambda r: r["limits"]["position"].__setitem__(3, [1.0, -1.0]), "limits.position[3]"),
        (lambda r: r["limits"].update(velocity=[1, 1, 1, 0, 1, 1]), "limits.velocity[3]"),
        (lambda r: r["dynamics"]["inertia"].__setitem__(1, [[1, 2, 0], [0, 1, 0], [0, 0, 1]]), "dynamics.inertia[1]"),
        (lambda r: r["links"][2]["elements"][0].update(color=[1.5, 0, 0]), "links[2].elements[0].color"),
        (lambda r: r["links"][3].update(link=9), "links[3].link"),
        (lambda r: r.pop("dh"), "dh"),
        (lambda r: r.update(dof=0), "dof"),
        (lambda r: r.update(base=[[1, 0, 0], [0, 1, 0]]), "base"),
        (lambda r: r.update(colour="red"), "colour"),
    ],
)
def test_bad_config_fields_are_named_with_file_and_index(tmp_path, edit, field):
    path = write_irb120(tmp_path, edit)
    with pytest.raises(InputError) as info:
        load_robot_config(path)
    message = str(info.value)
    assert str(path) in message
    assert f"{path}: {field}: " in message


def test_rgba_colours_and_modified_dh_flag(tmp_path):
    def edit(raw):
        raw["links"][1]["elements"][0]["color"] = [0.1, 0.2, 0.3, 0.4]
        raw["modified_dh"] = True

    cfg = load_robot_config(write_irb120(tmp_path, edit))
    assert cfg.links[1][0].color == (0.1, 0.2, 0.3, 0.4)
    assert cfg.modified_dh


def test_base_transform_moves_every_frame(tmp_path):
    path = write_irb120(tmp_path, lambda r: r.update(base={"xyz": [1, 2, 0.5], "rpy": [0, 0, "pi/2"]}))
    moved = Arm.from_file(path, load_meshes=False)
    origin = Arm.from_file(IRB120, load_meshes=False)
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    p = origin.fkine(q)[:3, 3]
    np.testing.assert_allclose(moved.fkine(q)[:3, 3], [1 - p[1], 2 + p[0], 0.5 + p[2]], atol=1e-12)


# --- STL -------------------------------------------------------------------------------------
def test_binary_and_ascii_stl_load_the_same_triangles(tmp_path):
    mesh = trimesh.creation.icosphere(subdivisions=2)
    triangles = mesh.triangles.astype(np.float32)
    write_stl(tmp_path / "b.stl", triangles)
    write_stl(tmp_path / "a.stl", triangles, ascii=True)
    np.testing.assert_array_equal(load_stl(tmp_path / "b.stl"), triangles)
    np.testing.assert_allclose(load_stl(tmp_path / "a.stl"), triangles, atol=1e-6)
    # trimesh reads our files the same way
    np.testing.assert_allclose(trimesh.load(tmp_path / "a.stl", process=False).triangles, triangles, atol=1e-6)


def test_shipped_ascii_mesh_matches_trimesh():
    path = config_path("arm/meshes/irb120/IRB120_link6.stl")
    assert path.read_bytes().startswith(b"solid")
    ours = load_stl(path)
    np.testing.assert_allclose(ours, trimesh.load(path, process=False).triangles, atol=1e-7)


def test_binary_stl_whose_header_starts_with_solid_is_read_as_binary(tmp_path):
    path = tmp_path / "sneaky.stl"
    write_stl(path, tetrahedron())
    data = bytearray(path.read_bytes())
    data[:5] = b"solid"
    np.testing.assert_array_equal(parse_stl(bytes(data), path), tetrahedron())


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-1e6, 1e6, allow_nan=False, width=32), min_size=9, max_size=9),
    st.sampled_from(["{:.6e}", "{:.9g}", "{:f}", "{!r}", "{:+.3E}"]),
)
def test_ascii_numbers_in_any_notation_parse_like_python(values, fmt):
    text = "solid t\nfacet normal 0 0 1\nouter loop\n"
    for k in range(3):
        text += "vertex " + " ".join(fmt.format(v) for v in values[3 * k : 3 * k + 3]) + "\n"
    text += "endloop\nendfacet\nendsolid t\n"
    parsed = parse_stl(text.encode())
    expected = np.array([float(fmt.format(v)) for v in values], dtype=np.float32).reshape(1, 3, 3)
    np.testing.assert_allclose(parsed, expected, rtol=1e-6)


def test_truncated_binary_stl_names_the_file(tmp_path):
    path = tmp_path / "cut.stl"
    write_stl(path, tetrahedron())
    path.write_bytes(path.read_bytes()[:-20])
    with pytest.raises(InputError, match=r"cut\.stl.*truncated.*4 triangles"):
        load_stl(path)


def test_garbage_stl_names_the_file(tmp_path):
    path = tmp_path / "garbage.stl"
    path.write_bytes(bytes(range(256)) * 3)
    with pytest.raises(InputError, match=r"garbage\.stl"):
        load_stl(path)
    (tmp_path / "tiny.stl").write_bytes(b"hello")
    with pytest.raises(InputError, match=r"tiny\.stl.*not an STL"):
        load_stl(tmp_path / "tiny.stl")


def test_truncated_ascii_stl_names_file_and_line(tmp_path):
    path = tmp_path / "cut.stl"
    write_stl(path, tetrahedron(), ascii=True)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:12]) + "\n")
    with pytest.raises(InputError, match=r"cut\.stl:12: truncated"):
        load_stl(path)


def test_bad_number_in_ascii_stl_names_the_line(tmp_path):
    path = tmp_path / "bad.stl"
    write_stl(path, tetrahedron(), ascii=True)
    lines = path.read_text().splitlines()
    lines[3] = "      vertex 1.0 abc 2.0"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"bad\.stl:4: expected three numbers"):
        load_stl(path)


def test_missing_or_broken_mesh_fails_the_arm_unless_skipped(tmp_path):
    path = write_irb120(tmp_path, lambda r: r["links"][2]["elements"][0].update(mesh="nowhere.stl"))
    with pytest.raises(InputError, match=r"nowhere\.stl"):
        Arm.from_file(path)
    arm = Arm.from_file(path, skip_missing_meshes=True)
    placeholders = [e for e in arm.elements if e.placeholder]
    assert len(placeholders) == 1 and placeholders[0].link == 2
    assert "nowhere.stl" in placeholders[0].error
    assert placeholders[0].triangles.shape == (12, 3, 3)


# --- scene -----------------------------------------------------------------------------------
def test_shipped_scene_has_objects_and_a_second_arm():
    scene = load_scene(config_path("arm/workcell.yaml"))
    assert [o.name for o in scene.objects] == ["table", "box"]
    table = scene.objects[0]
    assert table.triangles[..., 2].max() == pytest.approx(0.4)  # table top height
    assert [a.name for a in scene.arms] == ["csa"]
    np.testing.assert_allclose(scene.arms[0].base[:3, 3], [1.1, 0, 0])


def test_bad_scene_entries_are_named(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "objects": [
                    {"name": "a", "mesh": str(config_path("arm/meshes/scene/box.stl"))},
                    {"name": "a", "mesh": str(config_path("arm/meshes/scene/box.stl"))},
                ]
            }
        )
    )
    with pytest.raises(InputError, match=r"scene\.yaml: objects\[1\]\.name: .*twice"):
        load_scene(path)
    path.write_text(yaml.safe_dump({"arms": [{"name": "b", "config": "missing.yaml"}]}))
    with pytest.raises(InputError, match=r"arms\[0\]\.config: no such file"):
        load_scene(path)


# --- motion ----------------------------------------------------------------------------------
def test_move_to_arrives_together_within_velocity_limits():
    vmax = np.array([1.0, 2.0])
    motion = JointMotion(np.zeros(2), np.array([-5.0, -5.0]), np.array([5.0, 5.0]), vmax)
    duration = motion.move_to(np.array([1.0, -1.0]))
    assert duration == pytest.approx(1.5)  # joint 1 needs 1 s at full speed; a cubic peaks at 1.5x mean
    dt = 0.01
    speeds = []
    for _ in range(150):
        motion.step(dt)
        speeds.append(np.abs(motion.qd))
    np.testing.assert_allclose(motion.q, [1.0, -1.0], atol=1e-12)
    assert np.all(np.array(speeds) <= vmax + 1e-9)
    assert np.array(speeds)[:, 0].max() == pytest.approx(1.0, rel=1e-3)


def test_nan_coordinate_in_binary_stl_names_the_triangle(tmp_path):
    triangles = tetrahedron()
    triangles[2, 1, 0] = np.nan
    write_stl(tmp_path / "nan.stl", triangles)
    with pytest.raises(InputError, match=r"nan\.stl.*triangle 2 has a NaN"):
        load_stl(tmp_path / "nan.stl")


def _ascii_tetra(tmp_path: Path) -> bytes:
    tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    write_stl(tmp_path / "t.stl", tetra[np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])], ascii=True)
    return (tmp_path / "t.stl").read_bytes()


def test_an_ascii_stl_with_cr_only_line_ends_parses(tmp_path):
    text = _ascii_tetra(tmp_path)
    assert np.array_equal(parse_stl(text.replace(b"\n", b"\r")), parse_stl(text))


def test_an_ascii_stl_after_a_byte_order_mark_is_read_as_ascii(tmp_path):
    text = _ascii_tetra(tmp_path)
    assert np.array_equal(parse_stl(b"\xef\xbb\xbf" + text), parse_stl(text))


def test_a_cr_only_ascii_stl_cut_short_names_its_line(tmp_path):
    text = _ascii_tetra(tmp_path).replace(b"\n", b"\r")
    with pytest.raises(InputError, match=r"<bytes>:\d+: truncated ASCII STL"):
        parse_stl(text[: text.rindex(b"endsolid")])


def test_an_arm_config_on_a_pipe_says_it_is_a_pipe_not_that_it_is_missing():
    import subprocess
    import sys

    code = (
        "from arm_sim.robot_config import load_robot_config\nfrom sim_runtime.errors import InputError\n"
        "try:\n    load_robot_config('/dev/stdin')\nexcept InputError as e:\n    print(e)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], input="name: x\n", capture_output=True, text=True, timeout=120, check=True
    )
    assert "/dev/stdin: robot config is a FIFO (named pipe)" in result.stdout, result.stdout + result.stderr
