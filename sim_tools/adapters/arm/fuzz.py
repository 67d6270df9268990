"""The arm's fuzz targets: robot configs, scenes and STL meshes; trajectory files and the world
node's file parameters for the special paths.

The contract (what this module defines) is in :mod:`sim_tools.fuzz.targets`.
"""

from __future__ import annotations

import random
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sim_runtime.paths import config_path
from sim_tools.adapters.arm.world import NODE_EXECUTABLES
from sim_tools.fuzz_kit import Case, Defect, check_finite, mutated_yaml
from sim_tools.fuzz_kit.mutate import dump_yaml, mutate_bytes, mutate_text

#: Executable → its world node class, as ``module:Class``.
WORLD_NODES = {"arm": NODE_EXECUTABLES["arm"][0]}
#: (world executable, a file parameter of it).
FILE_PARAMETERS = (("arm", "robot_config_file"), ("arm", "scene_file"))


@dataclass
class ArmSeeds:
    folder: Path
    configs: list[Any]  # parsed robot configs
    scenes: list[Any]  # parsed scenes
    stls: list[bytes]


def prepare_seeds(folder: Path) -> None:
    """The shipped robot configs (at the top of ``folder``: a scene names them by their path, so
    that path is part of its mutated text) and work cell, their mesh paths made absolute, and STL
    meshes: a binary and an ASCII tetrahedron, a scene box and an IRB120 link."""
    from arm_sim.stl import write_stl

    for sub in ("scenes", "stl"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    for name in ("irb120.yaml", "csa7.yaml"):
        raw = yaml.safe_load(config_path(f"arm/{name}").read_text())
        raw["mesh_folder"] = str((config_path("arm") / raw.get("mesh_folder", ".")).resolve())
        (folder / name).write_text(yaml.safe_dump(raw, sort_keys=False))
    scene = yaml.safe_load(config_path("arm/workcell.yaml").read_text())
    for obj in scene.get("objects", []):
        obj["mesh"] = str((config_path("arm") / obj["mesh"]).resolve())
    for arm in scene.get("arms", []):
        arm["config"] = str((folder / arm["config"]).resolve())
    (folder / "scenes/workcell.yaml").write_text(yaml.safe_dump(scene, sort_keys=False))
    tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    tris = tetra[np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])]
    write_stl(folder / "stl/tetra_binary.stl", tris)
    write_stl(folder / "stl/tetra_ascii.stl", tris, ascii=True)
    shutil.copy(config_path("arm/meshes/scene/box.stl"), folder / "stl/box.stl")
    shutil.copy(config_path("arm/meshes/irb120/IRB120_base.stl"), folder / "stl/irb120_base.stl")


def load_seeds(folder: Path) -> ArmSeeds:
    def trees(pattern: str) -> list[Any]:
        return [yaml.safe_load(p.read_text(encoding="utf-8")) for p in sorted(folder.glob(pattern))]

    stls = [p.read_bytes() for p in sorted(folder.glob("stl/*.stl"))]
    return ArmSeeds(folder=folder, configs=trees("*.yaml"), scenes=trees("scenes/*.yaml"), stls=stls)


def drive(rng: random.Random, path: Path) -> None:
    """Build an arm from a robot config (meshes too, 30 %): kinematics, dynamics and a joint motion."""
    from arm_sim.arm import Arm
    from arm_sim.motion import JointMotion

    arm = Arm.from_file(path, load_meshes=rng.random() < 0.3, skip_missing_meshes=rng.random() < 0.5)
    q = arm.mid_range()
    check_finite(arm.fkine(q), "forward kinematics")
    check_finite(arm.rne(q, np.zeros(arm.n), np.zeros(arm.n)), "inverse dynamics")
    motion = JointMotion(q, arm.lower, arm.upper, arm.velocity_limits)
    motion.move_to(np.array([rng.uniform(lo, hi) for lo, hi in zip(arm.lower, arm.upper, strict=True)]))
    for _ in range(3):
        motion.step(0.05)
        position, _velocity, _ = motion.reference(0.05)
        check_finite(position, "joint motion")
    for element in arm.elements:
        check_finite(element.triangles, "mesh triangles")


def config_case(rng: random.Random, seeds: ArmSeeds, folder: Path) -> Case:
    (folder / "robot.yaml").write_text(mutated_yaml(rng, rng.choice(seeds.configs)), encoding="utf-8")
    return Case(folder, lambda: drive(rng, folder / "robot.yaml"))


def load_scene(path: Path) -> None:
    from arm_sim.scene import load_scene

    scene = load_scene(path)
    for obj in scene.objects:
        check_finite(obj.triangles, "scene object triangles")
        check_finite(obj.pose, "scene object pose")


def scene_case(rng: random.Random, seeds: ArmSeeds, folder: Path) -> Case:
    (folder / "scene.yaml").write_text(mutated_yaml(rng, rng.choice(seeds.scenes)), encoding="utf-8")
    return Case(folder, lambda: load_scene(folder / "scene.yaml"))


def load_stl(path: Path) -> None:
    from arm_sim.stl import load_stl

    tris = load_stl(path)
    if tris.ndim != 3 or tris.shape[1:] != (3, 3):
        raise Defect(f"STL triangles have shape {tris.shape}")
    check_finite(tris, "STL triangles")


def stl_case(rng: random.Random, seeds: ArmSeeds, folder: Path) -> Case:
    data = rng.choice(seeds.stls)
    if data.startswith(b"solid") and rng.random() < 0.5:
        data = mutate_text(rng, data.decode("ascii", "replace")).encode("utf-8", "replace")
    else:
        data = mutate_bytes(rng, data)
    (folder / "mesh.stl").write_bytes(data)
    return Case(folder, lambda: load_stl(folder / "mesh.stl"))


TARGETS = {"arm_config": (12, config_case), "scene": (6, scene_case), "stl": (10, stl_case)}


def _load_trajectory(path: Path) -> None:
    from arm_sim.trajectory_file import load_trajectory

    load_trajectory(path)


def loaders(rng: random.Random) -> dict[str, Callable[[Path], object]]:
    return {
        "robot_config": lambda p: drive(rng, p),
        "scene": load_scene,
        "stl": load_stl,
        "trajectory": _load_trajectory,
    }


def field_cases(rng: random.Random, seeds: ArmSeeds, folder: Path, special: Path) -> dict[str, Callable[[], object]]:
    """A robot config whose mesh folder or a mesh, and a scene whose mesh or arm config, is ``special``."""
    arm = dict(rng.choice(seeds.configs))
    if rng.random() < 0.5:
        arm["mesh_folder"] = str(special)
    else:
        arm["links"] = [{"link": 0, "elements": [{"mesh": str(special)}]}]
    (folder / "arm.yaml").write_text(dump_yaml(arm), encoding="utf-8")
    scene: dict[str, Any] = {"objects": [{"name": "thing", "mesh": str(special)}]}
    if rng.random() < 0.5:
        scene = {"arms": [{"name": "a", "config": str(special)}]}
    (folder / "scene.yaml").write_text(dump_yaml(scene), encoding="utf-8")
    return {
        "arm_mesh": lambda: drive(rng, folder / "arm.yaml"),
        "scene_field": lambda: load_scene(folder / "scene.yaml"),
    }


def warm_up(rng: random.Random, seeds: ArmSeeds, folder: Path) -> None:
    drive(rng, seeds.folder / "irb120.yaml")
    load_scene(seeds.folder / "scenes/workcell.yaml")
    for path in sorted((seeds.folder / "stl").glob("*.stl")):
        load_stl(path)
