"""The 3D view of arms and scene objects, shared by the Arm page (live) and the Replay page (a bag).

Both draw the same thing: groups of :class:`~studio.arm.ros_client.Drawable` (mesh, colour, scale) with
one pose each, as an arm's ``robot_markers`` and a world's ``scene_markers`` describe them, plus
each arm's end-effector frame. :class:`ArmScene` owns a NiceGUI ``ui.scene`` and keeps it in step
with the groups it is given: a mesh is read and reduced once per studio (:data:`MESHES`, served from
``/studio/mesh/<key>.stl``), put on the scene when ready, and only moved after that.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

import numpy as np
from nicegui import background_tasks, ui
from nicegui.elements.scene.scene_object3d import Object3D

from sim_runtime.errors import InputError
from sim_runtime.paths import mesh_path
from studio.arm.meshes import DISPLAY_FACES, MeshCache
from studio.arm.ros_client import Drawable, Group

MESHES = MeshCache()
"""Every page's meshes: a file is read and reduced once per studio."""
MESH_ROUTE = "/studio/mesh"
EE_AXES_M = 0.1
WORLD_AXES_M = 0.2
CAMERA = {"x": 0.95, "y": -0.95, "z": 0.8, "look_at_x": 0.15, "look_at_y": 0.0, "look_at_z": 0.3}
"""Where the camera starts, before any arm is seen (the IRB120 at the origin fills the view)."""


@dataclass
class Shown:
    """A drawable on the scene: its three.js object, what it looks like, its owner."""

    obj: Object3D | None  # None while its mesh is being prepared
    drawable: Drawable
    owner: str
    name: str


def camera_for(points: np.ndarray) -> dict[str, float]:
    """A camera looking at the middle of ``points`` (m, 3) from the front right, above, far enough
    back to see all of them (a perspective camera's 75° field of view)."""
    if len(points) == 0:
        return dict(CAMERA)
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = (lo + hi) / 2
    radius = max(0.35, float(np.linalg.norm(hi - lo)) / 2 + 0.25)
    offset = np.array([0.62, -0.62, 0.48]) * radius * 1.6
    x, y, z = (centre + offset).tolist()
    return {"x": x, "y": y, "z": z, "look_at_x": centre[0], "look_at_y": centre[1], "look_at_z": centre[2]}


def rotations(quaternions: np.ndarray) -> np.ndarray:
    """(m, 3, 3) rotation matrices of quaternions (m, 4) x y z w (normalised)."""
    q = quaternions / np.maximum(np.linalg.norm(quaternions, axis=1, keepdims=True), 1e-12)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )


def element_name(drawable: Drawable) -> str:
    """What the element list calls a drawable: its mesh file, else its marker name."""
    if drawable.mesh_uri:
        return drawable.mesh_uri.rsplit("/", 1)[-1]
    return drawable.key


def _hex(rgba) -> str:
    return "#{:02x}{:02x}{:02x}".format(*(max(0, min(255, round(c * 255))) for c in rgba[:3]))


class ArmScene:
    """A ``ui.scene`` drawing groups of meshes and end-effector frames (make it inside a layout)."""

    def __init__(self, size: tuple[int, int], css_class: str, faces: int = DISPLAY_FACES) -> None:
        self.faces = faces
        self.shown: dict[str, Shown] = {}  # element key ('<owner>|<marker ns>/<id>') -> what is on the scene
        self.hidden: set[str] = set()
        self.opacity: dict[str, float] = {}
        self.drawn_seq: dict[str, int] = {}
        self.axes: dict[str, Object3D] = {}  # arm prefix -> end-effector frame
        self.show_frames = True
        self.fitted = False
        self.last_points: dict[str, np.ndarray] = {}  # owner -> its elements' positions, for the camera
        self.stale = False  # an element came onto the scene since the last draw: it waits to be placed
        # Hidden and shown through a wrapper: a scene that is itself hidden when the page loads
        # never receives its objects. A fixed CSS size: three.js takes the canvas size from the
        # element's, which would otherwise shrink-wrap a canvas made 0 × 0 while hidden.
        with ui.element("div") as self.box:
            self.scene = (
                ui.scene(width=size[0], height=size[1], grid=(4, 40), background_color="#f4f4f4")
                .classes(css_class)
                .style(f"width:{size[0]}px;height:{size[1]}px")
            )
        self.scene.axes_helper(WORLD_AXES_M)  # the world frame
        self.scene.move_camera(**CAMERA, duration=0)

    def set_shown(self, on: bool) -> None:
        """Show or hide the view. three.js sizes its canvas when the scene mounts (0 × 0 if it was
        hidden then) and again only when the window resizes: shown, it is resized once laid out."""
        self.box.set_visibility(on)
        if on:
            ui.run_javascript(
                f"(function fit(tries) {{ const el = getHtmlElement({self.scene.id}); if (!el || tries > 600) return;"
                f" if (el.clientWidth) getElement({self.scene.id}).resize();"
                " else requestAnimationFrame(() => fit(tries + 1)); })(0)"
            )

    # ---------------------------------------------------------------- drawing
    def draw(self, groups: list[Group], end_effectors: dict[str, tuple[np.ndarray, np.ndarray]]) -> None:
        """Show exactly ``groups`` and the end-effector frames (prefix -> (xyz, quaternion x y z w))."""
        self.stale = False
        owners = {g.owner for g in groups}
        for key in [k for k, s in self.shown.items() if s.owner not in owners]:
            self.forget(key)
        for owner in [o for o in self.last_points if o not in owners]:
            del self.last_points[owner]
        for prefix in [p for p in self.axes if p not in end_effectors]:
            self.axes.pop(prefix).delete()
        with self.scene._batch_calls():  # one message per frame instead of one per call
            for group in groups:
                self.draw_group(group)
            for prefix, (xyz, quat) in end_effectors.items():
                self.draw_end_effector(prefix, xyz, quat)
        if not self.fitted and self.shown and all(s.obj is not None for s in self.shown.values()):
            self.fitted = True  # once: later the user's own orbit, pan and zoom are left alone
            self.reset_view()

    def draw_group(self, group: Group) -> None:
        owner = group.owner
        keys = [f"{owner}|{d.key}" for d in group.look]
        for key in [k for k, s in self.shown.items() if s.owner == owner and k not in keys]:
            self.forget(key)
        for key, drawable in zip(keys, group.look, strict=True):
            shown = self.shown.get(key)
            if shown is None:
                shown = self.shown[key] = Shown(None, drawable, owner, element_name(drawable))
                background_tasks.create(self.create(key, shown), name=f"arm mesh {key}")
            elif shown.drawable != drawable:  # e.g. the world's marker_alpha changed
                shown.drawable = drawable
                if shown.obj is not None:
                    self.apply_material(key, shown)
        if self.drawn_seq.get(owner) == group.seq and not any(self.shown[k].obj is None for k in keys):
            return
        self.drawn_seq[owner] = group.seq
        poses = group.poses
        if len(poses) != len(keys):
            return
        self.last_points[owner] = poses[:, :3]
        rot = rotations(poses[:, 3:]).tolist()
        for k, key in enumerate(keys):
            obj = self.shown[key].obj
            if obj is not None:
                obj.move(*poses[k, :3].tolist()).rotate_R(rot[k])

    async def create(self, key: str, shown: Shown) -> None:
        """Put a drawable on the scene once its mesh is ready (prepared in a worker thread, so a
        huge file never holds up the page or the other meshes)."""
        d = shown.drawable
        obj: Object3D | None = None
        if d.mesh_uri:
            path = mesh_path(d.mesh_uri)
            try:
                if path is None:
                    raise InputError(f"{d.mesh_uri}: cannot resolve this mesh URI on this machine")
                mesh = await asyncio.to_thread(MESHES.prepare, path, self.faces)
            except InputError as err:
                if not self.scene.is_deleted:
                    with self.scene:  # the tab's context: this runs as a task of its own
                        ui.notify(f"{err}: drawing a box instead", type="warning")
            else:
                if self.shown.get(key) is not shown or self.scene.is_deleted:
                    return
                obj = self.scene.stl(f"{MESH_ROUTE}/{mesh.key}.stl")
                shown.name = f"{element_name(d)} ({mesh.faces_out:,} of {mesh.faces_in:,} faces)"
        if self.shown.get(key) is not shown or self.scene.is_deleted:
            return
        if obj is None:
            obj = self.scene.box(1.0, 1.0, 1.0)
        obj.with_name(key).scale(*d.scale)  # the name: tests and tools find an element by its key
        shown.obj = obj
        self.drawn_seq.pop(shown.owner, None)  # place it at the next draw, even if no pose came in
        self.stale = True
        self.apply_material(key, shown)
        if key in self.hidden:
            obj.visible(False)

    def forget(self, key: str) -> None:
        shown = self.shown.pop(key)
        if shown.obj is not None:
            shown.obj.delete()

    def clear(self) -> None:
        """Nothing drawn (another bag is opened): meshes, frames, and the camera fitted again."""
        for key in list(self.shown):
            self.forget(key)
        for axes in self.axes.values():
            axes.delete()
        self.axes.clear()
        self.drawn_seq.clear()
        self.last_points.clear()
        self.fitted = False

    def draw_end_effector(self, prefix: str, xyz: np.ndarray, quat: np.ndarray) -> None:
        axes = self.axes.get(prefix)
        if axes is None:
            axes = self.axes[prefix] = self.scene.axes_helper(EE_AXES_M)
            axes.visible(self.show_frames)
        axes.move(*np.asarray(xyz, dtype=float).tolist()).rotate_R(rotations(np.array([quat], dtype=float))[0].tolist())

    # ---------------------------------------------------------------- what the user changes
    def set_visible(self, key: str, on: bool) -> None:
        (self.hidden.discard if on else self.hidden.add)(key)
        shown = self.shown.get(key)
        if shown is not None and shown.obj is not None:
            shown.obj.visible(on)

    def set_opacity(self, key: str, value: float) -> None:
        self.opacity[key] = float(value)
        shown = self.shown.get(key)
        if shown is not None and shown.obj is not None:
            self.apply_material(key, shown)

    def apply_material(self, key: str, shown: Shown) -> None:
        if shown.obj is None:
            return  # its mesh is still being prepared: it gets its material once on the scene
        rgba = shown.drawable.rgba
        shown.obj.material(_hex(rgba), opacity=float(rgba[3]) * self.opacity.get(key, 1.0), side="both")

    def set_frames_visible(self, on: bool) -> None:
        self.show_frames = bool(on)
        for axes in self.axes.values():
            axes.visible(self.show_frames)

    def reset_view(self) -> None:
        """Every element drawn in view."""
        points = np.concatenate(list(self.last_points.values())) if self.last_points else np.zeros((0, 3))
        self.scene.move_camera(**camera_for(points), up_x=0.0, up_y=0.0, up_z=1.0)

    def ready(self) -> int:
        """How many elements are on the scene (the rest wait for their mesh)."""
        return sum(s.obj is not None for s in self.shown.values())
