"""URDF of a serial arm from its robot config, and the transforms robot_state_publisher would send.

Pure (no rclpy): :func:`arm_tree` turns a :class:`~arm_sim.robot_config.RobotConfig` into a tree of
links and joints; :func:`arm_urdf` writes it as URDF; :func:`joint_transforms` and
:func:`fixed_transforms` give the transforms of that same tree for a joint vector, so what the arm
node publishes on ``/tf`` and ``/tf_static`` is what robot_state_publisher would publish from the
URDF and ``joint_states``.

The tree (every link and joint name carries ``prefix``, e.g. ``arm2/``)::

    world ─(fixed: base)─ base_link ─(joint_1)─ link_1 ─ … ─(joint_n)─ link_n ─(fixed)─ tool0

- ``world`` is the world frame (the node's ``frame_id``), shared by every arm, so not prefixed.
- ``base_link`` is DH frame 0; ``tool0`` is DH frame n, the flange that ``end_effector_pose``
  reports and IK solves for.
- Modified DH: ``link_k`` is DH frame k, since each joint's motion is the last factor of its link
  transform (Rx(alpha) Tx(a) Rz(theta) Tz(d), then Rz(q) or Tz(q)).
- Standard DH: the motion Rz(q) of joint k sits between Rz(theta) Tz(d) and Tx(a) Rx(alpha), and
  a URDF joint can only move its child frame last. So ``link_k`` is on joint k's axis
  (frame k-1 · Rz(theta + q) Tz(d)) and DH frame k is ``link_k`` · Tx(a) Rx(alpha): that fixed
  offset goes into the link's visual and inertial origins and into the next joint's origin.
  :attr:`ArmTree.dh_offsets` holds it for every link.
- Joint names are the config's with the prefix (``csa/joint_1``), as ``joint_states`` names them:
  two arms in one world never share a joint name.

Meshes are ``<visual>`` elements in the link's DH frame with the config's colour (each element its
own material) and scale; ``<inertial>`` comes from the config's dynamics (links with mass 0 get
none). URDF needs an effort limit on every moving joint; robot configs have none, so it is written
as 0 (RViz, robot_state_publisher and MoveIt do not use it).

``python -m arm_sim.urdf <robot_config.yaml | create>`` (``robot_sims urdf``) prints a URDF.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple
from xml.sax.saxutils import quoteattr

import numba
import numpy as np

from arm_sim.robot_config import RobotConfig
from sim_runtime.paths import mesh_uri

WORLD_FRAME = "world"
BASE_LINK = "base_link"
TOOL_LINK = "tool0"


class TreeJoint(NamedTuple):
    """A URDF joint: ``child`` = ``parent`` · ``origin`` · motion(q) (about/along z)."""

    name: str
    kind: str  # "revolute", "prismatic" or "fixed"
    parent: str
    child: str
    origin: np.ndarray  # (4, 4)


@dataclass(frozen=True)
class ArmTree:
    """Links and joints of an arm's URDF (see the module docstring)."""

    config: RobotConfig
    prefix: str
    world_frame: str
    base: np.ndarray  # (4, 4) world pose of DH frame 0
    links: tuple[str, ...]  # base_link, link_1 .. link_n (one per DH frame), then tool0
    joints: tuple[TreeJoint, ...]  # base (fixed), joint_1 .. joint_n, tool (fixed)
    dh_offsets: np.ndarray  # (n+1, 4, 4): URDF link k's frame -> DH frame k
    moving_origins: np.ndarray  # (n, 4, 4): the origins of joint_1 .. joint_n
    prismatic: np.ndarray  # (n,) bool

    @property
    def moving(self) -> tuple[TreeJoint, ...]:
        """joint_1 .. joint_n."""
        return self.joints[1:-1]

    @property
    def fixed(self) -> tuple[TreeJoint, ...]:
        """The base and tool joints."""
        return (self.joints[0], self.joints[-1])

    @property
    def tool_link(self) -> str:
        return self.links[-1]

    @property
    def base_link(self) -> str:
        return self.links[0]


def _rot_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[0:2, 0:2] = [[c, -s], [s, c]]
    return T


def _translation(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def arm_tree(
    config: RobotConfig, prefix: str = "", *, base: np.ndarray | None = None, world_frame: str = WORLD_FRAME
) -> ArmTree:
    """The URDF tree of ``config``; ``base`` (4x4) replaces the config's base as the Arm's does."""
    n = config.dof
    base_T = np.array(config.base if base is None else base, dtype=float)
    links = [f"{prefix}{BASE_LINK}", *(f"{prefix}link_{k}" for k in range(1, n + 1)), f"{prefix}{TOOL_LINK}"]
    offsets = np.tile(np.eye(4), (n + 1, 1, 1))
    origins = np.empty((n, 4, 4))
    for i in range(n):
        # Joint i+1 at q = 0: its DH link transform without the joint's own motion.
        at_axis = _rot_z(config.theta[i]) @ _translation(z=config.d[i])
        if config.modified_dh:
            origins[i] = offsets[i] @ _rot_x(config.alpha[i]) @ _translation(x=config.a[i]) @ at_axis
        else:
            origins[i] = offsets[i] @ at_axis
            offsets[i + 1] = _translation(x=config.a[i]) @ _rot_x(config.alpha[i])
    prismatic = np.array([t == "p" for t in config.joint_types])
    joints = [TreeJoint(f"{prefix}base_joint", "fixed", world_frame, links[0], base_T)]
    for i in range(n):
        kind = "prismatic" if prismatic[i] else "revolute"
        joints.append(TreeJoint(prefix + config.joint_names[i], kind, links[i], links[i + 1], origins[i]))
    joints.append(TreeJoint(f"{prefix}tool_joint", "fixed", links[n], links[n + 1], offsets[n]))
    return ArmTree(
        config=config,
        prefix=prefix,
        world_frame=world_frame,
        base=base_T,
        links=tuple(links),
        joints=tuple(joints),
        dh_offsets=offsets,
        moving_origins=origins,
        prismatic=prismatic,
    )


def joint_transforms(tree: ArmTree, q: np.ndarray) -> np.ndarray:
    """Parent-from-child transforms (n, 4, 4) of joint_1 .. joint_n at joint vector ``q``.

    What robot_state_publisher sends on ``/tf`` for ``joint_states`` = q: link_{k-1} → link_k.
    """
    out = np.empty_like(tree.moving_origins)
    _joint_transforms_into(out, tree.moving_origins, tree.prismatic, np.asarray(q, dtype=float))
    return out


@numba.njit(cache=True)
def _joint_transforms_into(out: np.ndarray, origins: np.ndarray, prismatic: np.ndarray, q: np.ndarray) -> None:
    """out[i] = origins[i] @ (Rz(q[i]) for a revolute joint, Tz(q[i]) for a prismatic one)."""
    out[:] = origins
    for i in range(q.shape[0]):
        if prismatic[i]:
            for r in range(3):
                out[i, r, 3] += q[i] * origins[i, r, 2]
        else:
            c = math.cos(q[i])
            s = math.sin(q[i])
            for r in range(3):
                out[i, r, 0] = c * origins[i, r, 0] + s * origins[i, r, 1]
                out[i, r, 1] = c * origins[i, r, 1] - s * origins[i, r, 0]


def fixed_transforms(tree: ArmTree) -> tuple[TreeJoint, ...]:
    """The fixed joints (what robot_state_publisher sends on ``/tf_static``): world → base_link
    and link_n → tool0."""
    return tree.fixed


def link_poses(tree: ArmTree, q: np.ndarray) -> dict[str, np.ndarray]:
    """World pose (4x4) of every link at ``q``, chained from the tree's transforms."""
    poses = {tree.world_frame: np.eye(4)}
    moving = joint_transforms(tree, q)
    for k, joint in enumerate(tree.joints):
        local = moving[k - 1] if joint.kind != "fixed" else joint.origin
        poses[joint.child] = poses[joint.parent] @ local
    return poses


def rpy_from_matrix(R: np.ndarray) -> tuple[float, float, float]:
    """Roll, pitch, yaw with R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's convention), exact to rounding.

    Pitch comes from atan2 (no asin precision loss near ±90°); yaw from the first column; roll
    from what remains once yaw and pitch are undone, so the three always rebuild R, even at or
    near gimbal lock where yaw alone is ill-defined.
    """
    R = np.asarray(R, dtype=float)[:3, :3]
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    yaw = math.atan2(R[1, 0], R[0, 0]) if math.hypot(R[0, 0], R[1, 0]) > 0.0 else 0.0
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    # Rx(roll) = Ry(-pitch) Rz(-yaw) R; roll from its column 2 (rows 1 and 2).
    undo_yaw = np.array([[cy, sy, 0.0], [-sy, cy, 0.0], [0.0, 0.0, 1.0]]) @ R
    undo_pitch = np.array([[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]]) @ undo_yaw
    roll = math.atan2(undo_pitch[2, 1], undo_pitch[1, 1])
    return roll, pitch, yaw


def _numbers(values: Iterable[float]) -> str:
    # repr gives the shortest text that reads back as the same double: no precision lost.
    return " ".join(repr(float(v) + 0.0) for v in values)


def _origin(T: np.ndarray) -> str:
    return f'<origin xyz="{_numbers(T[:3, 3])}" rpy="{_numbers(rpy_from_matrix(T))}"/>'


def _link_xml(tree: ArmTree, k: int, uri: Callable[[Path], str]) -> list[str]:
    """The <link> of DH frame k (k = 0 base .. n), with visuals and inertial in the DH frame."""
    config = tree.config
    name = tree.links[k]
    offset = tree.dh_offsets[k]
    lines = [f"  <link name={quoteattr(name)}>"]
    for j, element in enumerate(config.links[k]):
        scale = _numbers([element.scale] * 3)
        lines += [
            f"    <visual name={quoteattr(element.mesh.stem)}>",
            f"      {_origin(offset)}",
            f'      <geometry><mesh filename={quoteattr(uri(element.mesh))} scale="{scale}"/></geometry>',
            f'      <material name={quoteattr(f"{name}/{j}")}><color rgba="{_numbers(element.color)}"/></material>',
            "    </visual>",
        ]
    if k > 0 and config.dynamics.mass[k - 1] > 0.0:
        dyn = config.dynamics
        inertial = offset @ _translation(*dyn.cog[k - 1])
        I = dyn.inertia[k - 1]
        lines += [
            "    <inertial>",
            f"      {_origin(inertial)}",
            f'      <mass value="{_numbers([dyn.mass[k - 1]])}"/>',
            f'      <inertia ixx="{_numbers([I[0, 0]])}" ixy="{_numbers([I[0, 1]])}" ixz="{_numbers([I[0, 2]])}"'
            f' iyy="{_numbers([I[1, 1]])}" iyz="{_numbers([I[1, 2]])}" izz="{_numbers([I[2, 2]])}"/>',
            "    </inertial>",
        ]
    lines.append("  </link>")
    return lines


def _joint_xml(tree: ArmTree, joint: TreeJoint) -> list[str]:
    lines = [
        f"  <joint name={quoteattr(joint.name)} type={quoteattr(joint.kind)}>",
        f"    <parent link={quoteattr(joint.parent)}/>",
        f"    <child link={quoteattr(joint.child)}/>",
        f"    {_origin(joint.origin)}",
    ]
    if joint.kind != "fixed":
        i = [j.name for j in tree.moving].index(joint.name)
        lower, upper = tree.config.position_limits[i]
        velocity = tree.config.velocity_limits[i]
        lines += [
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_numbers([lower])}" upper="{_numbers([upper])}"'
            f' velocity="{_numbers([velocity])}" effort="0"/>',
        ]
    lines.append("  </joint>")
    return lines


def arm_urdf(
    config: RobotConfig,
    prefix: str = "",
    *,
    base: np.ndarray | None = None,
    world_frame: str = WORLD_FRAME,
    uri: Callable[[Path], str] = mesh_uri,
) -> str:
    """URDF text of ``config`` (see the module docstring for its links, joints and frames).

    ``prefix`` goes before every link name (several arms in one world); ``base`` (4x4) replaces
    the config's base; ``uri`` turns a mesh path into its URI.
    """
    tree = arm_tree(config, prefix, base=base, world_frame=world_frame)
    robot = f"{prefix}{config.name}"
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- Generated by robot_sims from {config.path.name}: {config.dof} joints,"
        f" {'modified' if config.modified_dh else 'standard'} DH. -->",
        f"<robot name={quoteattr(robot)}>",
        f"  <link name={quoteattr(world_frame)}/>",
    ]
    for k in range(config.dof + 1):
        lines += _link_xml(tree, k, uri)
    lines.append(f"  <link name={quoteattr(tree.tool_link)}/>")
    for joint in tree.joints:
        lines += _joint_xml(tree, joint)
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
