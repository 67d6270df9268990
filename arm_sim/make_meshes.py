"""Generate the shipped arm and scene meshes (run once: ``python -m arm_sim.make_meshes``).

We cannot ship ABB's or Schunk's CAD, so every link gets plain shapes that follow its DH geometry:
built in world coordinates at the home pose (q = 0) and written in the link's DH frame, as
RoboClass's CAD export did. A link k gets a tube along the DH path from frame k-1 to frame k
(``d`` along z_{k-1}, then ``a`` along x_k) and a joint housing (cylinder) around the next joint's
axis. Files are binary STL except ``IRB120_link6.stl``, written as ASCII so both loaders are used.
Needs trimesh (a development tool, not needed at run time).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from arm_sim.arm import Arm
from arm_sim.stl import write_stl

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config" / "arm"
SECTIONS = 28  # facets around every cylinder: round enough, small files


def _cylinder(p0: npt.ArrayLike, p1: npt.ArrayLike, radius: float) -> trimesh.Trimesh | None:
    start, end = np.asarray(p0, float), np.asarray(p1, float)
    if np.linalg.norm(end - start) < 1e-6:
        return None
    cylinder: trimesh.Trimesh = trimesh.creation.cylinder(radius=radius, segment=[start, end], sections=SECTIONS)
    return cylinder


def _ball(center: npt.ArrayLike, radius: float) -> trimesh.Trimesh:
    ball: trimesh.Trimesh = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    ball.apply_translation(center)
    return ball


def _merge(meshes: Sequence[trimesh.Trimesh | None]) -> trimesh.Trimesh:
    merged = trimesh.util.concatenate([m for m in meshes if m is not None])
    assert isinstance(merged, trimesh.Trimesh)  # concatenating meshes gives a mesh
    return merged


def _box(center: npt.ArrayLike, extents: npt.ArrayLike, rotation: np.ndarray | None = None) -> trimesh.Trimesh:
    T = np.eye(4)
    T[:3, :3] = np.eye(3) if rotation is None else rotation
    T[:3, 3] = center
    box: trimesh.Trimesh = trimesh.creation.box(extents=extents, transform=T)
    return box


def _tube(frames: np.ndarray, arm: Arm, k: int, radius: float) -> trimesh.Trimesh:
    """Link k's body along the DH path: o_{k-1} -> o_{k-1} + d z_{k-1} -> o_k, with rounded joints."""
    o_prev = frames[k - 1, :3, 3]
    corner = o_prev + arm.chain.dh[k - 1, 1] * frames[k - 1, :3, 2]
    o_k = frames[k, :3, 3]
    parts = [_cylinder(o_prev, corner, radius), _cylinder(corner, o_k, radius)]
    if np.linalg.norm(corner - o_prev) > 1e-6 and np.linalg.norm(o_k - corner) > 1e-6:
        parts.append(_ball(corner, radius))
    if all(p is None for p in parts):
        parts.append(_ball(o_k, radius))
    return _merge(parts)


def _housing(frames: np.ndarray, k: int, radius: float, length: float, offset: float = 0.0) -> trimesh.Trimesh | None:
    """Cylinder around joint k+1's axis (z of frame k) centred ``offset`` along it from o_k."""
    z = frames[k, :3, 2]
    centre = frames[k, :3, 3] + offset * z
    return _cylinder(centre - 0.5 * length * z, centre + 0.5 * length * z, radius)


def _to_link(mesh: trimesh.Trimesh, frame: np.ndarray) -> np.ndarray:
    """Triangles of a world-coordinate mesh expressed in the link frame."""
    local = mesh.copy()
    local.apply_transform(np.linalg.inv(frame))
    triangles: np.ndarray = local.triangles.astype(np.float32)
    return triangles


def make_irb120(folder: Path) -> list[Path]:
    arm = Arm.from_file(CONFIG_DIR / "irb120.yaml", load_meshes=False)
    frames = arm.fkine_all(np.zeros(arm.n))
    tube_r = [0.07, 0.05, 0.055, 0.04, 0.03, 0.022]
    house = [(0.07, 0.17, 0.0), (0.06, 0.14, 0.0), (0.06, 0.12, 0.0), (0.04, 0.09, 0.0), (0.033, 0.06, 0.02)]
    shapes = {0: _merge([_box([0, 0, 0.01], [0.24, 0.18, 0.02]), _cylinder([0, 0, 0.02], [0, 0, 0.12], 0.09)])}
    for k in range(1, arm.n + 1):
        parts: list[trimesh.Trimesh | None] = [_tube(frames, arm, k, tube_r[k - 1])]
        if k < arm.n:
            r, length, offset = house[k - 1]
            parts.append(_housing(frames, k, r, length, offset))
        else:
            parts.append(_housing(frames, k, 0.032, 0.012, -0.006))  # flange disc
        shapes[k] = _merge(parts)
    written = []
    for k, mesh in shapes.items():
        name = "IRB120_base.stl" if k == 0 else f"IRB120_link{k}.stl"
        path = folder / name
        write_stl(path, _to_link(mesh, frames[k]), ascii=(k == arm.n), name=name[:-4])
        written.append(path)
    return written


def make_csa7(folder: Path) -> list[Path]:
    arm = Arm.from_file(CONFIG_DIR / "csa7.yaml", load_meshes=False)
    frames = arm.fkine_all(np.zeros(arm.n))
    # module radius shrinks towards the wrist, as Schunk's modules do
    module_r = [0.065, 0.06, 0.055, 0.05, 0.045, 0.04, 0.035]
    files: dict[str, tuple[int, trimesh.Trimesh | None]] = {
        "csa_base_plate.stl": (0, _cylinder([0, 0, 0], [0, 0, 0.02], 0.14)),
        "csa_base_column.stl": (0, _cylinder([0, 0, 0.02], [0, 0, 0.12], 0.07)),
    }
    for k in range(1, arm.n + 1):
        r = module_r[k - 1]
        files[f"csa_link{k}_tube.stl"] = (k, _tube(frames, arm, k, 0.7 * r))
        if k < arm.n:
            files[f"csa_link{k}_module.stl"] = (k, _housing(frames, k, r, 2.1 * r))
            files[f"csa_link{k}_ring.stl"] = (k, _housing(frames, k, 1.08 * r, 0.25 * r))
    # gripper on the flange (frame 7: z along the approach direction)
    T = frames[arm.n]
    R, o = T[:3, :3], T[:3, 3]
    files["csa_gripper_body.stl"] = (arm.n, _box(o + R @ [0, 0, 0.025], [0.09, 0.05, 0.05], R))
    for name, side in (("csa_finger_left.stl", 1.0), ("csa_finger_right.stl", -1.0)):
        files[name] = (arm.n, _box(o + R @ [side * 0.03, 0, 0.08], [0.015, 0.03, 0.06], R))
    written = []
    for name, (k, mesh) in files.items():
        assert mesh is not None, f"{name}: a cylinder of zero length"
        path = folder / name
        write_stl(path, _to_link(mesh, frames[k]), name=name[:-4])
        written.append(path)
    return written


def make_scene(folder: Path) -> list[Path]:
    """A work table (top at z = 0.4 m in its own frame's origin at the floor) and a box."""
    legs = [_box([x, y, 0.19], [0.05, 0.05, 0.38]) for x in (-0.35, 0.35) for y in (-0.55, 0.55)]
    table = _merge([_box([0, 0, 0.39], [0.8, 1.2, 0.02]), *legs])
    box = _box([0, 0, 0.05], [0.1, 0.1, 0.1])
    written = []
    for name, mesh in (("table.stl", table), ("box.stl", box)):
        path = folder / name
        write_stl(path, mesh.triangles.astype(np.float32), name=name[:-4])
        written.append(path)
    return written


def main() -> None:
    """Write every shipped mesh into config/arm/meshes/."""
    for sub, make in (("irb120", make_irb120), ("csa7", make_csa7), ("scene", make_scene)):
        folder = CONFIG_DIR / "meshes" / sub
        folder.mkdir(parents=True, exist_ok=True)
        for path in make(folder):
            print(f"{path.relative_to(CONFIG_DIR)}: {path.stat().st_size} bytes")


if __name__ == "__main__":
    main()
