"""The Arm page (RoboClass's figure and slider GUI): every arm of the domain in 3D, joint sliders,
target pose, readouts, stored trajectories.

What is drawn comes from each arm's ``robot_markers`` (mesh, colour, scale, pose per element) and
its world's ``scene_markers``, so any arm world works, started here or elsewhere. Meshes go to the
browser once, reduced for display (:mod:`studio.arm.meshes`), from the route ``/studio/mesh/<key>.stl``
that serves only meshes an arm named. Angles are shown in degrees; everything sent is in radians.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from html import escape

import numpy as np
from fastapi import HTTPException, Response
from nicegui import app, ui

from arm_sim.robot_config import transform_from_xyz_rpy
from arm_sim.trajectory_file import load_trajectory
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path, mesh_path
from sim_tools.cli import executable_command
from studio.arm.meshes import DISPLAY_FACES
from studio.arm.ros_client import ArmRos, ArmState, Group
from studio.arm.scene import MESH_ROUTE, MESHES, ArmScene, rotations
from studio.shell.app import Studio
from studio.shell.kit import nav, stop_started_world
from studio.shell.processes import Child, clock_topic, namespace_args, yaml_string

FRAME_PERIOD_S = 0.05
VIEW_SIZE = (820, 620)
DETAIL_OPTIONS = {
    DISPLAY_FACES: f"{DISPLAY_FACES // 1000}k faces per mesh",
    200_000: "200k faces per mesh",
    0: "every face",
}
SYNC_AFTER_S = 1.0
"""Sliders follow the arm once it is still and nobody has moved a slider for this long."""
REACHED_M, REACHED_RAD = 2e-3, 2e-2
TARGET_TIMEOUT_S = 30.0


def _made_arm_ros(studio: Studio) -> ArmRos | None:
    """The studio's arm client if it has been made."""
    made = studio.families.get("arm")
    return made if isinstance(made, ArmRos) else None


def arm_ros(studio: Studio) -> ArmRos | None:
    """The studio's arm client (made on first use, once the studio's ROS node runs)."""
    made = _made_arm_ros(studio)
    if made is None and studio.ros is not None:
        made = studio.families["arm"] = ArmRos(studio.ros)
    return made


def prefetch(studio: Studio) -> None:
    """Read and reduce every arm's meshes as soon as the arm is found (a daemon thread): the first
    page then draws at once, even with a 756k-face file."""
    failed: set[str] = set()
    while True:
        time.sleep(0.5)
        ros = _made_arm_ros(studio)
        if ros is None:
            continue
        looks = [s.look for s in ros.arms.values()] + [s.look for s in ros.scenes.values()]
        for drawable in (d for look in looks for d in look):
            if not drawable.mesh_uri or drawable.mesh_uri in failed:
                continue
            path = mesh_path(drawable.mesh_uri)
            try:
                if path is None:
                    raise InputError(drawable.mesh_uri)
                MESHES.prepare(path, DISPLAY_FACES)
            except (InputError, OSError):
                failed.add(drawable.mesh_uri)  # the page says why when it draws it


def register(studio: Studio) -> None:
    app.on_startup(lambda: arm_ros(studio))  # discovery starts before anyone opens the page
    app.on_startup(lambda: threading.Thread(target=prefetch, args=(studio,), name="studio-meshes", daemon=True).start())

    @app.get(MESH_ROUTE + "/{key}.stl")
    def display_mesh(key: str) -> Response:
        mesh = MESHES.get(key)
        if mesh is None:
            raise HTTPException(status_code=404, detail="no such mesh")
        # The key names the file's contents (path, size, time) and the budget: it never changes.
        return Response(mesh.stl, media_type="model/stl", headers={"Cache-Control": "max-age=31536000, immutable"})

    @ui.page("/arm")
    def arm_page(faces: int = DISPLAY_FACES) -> None:
        ArmPage(studio, max(0, int(faces)))


def resolve_config(studio: Studio, name: str, what: str) -> str:
    """A robot config or scene file typed in the page: in the workspace, else a shipped one
    (``arm/irb120.yaml``); never a path outside both."""
    name = name.strip()
    path = studio.workspace.path(name)
    if path.is_file():
        return str(path)
    shipped = config_path(name)
    if ".." not in name.split("/") and shipped.is_file():
        return str(shipped)
    raise InputError(f"{name!r}: no {what} in the workspace {studio.workspace.root} nor among the shipped configs")


def arm_world_ros_args(ns: str, robot_config: str, scene_file: str, owns_clock: bool = False) -> list[str]:
    """``--ros-args`` of an arm world in namespace ``ns`` ('' = root), its clock on :func:`clock_topic`."""
    args = ["--ros-args", "-p", f"robot_config_file:={yaml_string(robot_config)}"]
    args += ["-p", f"scene_file:={yaml_string(scene_file)}"]
    return args + namespace_args(ns, owns_clock)


class ArmPage:
    """One browser tab's arm view and controls."""

    def __init__(self, studio: Studio, faces: int) -> None:
        self.studio = studio
        self.faces = faces
        self.selected: str | None = None
        self.listed: tuple = ()
        self.joint_rows: dict[str, tuple] = {}
        self.built_joints: tuple = ()
        self.syncing = False
        self.last_command = -math.inf
        self.endings_shown: set[Child] = set()
        self.build()

    # ---------------------------------------------------------------- layout
    def build(self) -> None:
        nav("/arm")
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.view = ArmScene(VIEW_SIZE, "studio-arm-view", self.faces)
                with ui.row().classes("items-center gap-3"):
                    ui.label("drag: orbit · right-drag: pan · wheel: zoom").classes("text-sm text-gray-600")
                    ui.button("Reset view", on_click=self.view.reset_view).props("dense flat")
                    ui.checkbox(
                        "End-effector frames", value=True, on_change=lambda e: self.view.set_frames_visible(e.value)
                    )
                    ui.select(
                        DETAIL_OPTIONS,
                        value=self.faces if self.faces in DETAIL_OPTIONS else DISPLAY_FACES,
                        label="mesh detail",
                        on_change=lambda e: ui.navigate.to(f"/arm?faces={e.value}"),
                    ).classes("w-52 studio-arm-detail")
                self.mesh_label = ui.label("").classes("text-sm text-gray-600 studio-arm-meshes")
                ui.label("Elements (show, opacity)").classes("font-bold")
                self.element_list = ui.column().classes("gap-0 studio-arm-elements")
            with ui.column().classes("gap-2 w-[440px]"):
                with ui.row().classes("items-center gap-2 w-full"):
                    self.arm_select = ui.select([], label="Arm (namespace)", on_change=self.on_select).classes(
                        "w-56 studio-arm-select"
                    )
                    self.no_arm = ui.label("no arm found yet").classes("text-orange-700 text-sm")
                self.build_world_panel()
                with ui.card().classes("w-full"):
                    ui.label("Joints (sliders send joint_command)").classes("font-bold")
                    self.joint_panel = ui.column().classes("w-full gap-0 studio-arm-joints")
                with ui.card().classes("w-full"):
                    ui.label("End effector (tool0)").classes("font-bold")
                    self.ee_label = ui.label("–").classes("font-mono text-sm studio-arm-ee")
                with ui.card().classes("w-full"):
                    ui.label("Target pose (IK through target_pose)").classes("font-bold")
                    with ui.row().classes("gap-2 no-wrap"):
                        self.target = [
                            ui.number(label, value=0.0, step=step, format="%.3f").classes(f"w-20 studio-target-{key}")
                            for key, label, step in (("x", "x (m)", 0.01), ("y", "y (m)", 0.01), ("z", "z (m)", 0.01))
                        ]
                    with ui.row().classes("gap-2 no-wrap"):
                        self.target += [
                            ui.number(label, value=0.0, step=1.0, format="%.1f").classes(f"w-20 studio-target-{key}")
                            for key, label in (("roll", "roll (°)"), ("pitch", "pitch (°)"), ("yaw", "yaw (°)"))
                        ]
                    with ui.row().classes("items-center gap-2"):
                        ui.button("Use current", on_click=self.fill_target).props("dense outline").classes(
                            "studio-target-current"
                        )
                        ui.button("Go", on_click=self.go_to_target).props("dense").classes("studio-target-go")
                    self.target_label = ui.label("").classes("text-sm studio-target-status")
                with ui.card().classes("w-full"):
                    ui.label("Stored trajectory").classes("font-bold")
                    ws = self.studio.workspace
                    self.trajectory_file = ui.input(
                        "trajectory file (YAML)", autocomplete=ws.files((".yaml", ".yml"))
                    ).classes("w-full studio-trajectory-file")
                    with ui.row().classes("items-center gap-2"):
                        ui.button("Play", on_click=self.play).props("dense").classes("studio-trajectory-play")
                        ui.button("Stop", on_click=self.stop_motion).props("dense outline").classes(
                            "studio-trajectory-stop"
                        )
                    self.trajectory_label = ui.label("").classes("text-sm break-all studio-trajectory-status")
        ui.timer(FRAME_PERIOD_S, self.tick)
        ui.timer(0.5, self.slow_tick)

    def build_world_panel(self) -> None:
        ws = self.studio.workspace
        with ui.expansion("New arm world", icon="add").classes("w-full border studio-new-arm-world"):
            self.world_config = ui.input(
                "robot config (workspace or shipped)", value="arm/irb120.yaml", autocomplete=ws.files((".yaml",))
            ).classes("w-full studio-arm-config")
            self.world_scene = ui.input("scene file (empty = none; e.g. arm/workcell.yaml)").classes(
                "w-full studio-arm-scene"
            )
            self.world_ns = ui.input("namespace", value=self.studio.free_namespace("arm")).classes("w-40 studio-arm-ns")
            with ui.row().classes("gap-2"):
                ui.button("Start arm world", on_click=self.start_world).props("dense").classes("studio-arm-start")
                ui.button("Stop arm world", on_click=self.stop_world).props("dense outline")
            self.world_label = ui.label("").classes("text-sm text-red-700 break-all studio-arm-world-error")

    # ---------------------------------------------------------------- arms
    def ros(self) -> ArmRos | None:
        return arm_ros(self.studio)

    def arm(self) -> ArmState | None:
        ros = self.ros()
        return None if ros is None or self.selected is None else ros.arms.get(self.selected)

    def commanded(self) -> tuple[ArmRos, str] | None:
        """The client and the arm prefix a command goes to (None: no arm selected)."""
        ros = self.ros()
        if ros is None or self.selected is None or self.selected not in ros.arms:
            return None
        return ros, self.selected

    def on_select(self, e) -> None:
        self.selected = e.value
        self.built_joints = ()

    def slow_tick(self) -> None:
        ros = self.ros()
        if ros is None:
            return
        names = ros.prefixes()
        if names != list(self.arm_select.options):
            value = self.selected if self.selected in names else (names[0] if names else None)
            self.arm_select.set_options({p: p or "/" for p in names}, value=value)
            self.selected = value
        self.no_arm.set_visibility(not names)
        for key, world in list(self.studio.worlds.items()):
            if key.startswith("arm:") and not world.running and world not in self.endings_shown:
                self.endings_shown.add(world)
                self.world_label.set_text(f"{key[4:] or '/'}: {world.error_line()}")
        listed = tuple((k, s.name) for k, s in self.view.shown.items())
        if listed != self.listed:
            self.listed = listed
            self.build_element_list()
        self.mesh_label.set_text(f"{self.view.ready()} of {len(self.view.shown)} elements drawn")

    def build_element_list(self) -> None:
        self.element_list.clear()
        with self.element_list:
            for key, shown in self.view.shown.items():
                owner = shown.owner if shown.owner.startswith("scene:") else (shown.owner or "/")
                with ui.row().classes("items-center gap-2 no-wrap studio-arm-element"):
                    ui.checkbox(
                        f"{owner} {shown.name}",
                        value=key not in self.view.hidden,
                        on_change=lambda e, k=key: self.view.set_visible(k, e.value),
                    ).classes("w-72 text-sm")
                    ui.slider(
                        min=0.0,
                        max=1.0,
                        step=0.05,
                        value=self.view.opacity.get(key, 1.0),
                        on_change=lambda e, k=key: self.view.set_opacity(k, e.value),
                    ).classes("w-40")

    # ---------------------------------------------------------------- drawing
    def tick(self) -> None:
        ros = self.ros()
        if ros is None:
            return
        groups = [Group(prefix, state.look, state.poses, state.seq) for prefix, state in ros.arms.items()]
        groups += [Group(f"scene:{ns}", s.look, s.poses, s.seq) for ns, s in ros.scenes.items()]
        effectors = {
            prefix: (np.array(state.end_effector[:3]), np.array(state.end_effector_quat))
            for prefix, state in ros.arms.items()
            if state.end_effector is not None and state.end_effector_quat is not None
        }
        self.view.draw(groups, effectors)
        self.update_controls()

    # ---------------------------------------------------------------- joints
    def update_controls(self) -> None:
        st = self.arm()
        if st is None:
            if self.built_joints:
                self.joint_panel.clear()
                self.built_joints = ()
            return
        layout = (self.selected, st.joint_names, tuple(sorted(st.limits)))
        if layout != self.built_joints and st.joint_names and st.limits and st.positions is not None:
            self.build_joints(st, st.positions)
            self.built_joints = layout
        if not self.joint_rows or st.positions is None or len(st.positions) != len(st.joint_names):
            return
        still = time.monotonic() - self.last_command > SYNC_AFTER_S and not st.moving()
        for k, name in enumerate(st.joint_names):
            row = self.joint_rows.get(name)
            if row is None:
                continue
            slider, number, readout, prismatic = row
            shown = st.positions[k] if prismatic else math.degrees(st.positions[k])
            unit = "m" if prismatic else "°"
            digits = 3 if prismatic else 1
            readout.set_text(f"{shown if round(shown, digits) else 0.0:8.{digits}f} {unit}")  # no "-0.0"
            if still and abs((slider.value or 0.0) - shown) > (5e-4 if prismatic else 0.05):
                self.syncing = True
                try:
                    slider.set_value(round(shown, 4 if prismatic else 2))
                    number.set_value(round(shown, 4 if prismatic else 2))
                finally:
                    self.syncing = False
        if st.end_effector is not None:
            x, y, z, roll, pitch, yaw = st.end_effector
            self.ee_label.set_text(
                f"x {x:.3f} y {y:.3f} z {z:.3f} m · roll {math.degrees(roll):.1f}° "
                f"pitch {math.degrees(pitch):.1f}° yaw {math.degrees(yaw):.1f}°"
            )

    def build_joints(self, st: ArmState, positions: np.ndarray) -> None:
        self.joint_panel.clear()
        self.joint_rows = {}
        with self.joint_panel:
            for k, name in enumerate(st.joint_names):
                limit = st.limits.get(name)
                if limit is None:
                    continue
                prismatic = limit.prismatic
                lo, hi = (
                    (limit.lower, limit.upper) if prismatic else (math.degrees(limit.lower), math.degrees(limit.upper))
                )
                value = float(positions[k]) if prismatic else math.degrees(positions[k])
                step = 0.001 if prismatic else 0.1
                with ui.row().classes(f"items-center gap-2 no-wrap w-full studio-joint-{k + 1}"):
                    ui.label(name).classes("w-16 text-sm")
                    slider = ui.slider(
                        min=round(lo, 4), max=round(hi, 4), step=step, value=round(value, 2),
                        on_change=lambda e, n=name, p=prismatic: self.on_slider(n, p, e.value),
                    ).classes("w-44 studio-joint-slider")  # fmt: skip
                    number = ui.number(
                        value=round(value, 2), step=step, format="%.3f" if prismatic else "%.1f"
                    ).classes("w-20 studio-joint-number")
                    number.on("keydown.enter", lambda _, n=name, p=prismatic, w=number: self.on_number(n, p, w))
                    number.on("blur", lambda _, n=name, p=prismatic, w=number: self.on_number(n, p, w))
                    readout = ui.label("").classes("font-mono text-sm w-20 studio-joint-readout")
                self.joint_rows[name] = (slider, number, readout, prismatic)

    def on_slider(self, name: str, prismatic: bool, value) -> None:
        if self.syncing or value is None:
            return
        row = self.joint_rows.get(name)
        if row is not None:
            self.syncing = True
            try:
                row[1].set_value(value)
            finally:
                self.syncing = False
        self.send_joint(name, prismatic, float(value))

    def on_number(self, name: str, prismatic: bool, number) -> None:
        if number.value is None:
            return
        slider = self.joint_rows[name][0]
        value = min(max(float(number.value), slider.props["min"]), slider.props["max"])
        self.syncing = True
        try:
            slider.set_value(value)
            number.set_value(value)
        finally:
            self.syncing = False
        self.send_joint(name, prismatic, value)

    def send_joint(self, name: str, prismatic: bool, value: float) -> None:
        to = self.commanded()
        if to is None:
            return
        self.last_command = time.monotonic()
        to[0].joint_command(to[1], [name], [value if prismatic else math.radians(value)])

    # ---------------------------------------------------------------- target pose
    def fill_target(self) -> None:
        st = self.arm()
        if st is None or st.end_effector is None:
            ui.notify("no arm selected", type="warning")
            return
        x, y, z, roll, pitch, yaw = st.end_effector
        for field, value in zip(self.target, (x, y, z, *map(math.degrees, (roll, pitch, yaw))), strict=True):
            field.set_value(round(value, 3 if field in self.target[:3] else 1))

    async def go_to_target(self) -> None:
        """Send the target pose, then say what became of it: reached, or unreachable (the world's
        warning on /rosout, or no motion at all while far from the target)."""
        st, to = self.arm(), self.commanded()
        if st is None or to is None:
            ui.notify("no arm selected", type="warning")
            return
        values = [float(f.value or 0.0) for f in self.target]
        x, y, z, roll, pitch, yaw = values[0], values[1], values[2], *map(math.radians, values[3:6])
        xyz, rpy = (x, y, z), (roll, pitch, yaw)
        sent = time.monotonic()
        self.last_command = sent
        self.target_label.set_text("solving IK…")
        self.target_label.classes(remove="text-red-700 text-green-700")
        to[0].target_pose(to[1], xyz, rpy)
        goal = transform_from_xyz_rpy(np.array(xyz), np.array(rpy))
        asked = "x {:.3f} y {:.3f} z {:.3f} m, roll {:.1f}° pitch {:.1f}° yaw {:.1f}°".format(*values)
        start = None if st.positions is None else st.positions.copy()
        moved = False
        while time.monotonic() - sent < TARGET_TIMEOUT_S:
            await asyncio.sleep(0.05)
            if st.unreachable_at > sent:
                self.target_label.set_text(f"unreachable: {asked} ({st.unreachable_text})")
                self.target_label.classes(add="text-red-700")
                return
            # A short move can start and end between two looks: compare the joints with the start.
            changed = start is not None and st.positions is not None and not np.array_equal(st.positions, start)
            moved = moved or st.moving() or changed
            if st.end_effector is not None and st.end_effector_quat is not None:
                here = rotations(np.array([st.end_effector_quat]))[0]
                position_error = float(np.linalg.norm(np.array(st.end_effector[:3]) - goal[:3, 3]))
                angle_error = math.acos(max(-1.0, min(1.0, (np.trace(here.T @ goal[:3, :3]) - 1) / 2)))
                if position_error < REACHED_M and angle_error < REACHED_RAD and not st.moving():
                    self.target_label.set_text(f"reached {asked} (error {position_error * 1000:.1f} mm)")
                    self.target_label.classes(add="text-green-700")
                    return
                # The world warns at most every 2 s: a second unreachable target soon after shows
                # only as an arm that never starts moving.
                if not moved and time.monotonic() - sent > 1.0:
                    self.target_label.set_text(f"unreachable: {asked} (the arm did not move: no IK solution)")
                    self.target_label.classes(add="text-red-700")
                    return
            self.target_label.set_text("moving…" if moved else "solving IK…")
        self.target_label.set_text(f"not reached in time: {asked}")

    # ---------------------------------------------------------------- trajectories
    def play(self) -> None:
        st, to = self.arm(), self.commanded()
        if st is None or to is None:
            ui.notify("no arm selected", type="warning")
            return
        name = self.trajectory_file.value or ""
        try:
            trajectory = load_trajectory(self.studio.workspace.path(name))
            names = list(trajectory.joint_names or st.joint_names)
            if trajectory.positions.shape[1] != len(names):
                raise InputError(
                    f"{name}: {trajectory.positions.shape[1]} positions per point, the arm has {len(names)} joints"
                )
            unknown = [n for n in names if n not in st.joint_names]
            if unknown:
                raise InputError(f"{name}: joint_names {unknown} are not joints of this arm {list(st.joint_names)}")
        except InputError as err:
            self.trajectory_label.set_text(f"error: {err}")
            return
        self.last_command = time.monotonic() + float(trajectory.times[-1])
        to[0].trajectory(to[1], names, trajectory.times, trajectory.positions, trajectory.velocities)
        self.trajectory_label.set_text(
            f"playing {escape(name)}: {len(trajectory.times)} points, {trajectory.times[-1]:g} s"
        )

    def stop_motion(self) -> None:
        if (to := self.commanded()) is not None:
            to[0].stop(to[1])
            self.trajectory_label.set_text("stopped")

    # ---------------------------------------------------------------- worlds
    async def start_world(self) -> None:
        studio = self.studio
        ns = (self.world_ns.value or "").strip().rstrip("/")
        if ns and not ns.startswith("/"):
            ns = "/" + ns
        self.world_label.set_text("")
        try:
            config = resolve_config(studio, self.world_config.value or "", "robot config")
            scene = (
                resolve_config(studio, self.world_scene.value, "scene file")
                if (self.world_scene.value or "").strip()
                else ""
            )
        except InputError as err:
            self.world_label.set_text(f"error: {err}")
            return
        key = f"arm:{ns}"
        ros = self.ros()
        refusal = studio.namespace_refusal(ns) or (
            f"an arm world already runs in {ns or '/'}: give another namespace"
            if ros is not None and ns in ros.arms
            else None
        )
        if refusal:
            self.world_label.set_text(f"error: {refusal}")
            return
        owns_clock = studio.clock_owner() is None
        child = Child(
            f"arm {ns or '/'}",
            executable_command("arm", arm_world_ros_args(ns, config, scene, owns_clock)),
            cwd=studio.workspace.root,
            clock=clock_topic(ns, owns_clock),
        )
        studio.worlds[key] = child
        self.world_label.set_text(f"starting an arm world in {ns or '/'}…")
        for _ in range(400):
            await asyncio.sleep(0.05)
            if not child.running:
                self.endings_shown.add(child)
                self.world_label.set_text(f"{ns or '/'}: {child.error_line()}")
                return
            ros = self.ros()
            if ros is not None and ns in ros.arms:
                break
        else:
            return
        self.world_label.set_text("")
        self.selected = ns
        self.built_joints = ()
        if ns in self.arm_select.options:
            self.arm_select.set_value(ns)
        self.world_ns.set_value(studio.free_namespace("arm"))
        ui.notify(f"arm world started in {ns or '/'} (its clock: {child.clock})")

    def stop_world(self) -> None:
        ns = self.selected or ""
        ros = self.ros()
        if ros is not None and ns in ros.arms:
            # The world node's namespace: a scene arm (/csa) belongs to the world in /.
            ns = ros.arms[ns].world_ns
        stop_started_world(self.studio.worlds, f"arm:{ns}")
