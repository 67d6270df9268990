"""Scene files (YAML): objects around the arms (RoboClass's LoadObject) and extra arms.

Format (paths relative to the scene file; numbers may be expressions with ``pi`` and ``deg``)::

    objects:                        # static STL objects, drawn as markers
      - name: table                 # unique; also the marker namespace
        mesh: meshes/scene/table.stl
        color: [0.55, 0.4, 0.25]    # RGB or RGBA in 0..1
        pose: {xyz: [0.5, 0, 0], rpy: [0, 0, 0]}   # or a 4x4 matrix (LoadObject's Tr)
        scale: 1.0                  # optional: STL units to metres
    arms:                           # optional: more arms in the same world
      - name: csa                   # topic prefix: csa/joint_states, csa/joint_command, ...
        config: csa7.yaml           # robot config file
        base: {xyz: [1.0, 0, 0.4], rpy: [0, 0, pi]}   # optional: replaces the config's base

Errors name the file, the field and the index.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from arm_sim.robot_config import read_color, read_transform
from arm_sim.stl import load_stl
from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem, resolved, shown
from sim_runtime.yamlfile import FieldReader, field_name, load_yaml, short

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class SceneObject:
    """A static STL object: world pose (4x4), RGBA colour, scale, triangles (metres, object frame)."""

    name: str
    mesh: Path
    color: tuple[float, float, float, float]
    pose: np.ndarray
    scale: float
    triangles: np.ndarray


@dataclass(frozen=True)
class SceneArm:
    """An arm of the scene: name (topic prefix), robot config path, base override (or None)."""

    name: str
    config: Path
    base: np.ndarray | None


@dataclass(frozen=True)
class Scene:
    path: Path
    objects: tuple[SceneObject, ...]
    arms: tuple[SceneArm, ...]


def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read a scene file and its meshes; raises InputError naming file, field and index."""
    path = resolved(path)
    raw = load_yaml(path, "scene file")
    r = FieldReader(path, expressions=True)
    raw = r.mapping(raw if raw is not None else {}, "<top level>")
    unknown = [k for k in raw if k not in ("objects", "arms")]
    if unknown:
        raise r.error(field_name(unknown[0]), "unknown field; known fields: ['arms', 'objects']")
    objects = []
    names: set[str] = set()
    for i, entry in enumerate(_list(r, raw.get("objects", []), "objects")):
        where = f"objects[{i}]"
        entry = r.mapping(entry, where)
        name = _name(r, entry, where, names)
        mesh = r.require(entry, "mesh", f"{where}.")
        if not isinstance(mesh, str) or not mesh:
            raise r.error(f"{where}.mesh", f"expected an STL file name, got {short(mesh)}")
        mesh_path = resolved(path.parent / mesh)
        scale = r.number(entry.get("scale", 1.0), f"{where}.scale")
        if scale <= 0:
            raise r.error(f"{where}.scale", f"must be > 0, got {scale}")
        objects.append(
            SceneObject(
                name=name,
                mesh=mesh_path,
                color=read_color(r, entry.get("color", [0.7, 0.7, 0.7]), f"{where}.color"),
                pose=read_transform(r, entry.get("pose", {}), f"{where}.pose"),
                scale=scale,
                triangles=_mesh(r, mesh_path, f"{where}.mesh") * np.float32(scale),
            )
        )
    arms = []
    arm_names: set[str] = set()
    for i, entry in enumerate(_list(r, raw.get("arms", []), "arms")):
        where = f"arms[{i}]"
        entry = r.mapping(entry, where)
        name = _name(r, entry, where, arm_names)
        config = r.require(entry, "config", f"{where}.")
        if not isinstance(config, str) or not config:
            raise r.error(f"{where}.config", f"expected a robot config file name, got {short(config)}")
        config_file = resolved(path.parent / config)
        problem = file_problem(config_file)  # a FIFO, a device, a name too long: never raises
        if problem is not None:
            reason = "no such file" if problem == "not found" else problem
            raise r.error(f"{where}.config", f"{reason}: {shown(config_file)}")
        base = read_transform(r, entry["base"], f"{where}.base") if "base" in entry else None
        arms.append(SceneArm(name=name, config=config_file, base=base))
    return Scene(path=path, objects=tuple(objects), arms=tuple(arms))


def _mesh(r: FieldReader, path: Path, where: str) -> np.ndarray:
    try:
        return load_stl(path)
    except InputError as error:  # the mesh's own error, said to be the field's
        raise r.error(where, str(error)) from None


def _list(r: FieldReader, value: Any, where: str) -> list[Any]:
    if not isinstance(value, list):
        raise r.error(where, f"expected a list, got {short(value)}")
    return value


def _name(r: FieldReader, entry: dict[str, Any], where: str, seen: set[str]) -> str:
    name = r.require(entry, "name", f"{where}.")
    if not isinstance(name, str) or not _NAME.match(name):
        raise r.error(f"{where}.name", f"expected a name of letters, digits and _, got {short(name)}")
    if name in seen:
        raise r.error(f"{where}.name", f"name {short(name)} is used twice")
    seen.add(name)
    return name
