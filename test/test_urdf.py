"""The URDFs we generate, checked with an independent URDF library (yourdfpy) against our FK."""

from __future__ import annotations

import io
import math
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
import yourdfpy

from arm_sim.arm import Arm
from arm_sim.robot_config import RobotConfig, load_robot_config, transform_from_xyz_rpy
from arm_sim.urdf import arm_tree, arm_urdf, joint_transforms, link_poses, rpy_from_matrix
from create_sim.spec import BODY_HEIGHT_M, RADIUS_M, SENSOR_MOUNTS, WHEEL_BASE_M, WHEEL_RADIUS_M
from create_sim.urdf import create_urdf
from sim_runtime.paths import config_path

ROOT = Path(__file__).resolve().parent.parent
MESHES = config_path("arm/meshes/irb120")

SMALL_ARM = """
name: Small{kind}
mesh_folder: {meshes}
dof: 4
base: {{xyz: [0.3, -0.2, 0.1], rpy: [0.2, -0.4, 2.0]}}
joint_types: rprr
joint_names: [swing, lift, elbow, wrist]
modified_dh: {modified}
dh:
  theta: [0.1, pi/2, -0.3, 0]
  d: [0.2, 0.05, 0.0, 0.08]
  a: [0.05, 0.0, 0.25, 0.1]
  alpha: [-pi/2, pi/2, 0.3, -pi/2]
limits:
  position: [[-pi, pi], [0, 0.4], [-2, 2], [-3, 3]]
  velocity: [1, 0.2, 2, 3]
dynamics:
  mass: [2.0, 1.5, 1.0, 0.5]
  cog: [[0.01, 0.02, 0.03], [0, 0.1, 0], [-0.1, 0, 0.02], [0, 0, 0.04]]
  inertia:
    - [[0.02, 0.001, 0], [0.001, 0.03, 0.002], [0, 0.002, 0.01]]
    - [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]
    - [[0.004, 0, 0], [0, 0.006, 0], [0, 0, 0.005]]
    - [[0.001, 0, 0], [0, 0.001, 0], [0, 0, 0.001]]
links:
  - link: 0
    elements: [{{mesh: IRB120_base.stl, color: [0.5, 0.5, 0.5, 0.8]}}]
  - link: 3
    elements: [{{mesh: IRB120_link3.stl, color: [0.9, 0.1, 0.1], scale: 0.5}}]
"""


def small_arm(tmp_path: Path, modified: bool) -> RobotConfig:
    """A 4-joint arm with a prismatic joint, offsets everywhere and a tilted base."""
    path = tmp_path / f"small_{modified}.yaml"
    kind = "Modified" if modified else "Standard"
    path.write_text(SMALL_ARM.format(kind=kind, meshes=MESHES, modified=str(modified).lower()))
    return load_robot_config(path)


@pytest.fixture(params=["irb120", "csa7", "small_modified", "small_standard"])
def config(request, tmp_path) -> RobotConfig:
    if request.param.startswith("small_"):
        return small_arm(tmp_path, request.param == "small_modified")
    return load_robot_config(config_path(f"arm/{request.param}.yaml"))


def load(text: str, **kwargs) -> yourdfpy.URDF:
    kwargs.setdefault("load_meshes", False)
    return yourdfpy.URDF.load(io.StringIO(text), build_scene_graph=True, **kwargs)


def random_configurations(arm: Arm, count: int = 40, seed: int = 7) -> np.ndarray:
    return np.random.default_rng(seed).uniform(arm.lower, arm.upper, size=(count, arm.n))


def assert_same_pose(T: np.ndarray, expected: np.ndarray) -> None:
    assert np.abs(T[:3, 3] - expected[:3, 3]).max() <= 1e-9, (T, expected)
    assert np.abs(T[:3, :3] - expected[:3, :3]).max() <= 1e-9, (T, expected)


def test_the_modified_dh_test_arm_really_is_modified(tmp_path):
    assert small_arm(tmp_path, True).modified_dh and not small_arm(tmp_path, False).modified_dh


def test_yourdfpy_puts_the_tool_where_our_forward_kinematics_does(config):
    urdf = load(arm_urdf(config, "arm2/"))
    arm = Arm(config, load_meshes=False)
    # joints carry the prefix like the links: two arms in one world never share a joint name
    assert urdf.actuated_joint_names == ["arm2/" + name for name in config.joint_names]
    for q in random_configurations(arm):
        urdf.update_cfg(q)
        assert_same_pose(urdf.get_transform("arm2/tool0", "world"), arm.fkine(q))


def test_every_dh_frame_is_its_urdf_link_times_the_published_offset(config):
    tree = arm_tree(config)
    urdf = load(arm_urdf(config))
    arm = Arm(config, load_meshes=False)
    for q in random_configurations(arm, 10):
        urdf.update_cfg(q)
        frames = arm.fkine_all(q)
        for k in range(config.dof + 1):
            link_pose = urdf.get_transform(tree.links[k], "world")
            assert_same_pose(link_pose @ tree.dh_offsets[k], frames[k])


def test_the_tf_transforms_chain_to_the_same_links_as_yourdfpy(config):
    """What the arm node publishes on /tf (+ /tf_static) equals what robot_state_publisher would."""
    tree = arm_tree(config, "a/")
    urdf = load(arm_urdf(config, "a/"))
    arm = Arm(config, load_meshes=False)
    for q in random_configurations(arm, 10):
        urdf.update_cfg(q)
        moving = joint_transforms(tree, q)
        for joint, T in zip(tree.moving, moving, strict=True):
            assert_same_pose(T, urdf.get_transform(joint.child, joint.parent))
        poses = link_poses(tree, q)
        assert set(poses) == {"world", *tree.links}
        for link in tree.links:
            assert_same_pose(poses[link], urdf.get_transform(link, "world"))
        assert_same_pose(poses["a/tool0"], arm.fkine(q))


def test_a_base_override_moves_the_whole_arm(tmp_path):
    config = small_arm(tmp_path, True)
    base = transform_from_xyz_rpy(np.array([1.1, 0.0, 0.2]), np.array([0.0, 0.0, math.pi]))
    urdf = load(arm_urdf(config, base=base))
    arm = Arm(config, base=base, load_meshes=False)
    q = arm.mid_range()
    urdf.update_cfg(q)
    assert_same_pose(urdf.get_transform("tool0", "world"), arm.fkine(q))


def test_joint_limits_velocities_and_axes_are_the_configs(config):
    urdf = load(arm_urdf(config))
    for i, name in enumerate(config.joint_names):
        joint = urdf.joint_map[name]
        assert joint.type == ("prismatic" if config.joint_types[i] == "p" else "revolute")
        np.testing.assert_array_equal(joint.axis, [0, 0, 1])
        assert (joint.limit.lower, joint.limit.upper) == tuple(config.position_limits[i])
        assert joint.limit.velocity == config.velocity_limits[i]


def test_inertials_put_each_links_mass_at_its_centre_of_gravity(config):
    tree = arm_tree(config)
    urdf = load(arm_urdf(config))
    arm = Arm(config, load_meshes=False)
    q = random_configurations(arm, 1)[0]
    urdf.update_cfg(q)
    frames = arm.fkine_all(q)
    dyn = config.dynamics
    for k in range(1, config.dof + 1):
        inertial = urdf.link_map[tree.links[k]].inertial
        assert inertial.mass == dyn.mass[k - 1]
        com_world = urdf.get_transform(tree.links[k], "world") @ inertial.origin
        np.testing.assert_allclose(com_world[:3, 3], frames[k][:3, :3] @ dyn.cog[k - 1] + frames[k][:3, 3], atol=1e-12)
        # The tensor is about the centre of gravity in the DH frame's axes, as the config gives it.
        np.testing.assert_allclose(com_world[:3, :3], frames[k][:3, :3], atol=1e-12)
        np.testing.assert_allclose(inertial.inertia, dyn.inertia[k - 1], atol=0)


def mesh_files(urdf: yourdfpy.URDF) -> list[tuple[str, yourdfpy.Visual]]:
    return [(link.name, v) for link in urdf.robot.links for v in link.visuals if v.geometry.mesh is not None]


def test_every_mesh_element_is_a_visual_with_an_existing_file_its_colour_and_scale(config):
    urdf = load(arm_urdf(config))
    visuals = mesh_files(urdf)
    elements = [(k, e) for k, link in enumerate(config.links) for e in link]
    assert len(visuals) == len(elements)
    tree = arm_tree(config)
    for (link, visual), (k, element) in zip(visuals, elements, strict=True):
        assert link == tree.links[k]
        uri = urlparse(visual.geometry.mesh.filename)
        assert uri.scheme == "file"
        assert Path(unquote(uri.path)) == element.mesh and element.mesh.is_file()
        np.testing.assert_array_equal(visual.material.color.rgba, element.color)
        np.testing.assert_array_equal(visual.geometry.mesh.scale, [element.scale] * 3)
        np.testing.assert_allclose(visual.origin, tree.dh_offsets[k], atol=1e-15)


def test_yourdfpy_loads_every_mesh_of_the_shipped_arms():
    for name in ("irb120", "csa7"):
        config = load_robot_config(config_path(f"arm/{name}.yaml"))
        urdf = load(arm_urdf(config), load_meshes=True, filename_handler=lambda fname: unquote(urlparse(fname).path))
        geometries = urdf.scene.geometry
        assert len(geometries) == sum(len(link) for link in config.links)
        assert all(len(g.faces) > 0 for g in geometries.values())


@pytest.mark.parametrize("prefix", ["", "robot1/"])
def test_the_create_urdf_has_a_link_at_every_sensor_mount_a_footprint_and_two_wheels(prefix):
    urdf = load(create_urdf(prefix))
    assert urdf.base_link == f"{prefix}base_link"
    wheels = {f"{prefix}left_wheel", f"{prefix}right_wheel"}
    others = {f"{prefix}base_link", f"{prefix}base_footprint", *wheels}
    assert set(urdf.link_map) == {*others, *(prefix + name for name in SENSOR_MOUNTS)}
    assert_same_pose(urdf.get_transform(f"{prefix}base_footprint", f"{prefix}base_link"), np.eye(4))
    assert urdf.actuated_joint_names == [f"{prefix}left_wheel_joint", f"{prefix}right_wheel_joint"]
    urdf.update_cfg([1.0, -1.0])  # turning about the axle (+y): the wheels sit on the floor either side
    for wheel, side in zip(sorted(wheels), (1.0, -1.0), strict=True):
        T = urdf.get_transform(wheel, f"{prefix}base_link")
        assert T[:3, 3] == pytest.approx([0.0, side * 0.5 * WHEEL_BASE_M, WHEEL_RADIUS_M])
        assert T[1, 1] == pytest.approx(1.0)  # the axle stays the wheel's y
    for name, mount in SENSOR_MOUNTS.items():
        T = urdf.get_transform(prefix + name, f"{prefix}base_link")
        expected = transform_from_xyz_rpy(np.array([mount.x_m, mount.y_m, mount.z_m]), np.array([0, 0, mount.yaw_rad]))
        assert_same_pose(T, expected)
    body = urdf.link_map[f"{prefix}base_link"].visuals[0].geometry.cylinder
    assert (body.radius, body.length) == (RADIUS_M, BODY_HEIGHT_M)


def test_rpy_rebuilds_every_rotation_even_at_gimbal_lock():
    rng = np.random.default_rng(3)
    angles = list(rng.uniform(-math.pi, math.pi, size=(200, 3)))
    for pitch in (math.pi / 2, -math.pi / 2, math.pi / 2 - 1e-9, -math.pi / 2 + 1e-7):
        angles += [np.array([r, pitch, y]) for r, y in rng.uniform(-math.pi, math.pi, size=(20, 2))]
    for rpy in angles:
        R = transform_from_xyz_rpy(np.zeros(3), rpy)
        rebuilt = transform_from_xyz_rpy(np.zeros(3), np.array(rpy_from_matrix(R)))
        np.testing.assert_allclose(rebuilt, R, atol=2e-15)


def urdf_command(*args: str) -> subprocess.CompletedProcess:
    """``robot_sims urdf ...`` (the executable's own main, from this checkout)."""
    return subprocess.run(
        [sys.executable, "-m", "sim_tools.urdf_cli", *args], cwd=ROOT, capture_output=True, text=True, timeout=120
    )


@pytest.mark.parametrize("target", ["arm/irb120.yaml", str(config_path("arm/csa7.yaml")), "create"])
def test_the_urdf_command_prints_a_urdf_that_loads(target):
    done = urdf_command(target, "--prefix", "x/")
    assert done.returncode == 0, done.stderr
    urdf = load(done.stdout)
    assert urdf.base_link == ("x/base_link" if target == "create" else "world")


@pytest.mark.parametrize("content", [None, "name: [unclosed", "name: X\ndof: 0\n", bytes(range(256)).decode("latin-1")])
def test_the_urdf_command_names_a_bad_file_in_one_line_and_exits_2(tmp_path, content):
    path = tmp_path / "bad.yaml"
    if content is not None:
        path.write_text(content, encoding="latin-1")
    done = urdf_command(str(path))
    assert done.returncode == 2
    assert done.stdout == ""
    assert str(path) in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr
