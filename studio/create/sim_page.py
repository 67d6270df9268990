"""The Simulator page (the original's SimulatorGUI): live view, status, driving, worlds, controllers, recording.

The page lays out its parts, each in a module of its own: the view (:mod:`studio.create.sim_view`),
Manual control (:mod:`studio.create.sim_drive`), New world, Autonomous and Save Data
(:mod:`studio.create.sim_runs`); they share the tab's choice of robot (:class:`SimTab`).
"""

from __future__ import annotations

import json
import math
from html import escape

import numpy as np
from nicegui import events, ui

from create_sim.spec import CLIFF_NAMES, SONAR_NAMES
from studio.create.family import create_family, create_ros
from studio.create.lidar_plot import lidar_plot_svg
from studio.create.ros_client import RobotState
from studio.create.sim_drive import DrivePanel
from studio.create.sim_files import WorldFilesPanel
from studio.create.sim_runs import ControllerPanel, RecordPanel, WorldPanel
from studio.create.sim_tab import SimTab
from studio.create.sim_view import FRAME_PERIOD_S, SimView
from studio.shell.app import Studio
from studio.shell.kit import nav


def _fmt(value: float | None, digits: int = 3) -> str:
    if value is None:
        return "–"
    return f"{value:.{digits}f}" if math.isfinite(value) else ("+inf" if value > 0 else "-inf" if value < 0 else "nan")


def status_html(ns: str, st: RobotState) -> str:
    """The live Read Sensors table of one robot."""
    rows = [
        ("namespace", escape(ns or "/")),
        ("sim time (s)", _fmt(st.sim_time, 2)),
        ("real-time factor", _fmt(st.rtf, 2)),
    ]
    pose = st.pose or (None, None, None)
    odom = st.odom or (None, None, None)
    rows += [
        ("x (m) truth / odometry", f"{_fmt(pose[0])} / {_fmt(odom[0])}"),
        ("y (m) truth / odometry", f"{_fmt(pose[1])} / {_fmt(odom[1])}"),
        ("θ (rad) truth / odometry", f"{_fmt(pose[2])} / {_fmt(odom[2])}"),
        ("v (m/s), ω (rad/s)", f"{_fmt(st.velocity[0], 2)}, {_fmt(st.velocity[1], 2)}"),
        ("bump left / right", f"{int(st.bumps[0])} / {int(st.bumps[1])}"),
        ("wall / virtual wall", f"{int(st.wall)} / {int(st.virtual_wall)}"),
        (
            "cliff (%) " + " ".join(n.replace("_", "-") for n in CLIFF_NAMES),
            " ".join(_fmt(st.cliffs.get(n), 1) for n in CLIFF_NAMES),
        ),
        ("sonar (m) " + " ".join(SONAR_NAMES), " ".join(_fmt(st.sonar.get(n), 2) for n in SONAR_NAMES)),
    ]
    if st.scan is not None:
        ranges = st.scan[2]
        finite = ranges[np.isfinite(ranges)]
        nearest = _fmt(float(finite.min()), 2) if len(finite) else "none"
        rows.append(("LIDAR beams, nearest (m)", f"{len(ranges)}, {nearest}"))
    sightings = ", ".join(
        f"{escape(i)} at {math.hypot(x, y):.2f} m {math.degrees(math.atan2(y, x)):.0f}°" for x, y, i in st.sightings
    )
    rows.append(("camera beacons", sightings or "none"))
    body = "".join(f"<tr><td class='pr-3 text-gray-600'>{k}</td><td class='font-mono'>{v}</td></tr>" for k, v in rows)
    return f"<table class='studio-status text-sm'>{body}</table>"


TAB_ROBOT_KEY = "robot_sims.studio.robot"
"""Where a tab keeps its choice of robot: the browser's sessionStorage, one per tab, kept over a
reload (the studio's own "last picked" is every tab's, so a reloaded tab took another tab's robot)."""


def register(studio: Studio) -> None:
    @ui.page("/")
    def simulator_page() -> None:
        SimulatorPage(studio)


class SimulatorPage:
    """One browser tab's simulator: its own view, selected robot and panels."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.tab = SimTab(studio)
        self.view = SimView(self.tab)
        self.drive = DrivePanel(self.tab)
        self.world = WorldPanel(self.tab, started=self.follow)
        self.files = WorldFilesPanel(self.tab)
        self.controller = ControllerPanel(self.tab, stop_robot=self.drive.stop)
        self.record = RecordPanel(self.tab)
        self.restored = False  # the tab's own choice is read back from the browser (until then: none)
        self.plotted_scan = -1  # the scan count the LIDAR plot shows
        self.build()

    def build(self) -> None:
        nav("/")
        self.drive.listen_to_keys()
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.view.build()
                with ui.card().classes("w-[800px] studio-read-sensors"):  # the original's Read Sensors
                    ui.label("Read Sensors").classes("font-bold")
                    with ui.row().classes("no-wrap items-start gap-4"):
                        self.status = ui.html("", sanitize=False).classes("w-[330px]")
                        with ui.column().classes("gap-0"):
                            ui.label("LIDAR: range by beam angle (0° ahead, left +)").classes("text-sm")
                            self.lidar_plot = ui.html(lidar_plot_svg(None), sanitize=False)
            with ui.column().classes("gap-2 w-[430px]"):
                with ui.row().classes("items-center gap-2 w-full"):
                    self.robot_select = ui.select([], label="Robot (namespace)", on_change=self.on_select).classes(
                        "w-56 studio-robot"
                    )
                    self.no_world = ui.label("no Create world found yet").classes("text-orange-700 text-sm")
                self.world.build()
                self.files.build()
                self.drive.build()
                self.controller.build()
                self.record.build()

        ui.timer(FRAME_PERIOD_S, self.view.tick)
        ui.timer(0.5, self.slow_tick)
        ui.timer(0.0, self.restore_choice, once=True)

    async def restore_choice(self) -> None:
        """The robot this tab picked before a reload (a new tab: the studio's last picked): until
        it is known the tab lists no robot, so no key press reaches another tab's robot."""
        try:  # run by a timer once the tab has connected
            stored = await ui.run_javascript(f"return sessionStorage.getItem({json.dumps(TAB_ROBOT_KEY)})")
        except TimeoutError:
            stored = None
        if isinstance(stored, str) and self.tab.selected is None:
            self.tab.selected = json.loads(stored)
        self.restored = True

    def remember(self, ns: str | None) -> None:
        """Make ``ns`` this tab's robot (and the studio's last picked, a new tab's default)."""
        self.tab.selected = ns
        if ns is not None:
            create_family(self.studio).selected = ns
            ui.run_javascript(f"sessionStorage.setItem({json.dumps(TAB_ROBOT_KEY)}, {json.dumps(json.dumps(ns))})")

    async def on_select(self, e: events.ValueChangeEventArguments) -> None:
        self.remember(e.value)
        self.view.view_dirty = True
        await self.drive.show_speed()

    def follow(self, ns: str) -> None:
        """Select the world this tab started in ``ns``, and fit the view to it."""
        self.remember(ns)
        if ns in self.robot_select.options:
            self.robot_select.set_value(ns)
        self.view.refit(ns)

    def slow_tick(self) -> None:
        ros = create_ros(self.studio)
        if ros is None:
            return
        names = ros.namespaces() if self.restored else []
        if names != list(self.robot_select.options):
            value = create_family(self.studio).default_robot(names, self.tab.selected)
            self.robot_select.set_options({ns: ns or "/" for ns in names}, value=value)
        self.no_world.set_visibility(not names)
        st = self.tab.robot()
        if st is not None and self.tab.selected is not None:
            self.status.set_content(status_html(self.tab.selected, st))
            self.drive.show_command(st.command)
            if st.scan_count != self.plotted_scan:
                self.plotted_scan = st.scan_count
                self.lidar_plot.set_content(lidar_plot_svg(st.scan, st.scan_stamp))
        self.drive.show_driving()
        self.world.show_endings()
        self.controller.show_state()
        if self.studio.recorder is not None:
            self.record.show_recording()
