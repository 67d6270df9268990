"""The Arm page's Target pose (IK through ``target_pose``) and Stored trajectory cards."""

from __future__ import annotations

import asyncio
import math
import time
from html import escape

import numpy as np
from nicegui import ui

from arm_sim.robot_config import transform_from_xyz_rpy
from arm_sim.trajectory_file import load_trajectory
from sim_runtime.errors import InputError
from studio.arm.page_base import ArmPageBase
from studio.arm.scene import rotations

REACHED_M, REACHED_RAD = 2e-3, 2e-2
TARGET_TIMEOUT_S = 30.0


class ArmMotion(ArmPageBase):
    """A target pose sent and followed to reached or unreachable; a trajectory file played."""

    def build_target_card(self) -> None:
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

    def build_trajectory_card(self) -> None:
        with ui.card().classes("w-full"):
            ui.label("Stored trajectory").classes("font-bold")
            ws = self.studio.workspace
            self.trajectory_file = ui.input("trajectory file (YAML)", autocomplete=ws.files((".yaml", ".yml"))).classes(
                "w-full studio-trajectory-file"
            )
            with ui.row().classes("items-center gap-2"):
                ui.button("Play", on_click=self.play).props("dense").classes("studio-trajectory-play")
                ui.button("Stop", on_click=self.stop_motion).props("dense outline").classes("studio-trajectory-stop")
            self.trajectory_label = ui.label("").classes("text-sm break-all studio-trajectory-status")

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
            # a file may name a scene arm's joints as its config does (joint_1 for csa/joint_1)
            names = [_arm_joint(n, st.joint_names) for n in trajectory.joint_names or st.joint_names]
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


def _arm_joint(name: str, joint_names: tuple[str, ...]) -> str:
    """``name`` as the arm's ``joint_states`` names it: itself, or the one prefixed joint ending in
    ``/name`` (a scene arm's ``csa/joint_1`` for ``joint_1``)."""
    if name in joint_names:
        return name
    prefixed = [n for n in joint_names if n.endswith("/" + name)]
    return prefixed[0] if len(prefixed) == 1 else name
