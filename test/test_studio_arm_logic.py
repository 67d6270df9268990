"""The arm page's logic without a browser: display meshes, trajectory files, URDF joint limits."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from arm_sim.robot_config import load_robot_config
from arm_sim.stl import load_stl, parse_stl
from arm_sim.trajectory_file import load_trajectory
from arm_sim.urdf import arm_urdf
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from studio.arm.meshes import MeshCache, binary_stl, decimate
from studio.arm.ros_client import joint_limits


def bumpy_sphere(rows: int, cols: int, radius: float = 0.1) -> np.ndarray:
    """A closed-looking latitude-longitude sphere with bumps: 2 * rows * cols triangles (F, 3, 3)."""
    theta = np.linspace(0.0, np.pi, rows + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, cols + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    r = radius * (1.0 + 0.05 * np.sin(8 * t) * np.cos(6 * p))
    v = np.stack([r * np.sin(t) * np.cos(p), r * np.sin(t) * np.sin(p), r * np.cos(t)], axis=-1)
    a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
    first = np.stack([a, b, c], axis=2).reshape(-1, 3, 3)
    second = np.stack([a, c, d], axis=2).reshape(-1, 3, 3)
    return np.concatenate([first, second]).astype(np.float32)


def test_a_dense_mesh_is_reduced_to_the_budget_and_keeps_its_shape():
    dense = bumpy_sphere(150, 150)  # 45k faces
    reduced = decimate(dense, 4000)
    assert 1000 < len(reduced) <= 4000
    radii = np.linalg.norm(reduced.reshape(-1, 3), axis=1)
    assert radii.min() > 0.09 and radii.max() < 0.106  # still the same sphere, within its bumps
    lo, hi = reduced.reshape(-1, 3).min(axis=0), reduced.reshape(-1, 3).max(axis=0)
    assert np.allclose(lo, dense.reshape(-1, 3).min(axis=0), atol=0.01)
    assert np.allclose(hi, dense.reshape(-1, 3).max(axis=0), atol=0.01)
    areas = np.linalg.norm(np.cross(reduced[:, 1] - reduced[:, 0], reduced[:, 2] - reduced[:, 0]), axis=1)
    assert (areas > 0).all()  # no collapsed triangles


def test_a_mesh_within_the_budget_or_with_no_budget_is_left_alone():
    small = bumpy_sphere(10, 10)
    assert decimate(small, 1000) is small
    assert decimate(small, 0) is small


def test_the_display_stl_reads_back_with_outward_normals(tmp_path):
    triangles = bumpy_sphere(20, 20)
    data = binary_stl(triangles)
    assert np.array_equal(parse_stl(data), triangles)
    normals = np.frombuffer(data, dtype=np.uint8)[84:].reshape(-1, 50)[:, :12].copy().view("<f4").reshape(-1, 3)
    centres = triangles.mean(axis=1)
    keep = np.linalg.norm(normals, axis=1) > 0
    outward = np.einsum("ij,ij->i", normals[keep], centres[keep]) < 0  # the sphere's winding points inwards
    assert outward.all() or (~outward).all()  # one consistent side, as the file's winding says


def test_the_cache_reads_a_file_once_and_again_when_it_changes(tmp_path):
    path = tmp_path / "part.stl"
    path.write_bytes(binary_stl(bumpy_sphere(60, 60)))
    cache = MeshCache()
    results = []
    threads = [threading.Thread(target=lambda: results.append(cache.prepare(path, 2000))) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len({id(r) for r in results}) == 1  # four pages at once: one reading
    first = results[0]
    assert first.faces_in == 7200 and first.faces_out <= 2000
    assert cache.get(first.key) is first
    assert len(load_stl(path)) == 7200
    path.write_bytes(binary_stl(bumpy_sphere(10, 10)))
    again = cache.prepare(path, 2000)
    assert again.key != first.key and again.faces_in == again.faces_out == 200


def test_a_bad_mesh_file_is_an_input_error_naming_it(tmp_path):
    bad = tmp_path / "broken.stl"
    bad.write_bytes(b"\x00" * 100)
    with pytest.raises(InputError, match=r"broken\.stl"):
        MeshCache().prepare(bad)
    with pytest.raises(InputError, match=r"missing\.stl"):
        MeshCache().prepare(tmp_path / "missing.stl")


def test_a_trajectory_file_is_read_with_expressions_and_optional_names(tmp_path):
    path = tmp_path / "wave.yaml"
    path.write_text(
        "joint_names: [joint_1, joint_2]\n"
        "points:\n"
        "  - {time: 0.5, positions: [90*deg, -pi/4], velocities: [0, 0]}\n"
        "  - {time: 2, positions: [0, 0], velocities: [0.1, 0]}\n"
    )
    trajectory = load_trajectory(path)
    assert trajectory.joint_names == ("joint_1", "joint_2")
    assert trajectory.times.tolist() == [0.5, 2.0]
    assert trajectory.positions.tolist() == [[pytest.approx(math.pi / 2), pytest.approx(-math.pi / 4)], [0.0, 0.0]]
    assert trajectory.velocities.tolist() == [[0.0, 0.0], [0.1, 0.0]]
    path.write_text("points:\n  - {time: 1, positions: [1, 2, 3]}\n")
    assert load_trajectory(path).joint_names == () and load_trajectory(path).velocities is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("points: []\n", "points: expected at least one point"),
        ("points:\n  - {time: 1, positions: [0]}\n  - {time: 1, positions: [0]}\n", "points[1].time: times must"),
        ("points:\n  - {time: 1, positions: [0, 1]}\n  - {time: 2, positions: [0]}\n", "points[1].positions"),
        ("joint_names: [a, a]\npoints:\n  - {time: 1, positions: [0, 0]}\n", "joint_names: expected distinct"),
        ("points:\n  - {time: 1, positions: [nan]}\n", "points[0].positions[0]"),
        ("points:\n  - {time: 1, positions: [0], velocities: [0]}\n  - {time: 2, positions: [0]}\n", "every point"),
        ("points:\n  - {time: 1, position: [0]}\n", "position"),
    ],
)
def test_a_bad_trajectory_file_names_the_file_and_field(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=r"bad\.yaml") as err:
        load_trajectory(path)
    assert message in str(err.value)


def test_the_joint_limits_come_from_the_arms_urdf():
    config = load_robot_config(config_path("arm/irb120.yaml"))
    limits = joint_limits(arm_urdf(config, ""))
    assert list(limits) == list(config.joint_names)
    for name, (lower, upper) in zip(config.joint_names, config.position_limits, strict=True):
        assert (limits[name].lower, limits[name].upper) == (pytest.approx(lower), pytest.approx(upper))
        assert not limits[name].prismatic


def test_element_poses_turn_into_the_same_rotations_as_the_messages_helpers():
    from geometry_msgs.msg import Quaternion

    from sim_runtime.msgs import matrix_from_quaternion
    from studio.arm.scene import rotations

    rng = np.random.default_rng(3)
    q = rng.normal(size=(20, 4))
    expected = [matrix_from_quaternion(Quaternion(x=a, y=b, z=c, w=d)) for a, b, c, d in q]
    assert np.allclose(rotations(q), expected, atol=1e-12)


def test_a_world_file_typed_in_the_arm_page_stays_in_the_workspace_or_the_shipped_configs(tmp_path):
    from studio.arm.worlds import arm_world_ros_args, resolve_config
    from studio.shell.app import Studio
    from studio.shell.workspace import Workspace

    studio = Studio(workspace=Workspace(tmp_path), controllers={})
    (tmp_path / "mine.yaml").write_text("name: x\n")
    assert resolve_config(studio, "mine.yaml", "robot config") == str(tmp_path / "mine.yaml")
    assert resolve_config(studio, "arm/irb120.yaml", "robot config") == str(config_path("arm/irb120.yaml"))
    for name in ("../../etc/passwd", "/etc/passwd", "arm/../../setup.py", "nothing.yaml"):
        with pytest.raises(InputError):
            resolve_config(studio, name, "robot config")
    args = arm_world_ros_args("/cell", "it's.yaml", "")
    assert args == [
        "--ros-args", "-p", "robot_config_file:='it''s.yaml'", "-p", "scene_file:=''",
        "-r", "__ns:=/cell", "-r", "/clock:=/cell/clock",
    ]  # fmt: skip
