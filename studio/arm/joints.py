"""The Arm page's Joints and End effector cards: a slider and a number per joint (sending
``joint_command``), following the arm once it is still; the end effector's pose."""

from __future__ import annotations

import math
import time

import numpy as np
from nicegui import ui

from studio.arm.page_base import ArmPageBase
from studio.arm.ros_client import ArmState

SYNC_AFTER_S = 1.0
"""Sliders follow the arm once it is still and nobody has moved a slider for this long."""


class ArmJoints(ArmPageBase):
    """The joint rows, built for the selected arm's joints and limits."""

    syncing = False  # while a slider or number is set from the arm (not a user's move)
    joint_rows: dict[str, tuple]

    def build_joint_cards(self) -> None:
        with ui.card().classes("w-full"):
            ui.label("Joints (sliders send joint_command)").classes("font-bold")
            self.joint_panel = ui.column().classes("w-full gap-0 studio-arm-joints")
        with ui.card().classes("w-full"):
            ui.label("End effector (tool0)").classes("font-bold")
            self.ee_label = ui.label("–").classes("font-mono text-sm studio-arm-ee")

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
