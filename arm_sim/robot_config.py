"""Robot configuration files (YAML) for serial arms: RoboClass's config fields, checked.

Format (every angle in radians, every length in metres; any number may instead be written as an
expression string using ``pi`` and ``deg`` = pi/180, e.g. ``-pi/2`` or ``165*deg``)::

    name: IRB120                    # robot name
    mesh_folder: meshes/irb120      # folder of the STL files, relative to this file
    dof: 6                          # number of joints (any number >= 1)
    base:                           # world pose of frame 0: {xyz, rpy} (rpy = roll pitch yaw,
      xyz: [0, 0, 0]                #   fixed axes X, Y, Z) or a 4x4 matrix (RoboClass's originTr)
      rpy: [0, 0, 0]
    joint_types: rrrrrr             # r = revolute, p = prismatic (string or list)
    joint_names: [joint_1, ...]     # optional, default joint_1 … joint_<dof>
    modified_dh: false              # optional: true = modified (Craig) DH, default standard DH
    dh:                             # one value per joint
      theta: [0, -pi/2, 0, 0, 0, 0] # joint angle offset (the joint angle is q + theta)
      d: [0.29, 0, 0, 0.30, 0, 0.072]  # link offset (prismatic: q + d)
      a: [0, 0.27, 0.07, 0, 0, 0]   # link length
      alpha: [-pi/2, 0, -pi/2, -pi/2, pi/2, 0]  # link twist
    limits:
      position: [[-165*deg, 165*deg], ...]   # [min, max] per joint
      velocity: [250*deg, ...]               # maximum speed per joint (1e-9..1e6)
    dynamics:                       # optional (without it efforts are zero)
      gravity: [0, 0, -9.81]        # world gravity, optional
      mass: [3.07, ...]             # per link 1..dof (kg)
      cog: [[0, -0.1, 0], ...]      # centre of gravity in the link's DH frame (m)
      inertia: [[[..3x3..]], ...]   # inertia about the centre of gravity, link frame (kg m^2)
    links:                          # STL elements per link; link 0 is the base
      - link: 0
        elements:
          - mesh: IRB120_base.stl   # file in mesh_folder, binary or ASCII STL
            color: [0.9, 0.4, 0.2]  # RGB or RGBA, 0..1
            scale: 1.0              # optional: STL units to metres (0.001 for millimetres)
    view:                           # optional: plot limits and camera (used by the Rerun view)
      limits: [-0.4, 1.0, -0.8, 1.8, -0.4, 1.0]  # minX maxX minY maxY minZ maxZ
      azimuth: 40                   # degrees
      elevation: 10                 # degrees

Each element's mesh is drawn in its link's DH frame (frame k = after joint k; the base in frame 0),
as RoboClass's STL export convention. Every error names the file, the field and the index.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sim_runtime.inputfile import resolved
from sim_runtime.yamlfile import FieldReader, field_name, load_yaml, short

MAX_JOINTS = 100
"""Most joints a config may declare (a guard against a typo such as 6000)."""
MAX_LIMIT = 1e6
"""Largest |joint limit| (rad or m) and joint speed (rad/s or m/s) a config may hold."""
MAX_NAME_CHARS = 200
"""Longest robot name (it becomes part of topic and frame names)."""
MIN_VELOCITY = 1e-9
"""Slowest joint speed limit (rad/s or m/s)."""


@dataclass(frozen=True)
class MeshElement:
    """One STL element of a link: absolute mesh path, RGBA colour, scale (STL units -> m)."""

    mesh: Path
    color: tuple[float, float, float, float]
    scale: float = 1.0
    #: Where the config names the mesh ("<file>: links[0].elements[1].mesh"), for messages.
    where: str = field(default="", compare=False)


@dataclass(frozen=True)
class Dynamics:
    """Rigid-body parameters of links 1..n in their DH frames, and world gravity."""

    mass: np.ndarray  # (n,)
    cog: np.ndarray  # (n, 3)
    inertia: np.ndarray  # (n, 3, 3), about the centre of gravity
    gravity: np.ndarray  # (3,)


@dataclass(frozen=True)
class ViewInfo:
    """Axis limits [minX maxX minY maxY minZ maxZ] and camera azimuth/elevation in degrees."""

    limits: tuple[float, ...] = (-1.0, 1.0, -1.0, 1.0, 0.0, 1.0)
    azimuth: float = 40.0
    elevation: float = 10.0


@dataclass(frozen=True)
class RobotConfig:
    """A parsed, checked robot configuration file (see the module docstring for the format)."""

    path: Path
    name: str
    mesh_folder: Path
    dof: int
    base: np.ndarray  # (4, 4)
    joint_types: str
    joint_names: tuple[str, ...]
    theta: np.ndarray
    d: np.ndarray
    a: np.ndarray
    alpha: np.ndarray
    modified_dh: bool
    position_limits: np.ndarray  # (n, 2)
    velocity_limits: np.ndarray  # (n,)
    dynamics: Dynamics
    links: tuple[tuple[MeshElement, ...], ...]  # dof + 1 entries, link 0 = base
    view: ViewInfo = field(default_factory=ViewInfo)


def transform_from_xyz_rpy(xyz: np.ndarray, rpy: np.ndarray) -> np.ndarray:
    """4x4 transform: translation ``xyz`` and rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(rpy[0]), math.sin(rpy[0])
    cp, sp = math.cos(rpy[1]), math.sin(rpy[1])
    cy, sy = math.cos(rpy[2]), math.sin(rpy[2])
    T = np.eye(4)
    T[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = xyz
    return T


def read_transform(reader: FieldReader, value: Any, where: str) -> np.ndarray:
    """A pose field: {xyz, rpy} (both optional) or a 4x4 homogeneous matrix."""
    if isinstance(value, dict):
        reader.mapping(value, where, {"xyz", "rpy"})
        xyz = reader.vector(value.get("xyz", [0, 0, 0]), f"{where}.xyz", 3)
        rpy = reader.vector(value.get("rpy", [0, 0, 0]), f"{where}.rpy", 3)
        return transform_from_xyz_rpy(xyz, rpy)
    T = reader.matrix(value, where, 4, 4)
    if (
        not np.allclose(T[3], [0, 0, 0, 1])
        or not np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-6)
        or np.linalg.det(T[:3, :3]) < 0
    ):
        raise reader.error(where, "not a rigid transform (rotation must be orthonormal, last row 0 0 0 1)")
    return T


def read_color(reader: FieldReader, value: Any, where: str) -> tuple[float, float, float, float]:
    """RGB or RGBA in 0..1 -> RGBA tuple."""
    if not isinstance(value, (list, tuple)) or len(value) not in (3, 4):
        raise reader.error(where, f"expected [r, g, b] or [r, g, b, a] in 0..1, got {short(value)}")
    rgba = reader.vector(value, where)
    if ((rgba < 0) | (rgba > 1)).any():
        raise reader.error(where, f"colour components must be in 0..1, got {short(value)}")
    if len(rgba) == 3:
        rgba = np.append(rgba, 1.0)
    r, g, b, a = (float(c) for c in rgba)
    return r, g, b, a


#: The top-level fields of a robot config file.
KNOWN_FIELDS = frozenset(
    {
        "name",
        "mesh_folder",
        "dof",
        "base",
        "joint_types",
        "joint_names",
        "modified_dh",
        "dh",
        "limits",
        "dynamics",
        "links",
        "view",
    }
)


def load_robot_config(path: str | os.PathLike[str]) -> RobotConfig:
    """Read and check a robot configuration file; raises InputError naming file, field and index."""
    path = resolved(path)
    raw = load_yaml(path, "robot config")
    r = FieldReader(path, expressions=True)
    raw = r.mapping(raw, "<top level>")
    unknown = [k for k in raw if k not in KNOWN_FIELDS]
    if unknown:
        raise r.error(field_name(unknown[0]), f"unknown field; known fields: {sorted(KNOWN_FIELDS)}")

    name = r.text(r.require(raw, "name"), "name")
    if len(name) > MAX_NAME_CHARS:
        raise r.error("name", f"at most {MAX_NAME_CHARS} characters, got {len(name)}")
    mesh_folder = resolved(path.parent / r.text(raw.get("mesh_folder", "."), "mesh_folder"))
    dof = r.integer(r.require(raw, "dof"), "dof", minimum=1, maximum=MAX_JOINTS)
    base = read_transform(r, raw.get("base", {}), "base")
    types = _read_joint_types(r, r.require(raw, "joint_types"), dof)
    names = _read_joint_names(r, raw.get("joint_names", [f"joint_{i + 1}" for i in range(dof)]), dof)
    modified = raw.get("modified_dh", False)
    if not isinstance(modified, bool):
        raise r.error("modified_dh", f"expected true or false, got {short(modified)}")
    params = _read_dh(r, r.mapping(r.require(raw, "dh"), "dh"), dof)
    position, velocity = _read_limits(r, r.mapping(r.require(raw, "limits"), "limits"), dof)
    dynamics = _read_dynamics(r, raw.get("dynamics"), dof)
    links = _read_links(r, r.require(raw, "links"), dof, mesh_folder)
    view = _read_view(r, raw.get("view"))
    return RobotConfig(
        path=path,
        name=name,
        mesh_folder=mesh_folder,
        dof=dof,
        base=base,
        joint_types=types,
        joint_names=names,
        theta=params["theta"],
        d=params["d"],
        a=params["a"],
        alpha=params["alpha"],
        modified_dh=modified,
        position_limits=position,
        velocity_limits=velocity,
        dynamics=dynamics,
        links=links,
        view=view,
    )


def _read_joint_types(r: FieldReader, raw: Any, dof: int) -> str:
    if isinstance(raw, (list, tuple)) and len(raw) == dof:
        types = "".join(r.text(t, f"joint_types[{i}]") for i, t in enumerate(raw))
    elif isinstance(raw, str):
        types = raw
    else:
        raise r.error("joint_types", f"expected {dof} joint types (a string such as 'rrp' or a list), got {short(raw)}")
    if len(types) != dof:
        raise r.error("joint_types", f"expected {dof} joint types (dof), got {len(types)}: {short(types)}")
    for i, t in enumerate(types):
        if t not in "rp":
            raise r.error(f"joint_types[{i}]", f"unknown joint type {short(t)}; use 'r' (revolute) or 'p' (prismatic)")
    return types


def _read_joint_names(r: FieldReader, raw: Any, dof: int) -> tuple[str, ...]:
    if not isinstance(raw, (list, tuple)) or len(raw) != dof:
        raise r.error("joint_names", f"expected {dof} names (dof), got {short(raw)}")
    names = tuple(r.text(n, f"joint_names[{i}]") for i, n in enumerate(raw))
    if len(set(names)) != dof:
        raise r.error("joint_names", f"names must be unique, got {short(list(names))}")
    return names


def _read_dh(r: FieldReader, dh: dict[str, Any], dof: int) -> dict[str, np.ndarray]:
    params = {}
    for key in ("theta", "d", "a", "alpha"):
        value = r.require(dh, key, "dh.")
        if not isinstance(value, (list, tuple)) or len(value) != dof:
            count = len(value) if isinstance(value, (list, tuple)) else "not a list"
            raise r.error(f"dh.{key}", f"expected {dof} values (dof), got {count}")
        params[key] = r.vector(value, f"dh.{key}", dof)
    return params


def _read_limits(r: FieldReader, limits: dict[str, Any], dof: int) -> tuple[np.ndarray, np.ndarray]:
    """(position (dof, 2) [min, max], velocity (dof,)) limits."""
    position = r.require(limits, "position", "limits.")
    if not isinstance(position, (list, tuple)) or len(position) != dof:
        raise r.error("limits.position", f"expected {dof} [min, max] pairs (dof), got {short(position)}")
    position = np.array([r.vector(p, f"limits.position[{i}]", 2) for i, p in enumerate(position)])
    for i, (lo, hi) in enumerate(position):
        if not lo < hi:
            raise r.error(f"limits.position[{i}]", f"min must be below max, got [{lo}, {hi}]")
        if max(abs(lo), abs(hi)) > MAX_LIMIT:
            raise r.error(f"limits.position[{i}]", f"beyond ±{MAX_LIMIT:g}, got [{lo}, {hi}]")
    velocity = r.vector(r.require(limits, "velocity", "limits."), "limits.velocity", dof)
    for i, v in enumerate(velocity):
        if v <= 0:
            raise r.error(f"limits.velocity[{i}]", f"must be > 0, got {v}")
        if not MIN_VELOCITY <= v <= MAX_LIMIT:  # 1e-320 rad/s makes every move last forever
            raise r.error(f"limits.velocity[{i}]", f"must be within {MIN_VELOCITY:g}..{MAX_LIMIT:g}, got {v}")
    return position, velocity


def _read_dynamics(r: FieldReader, raw: Any, dof: int) -> Dynamics:
    if raw is None:
        return Dynamics(
            mass=np.zeros(dof),
            cog=np.zeros((dof, 3)),
            inertia=np.zeros((dof, 3, 3)),
            gravity=np.array([0.0, 0.0, -9.81]),
        )
    raw = r.mapping(raw, "dynamics")
    gravity = r.vector(raw.get("gravity", [0.0, 0.0, -9.81]), "dynamics.gravity", 3)
    mass = r.vector(r.require(raw, "mass", "dynamics."), "dynamics.mass", dof)
    for i, m in enumerate(mass):
        if m < 0:
            raise r.error(f"dynamics.mass[{i}]", f"must be >= 0, got {m}")
    cog_raw = r.require(raw, "cog", "dynamics.")
    if not isinstance(cog_raw, (list, tuple)) or len(cog_raw) != dof:
        raise r.error("dynamics.cog", f"expected {dof} [x, y, z] vectors (dof), got {short(cog_raw)}")
    cog = np.array([r.vector(c, f"dynamics.cog[{i}]", 3) for i, c in enumerate(cog_raw)])
    inertia_raw = r.require(raw, "inertia", "dynamics.")
    if not isinstance(inertia_raw, (list, tuple)) or len(inertia_raw) != dof:
        raise r.error("dynamics.inertia", f"expected {dof} 3x3 matrices (dof), got {short(inertia_raw)}")
    inertia = np.array([r.matrix(m, f"dynamics.inertia[{i}]", 3, 3) for i, m in enumerate(inertia_raw)])
    for i, m in enumerate(inertia):
        if not np.allclose(m, m.T) or np.linalg.eigvalsh(m).min() < -1e-12:
            raise r.error(f"dynamics.inertia[{i}]", f"must be symmetric positive semi-definite, got {m.tolist()}")
    return Dynamics(mass=mass, cog=cog, inertia=inertia, gravity=gravity)


def _read_links(r: FieldReader, raw: Any, dof: int, mesh_folder: Path) -> tuple[tuple[MeshElement, ...], ...]:
    if not isinstance(raw, (list, tuple)):
        raise r.error("links", f"expected a list of links, got {short(raw)}")
    links: list[tuple[MeshElement, ...] | None] = [None] * (dof + 1)
    for i, entry in enumerate(raw):
        where = f"links[{i}]"
        entry = r.mapping(entry, where)
        number = r.require(entry, "link", f"{where}.")
        if isinstance(number, bool) or not isinstance(number, int) or not 0 <= number <= dof:
            raise r.error(f"{where}.link", f"expected a link number 0..{dof} (0 = base), got {short(number)}")
        if links[number] is not None:
            raise r.error(f"{where}.link", f"link {number} is listed twice")
        elements = r.require(entry, "elements", f"{where}.")
        if not isinstance(elements, (list, tuple)) or not elements:
            raise r.error(f"{where}.elements", f"expected a non-empty list of elements, got {short(elements)}")
        parsed = []
        for j, element in enumerate(elements):
            ewhere = f"{where}.elements[{j}]"
            element = r.mapping(element, ewhere)
            mesh = r.require(element, "mesh", f"{ewhere}.")
            if not isinstance(mesh, str) or not mesh:
                raise r.error(f"{ewhere}.mesh", f"expected an STL file name, got {short(mesh)}")
            color = read_color(r, element.get("color", [0.7, 0.7, 0.7]), f"{ewhere}.color")
            scale = r.number(element.get("scale", 1.0), f"{ewhere}.scale")
            if scale <= 0:
                raise r.error(f"{ewhere}.scale", f"must be > 0, got {scale}")
            where = r.where(f"{ewhere}.mesh")
            parsed.append(MeshElement(mesh=resolved(mesh_folder / mesh), color=color, scale=scale, where=where))
        links[number] = tuple(parsed)
    return tuple(link or () for link in links)


def _read_view(r: FieldReader, raw: Any) -> ViewInfo:
    if raw is None:
        return ViewInfo()
    raw = r.mapping(raw, "view")
    limits = tuple(r.vector(raw.get("limits", list(ViewInfo.limits)), "view.limits", 6))
    for axis, k in zip("XYZ", range(0, 6, 2), strict=True):
        if not limits[k] < limits[k + 1]:
            raise r.error("view.limits", f"min{axis} must be below max{axis}, got {limits[k]}, {limits[k + 1]}")
    return ViewInfo(
        limits=limits,
        azimuth=r.number(raw.get("azimuth", ViewInfo.azimuth), "view.azimuth"),
        elevation=r.number(raw.get("elevation", ViewInfo.elevation), "view.elevation"),
    )
