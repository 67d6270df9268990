"""The arm for batch, demo, warm-up and ``--help`` (the contract: :mod:`sim_tools.adapters.contract`).

A sweep's world entry: ``{robot_config: FILE, targets: [[x, y, z], ...], hold_s: S}``: the arm is
to reach each target position (m, world frame) in turn, ``hold_s`` sim seconds apart (default 2).
Our ``arm_targets`` controller publishes them; the probe records the flange's distance to the
target being held after every step, and the world counts the targets its inverse kinematics
could not reach.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sim_tools.adapters.contract import EntryReader, EpisodeData, ExtraNodes, MakeController, Pose

LABEL = "arm"
WORLD_KEY = "robot_config"
WORLD_OPTIONS = {"targets": "targets", "hold_s": "targets"}
RESERVED = {"robot_config": "the world's robot_config", "robot_config_file": "the world's robot_config"}
#: ``arm_targets``'s class under the name sweeps have always used (an episode's key holds it).
CONTROLLERS = {"arm_targets": "sim_tools.batch.arm_targets:ArmTargetsNode"}
WORLD_NODE_NAME = "arm"
NODE_EXECUTABLES = {"arm": ("arm_sim.arm_node:ArmNode", "[--ros-args -p NAME:=VALUE ...]")}
ROBOT_NAMESPACES = False
MFILE_CONTROLLERS = False
random_poses = None
#: Seconds each target is held unless the world entry says.
DEFAULT_HOLD_S = 2.0


# ---------------------------------------------------------------------------------- the world
def _load_robot_config(path: str) -> Any:
    from arm_sim.robot_config import load_robot_config

    return load_robot_config(path)


WORLD_FILES = {"robot_config": _load_robot_config}


def read_world(r: EntryReader, entry: dict[str, Any], where: str) -> dict[str, Any]:
    """The robot config, resolved; the targets as [x, y, z] lists (m); the hold time (s)."""
    world: dict[str, Any] = {"robot_config": r.file(entry["robot_config"], f"{where}.robot_config")}
    checked = []
    for k, target in enumerate(r.listing(entry.get("targets"), f"{where}.targets")):
        if not isinstance(target, list) or len(target) != 3:
            raise r.fail(f"{where}.targets[{k}]", f"{target!r}: expected [x, y, z] (m)")
        checked.append([r.number(v, f"{where}.targets[{k}]") for v in target])
    world["targets"] = checked
    world["hold_s"] = r.number(entry.get("hold_s", DEFAULT_HOLD_S), f"{where}.hold_s", positive=True)
    return world


def make_world(world: dict[str, Any], pose: Pose | None, overrides: list[Any], **node_kwargs: Any) -> Any:
    """An ``arm`` node with the entry's robot config (meshes it cannot find are left out)."""
    from rclpy.parameter import Parameter

    from arm_sim.arm_node import ArmNode

    overrides = [
        *overrides,
        Parameter("robot_config", value=world["robot_config"]),
        Parameter("skip_missing_meshes", value=True),
    ]
    return ArmNode(parameter_overrides=overrides, **node_kwargs)


def _target_poses(world_node: Any, world: dict[str, Any]) -> np.ndarray:
    from sim_tools.adapters.arm.targets_node import target_poses

    return target_poses(world_node.arms[0].arm, world["targets"])


# ---------------------------------------------------------------------------------- controllers
def controller_nodes(
    cls: type, world_node: Any, world: dict[str, Any], make: MakeController, **node_kwargs: Any
) -> list[Any]:
    """``arm_targets`` with the world's target poses, or one node of a user's class."""
    from sim_tools.adapters.arm.targets_node import ArmTargetsNode

    if cls is ArmTargetsNode:
        return [ArmTargetsNode(_target_poses(world_node, world), world["hold_s"], **node_kwargs)]
    return [make(cls)]


def probe_kwargs(cls: type) -> dict[str, str] | None:
    """``arm_targets`` declares nothing (it is built from the world); a user's class is built as is."""
    from sim_tools.adapters.arm.targets_node import ArmTargetsNode

    return None if cls is ArmTargetsNode else {}


# ---------------------------------------------------------------------------------- the probe
class ArmProbe:
    """Flange-to-target distance after every step; the target held is the schedule's at that time.

    Arrays ``error`` (m), ``target`` (index of the target held); info ``ik_failures`` (targets
    the inverse kinematics could not reach, from the world's warnings)."""

    def __init__(self, world: Any, steps: int, targets: np.ndarray, hold_s: float) -> None:
        self.world = world
        self.instance = world.arms[0]
        self.targets = targets
        self.hold_s = hold_s
        self.rows = np.empty((steps + 1, 3))
        self.n = 0
        self.sample()

    def sample(self) -> None:
        t = self.world.sim_time
        k = min(int(t / self.hold_s + 1e-9), len(self.targets) - 1)
        flange = self.instance.arm.fkine(self.instance.motion.q)[:3, 3]
        self.rows[self.n] = (t, k, float(np.linalg.norm(flange - self.targets[k, :3, 3])))
        self.n += 1

    def ik_failures(self) -> int:
        """Targets the arm found unreachable: its world warned ``<arm>/target_pose/unreachable``."""
        return self.world.warning_counts[f"{self.instance.label}/target_pose/unreachable"]

    def data(self, params: dict[str, Any], seed: int) -> EpisodeData:
        r = self.rows[: self.n]
        arrays = {"target": r[:, 1].astype(np.int64), "error": r[:, 2]}
        return EpisodeData(r[:, 0], arrays, {"ik_failures": self.ik_failures()}, params, seed)


def probe(world_node: Any, world: dict[str, Any], steps: int) -> ArmProbe:
    return ArmProbe(world_node, steps, _target_poses(world_node, world), world["hold_s"])


# ---------------------------------------------------------------------------------- metrics
def arm_tracking_error_m(data: EpisodeData) -> dict[str, float]:
    """Flange-to-target distance at the end of each target's hold: mean and worst (m)."""
    ends = np.flatnonzero(np.diff(data.arrays["target"], append=-1) != 0)
    errors = data.arrays["error"][ends]
    return {"tracking_error_m": float(errors.mean()), "max_tracking_error_m": float(errors.max())}


def arm_ik_failures(data: EpisodeData) -> int:
    """Targets the inverse kinematics could not reach."""
    return int(data.info["ik_failures"])


METRICS = {"tracking_error_m": arm_tracking_error_m, "ik_failures": arm_ik_failures}
METRIC_RULES: dict[tuple[str, str], Any] = {}


# ---------------------------------------------------------------------------------- demo, warm-up
def demo(out: Path, extra_nodes: ExtraNodes) -> dict[str, Any]:
    """IRB120 following a joint trajectory, then a target pose."""
    from arm_sim.demo import run_demo

    summary = run_demo(out, extra_nodes=extra_nodes)
    print(f"arm demo: {summary}")
    return summary


sample_run = None


def warm_up() -> None:
    """Forward/inverse kinematics and dynamics, single and batched; both STL readers; rotations;
    the URDF joints' transforms."""
    from arm_sim.arm import Arm
    from arm_sim.stl import parse_stl
    from arm_sim.urdf import arm_tree, joint_transforms
    from sim_runtime.paths import config_path
    from sim_runtime.rotations import quaternions_xyzw

    arm = Arm.from_file(config_path("arm/irb120.yaml"))  # reads its binary STL meshes
    q = arm.mid_range()
    frames = arm.fkine_all(q)
    quaternions_xyzw(np.ascontiguousarray(frames))
    joint_transforms(arm_tree(arm.config), q)  # the node's /tf of the URDF's joints
    arm.fkine(q), arm.jacob0(q), arm.rne(q, q, q), arm.gravload(q), arm.inertia(q)
    arm.ikine(arm.fkine(q + 0.1), q0=q)
    arm.ikine_batch(np.stack([arm.fkine(q)] * 2), np.tile(q, (2, 1)))
    Q = np.tile(q, (2, 1))
    arm.fkine_batch(Q), arm.jacob0_batch(Q), arm.rne_batch(Q, Q, Q)
    triangle = b"facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
    parse_stl(b"solid t\n" + triangle + b"endsolid t\n")  # the ASCII reader


def describe_kwargs(executable: str) -> dict[str, Any]:
    return {}
