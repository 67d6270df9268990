"""The Arm page (RoboClass's figure and slider GUI): every arm of the domain in 3D, joint sliders,
target pose, readouts, stored trajectories.

What is drawn comes from each arm's ``robot_markers`` (mesh, colour, scale, pose per element) and
its world's ``scene_markers``, so any arm world works, started here or elsewhere. Meshes go to the
browser once, reduced for display (:mod:`studio.arm.meshes`), from the route ``/studio/mesh/<key>.stl``
that serves only meshes an arm named. Angles are shown in degrees; everything sent is in radians.
The page is made of its joints, motion and worlds parts (:mod:`studio.arm.page_base`).
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np
from fastapi import HTTPException, Response
from nicegui import app, ui

from sim_runtime.errors import InputError
from sim_runtime.paths import mesh_path
from studio.arm.joints import ArmJoints
from studio.arm.meshes import DISPLAY_FACES
from studio.arm.motion import ArmMotion
from studio.arm.page_base import arm_ros, arm_worlds
from studio.arm.ros_client import Group
from studio.arm.scene import MESH_ROUTE, MESHES, ArmScene
from studio.arm.worlds import ArmWorlds
from studio.shell.app import Studio
from studio.shell.kit import nav
from studio.shell.processes import Child

FRAME_PERIOD_S = 0.05
VIEW_SIZE = (820, 620)
DETAIL_OPTIONS = {
    DISPLAY_FACES: f"{DISPLAY_FACES // 1000}k faces per mesh",
    200_000: "200k faces per mesh",
    0: "every face",
}


def prefetch(studio: Studio) -> None:
    """Read and reduce every arm's meshes as soon as the arm is found (a daemon thread): the first
    page then draws at once, even with a 756k-face file."""
    failed: set[str] = set()
    while True:
        time.sleep(0.5)
        ros = arm_ros(studio)
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


class ArmPage(ArmJoints, ArmMotion, ArmWorlds):
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
                self.build_joint_cards()
                self.build_target_card()
                self.build_trajectory_card()
        ui.timer(FRAME_PERIOD_S, self.tick)
        ui.timer(0.5, self.slow_tick)

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
        for ns, world in list(arm_worlds(self.studio).items()):
            if not world.running and world not in self.endings_shown:
                self.endings_shown.add(world)
                self.world_label.set_text(f"{ns or '/'}: {world.error_line()}")
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
