"""The Simulator page's drawing area: the map, every robot and the selected one's sensors, with
pan, zoom, layers, robot-centred view and "Set position" by drag."""

from __future__ import annotations

import json
import math
from collections import deque
from pathlib import Path

import numpy as np
from nicegui import events, ui

from studio.create import draw
from studio.create.ros_client import TRACK_POINTS, RobotState
from studio.create.sim_tab import SimTab
from studio.shell import svg
from studio.shell.kit import VIEW_SIZE, ZoomableView, view_image

FRAME_PERIOD_S = 0.05
"""The view is redrawn at most this often (20 frames/s, as the SIMROBOT and arm pages), and only
when a new reading came in. Each update costs the studio ~1.5 ms of CPU (mostly NiceGUI's message
to the page): at 25 frames/s an open page took 3.7 % of a core on an idle machine."""
LAYERS = {
    "lidar": "LIDAR",
    "sonar": "Sonar",
    "wall": "IR wall",
    "bump": "Bump",
    "cliff": "Cliff",
    "camera": "Camera",
    "track": "Track",
    "fields": "Virtual-wall fields",
    "grid": "Grid",
}
SET_POSE_MIN_DRAG_PX = 5.0
LIVE_JS = Path(__file__).with_name("static") / "sim_view.js"
"""Draws the robots and sensor layers in the browser from the state :meth:`SimView.tick` sends: the
studio sends a few numbers per update instead of the layer's SVG (a page cost 12.9 % of a core)."""


def fit_due(fitted_map_seq: int | None, map_seq: int) -> bool:
    """Whether the view fits (again): the robot is shown for the first time (``fitted_map_seq``
    None), or it was fitted before its map arrived (a fit to the robot alone is ±1 m around it)."""
    return fitted_map_seq is None or (fitted_map_seq == 0 and map_seq > 0)


class SimView(ZoomableView):
    """One tab's view: its own zoom, layers and centring, redrawn by :meth:`tick` (the page's timer,
    every FRAME_PERIOD_S)."""

    def __init__(self, tab: SimTab) -> None:
        self.tab = tab
        self.view = svg.View(*VIEW_SIZE, scale=60.0)
        self.layers = set(LAYERS)
        self.centred = False
        self.mouse_mode = "pan"
        self.drawn_seq = -1
        self.drawn_map: tuple[str | None, int] = (None, -1)
        self.view_dirty = True
        self.mouse_down: tuple[float, float] | None = None  # pixel of the mouse press
        self.view_at_press = (0.0, 0.0)
        self.fitted: dict[str, int] = {}  # namespace → its map_seq when the view was fitted to it
        self.frames = 0
        self.live_ready = False  # the page has the live layer's style
        self.sent_ns: str | None = None  # the robot the page draws
        self.sent: dict = {}  # what the page last got of it, by message key
        self.track_last: tuple[float, float] | None = None  # the last track point it got

    def build(self) -> None:
        """The drawing area, its toolbar and the layer checkboxes (inside the page's layout)."""
        self.image = view_image(self.on_mouse, self.on_wheel, "studio-view", "#fafafa")
        self.dynamic = self.image.add_layer()  # drawn by the browser (LIVE_JS)
        ui.add_body_html(f"<script>{LIVE_JS.read_text()}</script>")
        self.overlay = self.image.add_layer()
        with ui.row().classes("items-center gap-2"):
            ui.toggle({"pan": "Pan", "pose": "Set position"}, value="pan", on_change=self.on_mouse_mode).classes(
                "studio-mouse-mode"
            )
            ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
            ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
            ui.button("Fit map", on_click=self.fit).props("dense flat")
            ui.checkbox("Robot-centred", on_change=self.on_centred)
        with ui.row().classes("gap-3"):
            for key, text in LAYERS.items():
                ui.checkbox(text, value=key in self.layers, on_change=lambda e, k=key: self.toggle_layer(k, e.value))

    def refit(self, ns: str) -> None:
        """Fit the view to the world in ``ns`` again when it is next drawn (a world just started)."""
        self.fitted.pop(ns, None)
        self.view_dirty = True

    # ---------------------------------------------------------------- drawing
    def tick(self) -> None:
        st, ns = self.tab.robot(), self.tab.selected
        if st is None or st.pose is None or ns is None:
            if self.sent_ns is not None:  # the robot went: nothing of it stays drawn
                self.sent_ns = None
                self.dynamic.client.run_javascript(f"studioSimView.clear({self.dynamic.id})")
            return
        if fit_due(self.fitted.get(ns), st.map_seq):
            self.fitted[ns] = st.map_seq
            self.fit()
        if self.centred:
            self.view.centre_x, self.view.centre_y = st.pose[0], st.pose[1]
            self.view_dirty = True
        if self.view_dirty or self.drawn_map != (ns, st.map_seq):
            self.drawn_map = (ns, st.map_seq)
            base = svg.grid_svg(self.view, 0.5) if "grid" in self.layers else ""
            self.image.set_content(base + draw.map_svg(self.view, st.map, fields="fields" in self.layers))
        if self.view_dirty or st.seq != self.drawn_seq:
            self.drawn_seq = st.seq
            self.view_dirty = False
            message = self.live_message(st, ns)
            if message:
                code = f"studioSimView.update({self.dynamic.id},{json.dumps(message, separators=(',', ':'))})"
                if not self.live_ready:  # the first message: the drawing's style with it
                    style = json.dumps(draw.live_style(VIEW_SIZE, TRACK_POINTS), separators=(",", ":"))
                    code = f"studioSimView.init({self.dynamic.id},{style});{code}"
                    self.live_ready = True
                self.dynamic.client.run_javascript(code)
                self.frames += 1

    def live_message(self, st: RobotState, ns: str) -> dict:
        """What changed since the page's last update (the page keeps the rest): the view's
        transform, the layers, the robots' poses, the selected one's readings, a new scan and the
        track's new points. The page draws it (``static/sim_view.js``)."""
        message: dict = {}
        if ns != self.sent_ns:  # another robot: everything anew
            self.sent_ns, self.sent, self.track_last = ns, {}, None
            message["track_reset"] = True
        v = self.view
        state = {
            "view": [float(v.centre_x), float(v.centre_y), float(v.scale)],
            "layers": sorted(self.layers),
            "label": ns,
            "others": [
                [other_ns, *map(float, other.pose)]
                for other_ns, other in self.tab.ros.robots.items()
                if other_ns != ns and other.pose is not None
            ],
            **draw.live_readings(draw.readings_of(st, None)),
        }
        if st.scan is not None:
            state["scan_stamp"] = st.scan_stamp
        for key, value in state.items():
            if self.sent.get(key) != value:
                self.sent[key] = value
                message[key] = value
        if "scan_stamp" in message and st.scan is not None:
            message["scan"] = draw.live_scan(st.scan, message.pop("scan_stamp"))
        message.pop("scan_stamp", None)
        reset, points = self.new_track_points(st.track)
        if reset:
            message["track_reset"] = True
        if points:
            message["track"] = [[float(x), float(y)] for x, y in points]
        return message

    def new_track_points(self, track: deque) -> tuple[bool, list]:
        """The track's points the page has not got (and whether it starts again: the track was
        cleared or has moved past the last point sent). Points are told apart by identity: the
        client appends a new tuple for each."""
        points = list(track)  # one atomic copy
        last, self.track_last = self.track_last, (points[-1] if points else None)
        if last is None:
            return False, points
        for i in range(len(points) - 1, -1, -1):
            if points[i] is last:
                return False, points[i + 1 :]
        return True, points

    def view_changed(self) -> None:
        self.view_dirty = True

    def fit(self) -> None:
        st = self.tab.robot()
        if st is None:
            return
        w = st.map
        xs = np.concatenate(
            [w.walls[:, 0], w.walls[:, 2], w.lines[:, 0], w.lines[:, 2], w.beacon_xy[:, 0], w.virtwalls[:, 0]]
        )
        ys = np.concatenate(
            [w.walls[:, 1], w.walls[:, 3], w.lines[:, 1], w.lines[:, 3], w.beacon_xy[:, 1], w.virtwalls[:, 1]]
        )
        if st.pose is not None:
            xs, ys = np.append(xs, st.pose[0]), np.append(ys, st.pose[1])
        self.view.fit(xs, ys, margin_m=1.0)
        self.view_dirty = True

    def on_centred(self, e: events.ValueChangeEventArguments) -> None:
        self.centred = e.value
        self.view_dirty = True

    # ---------------------------------------------------------------- mouse: pan or set position
    def on_mouse_mode(self, e: events.ValueChangeEventArguments) -> None:
        self.mouse_mode = e.value
        self.overlay.set_content("")

    async def on_mouse(self, e: events.MouseEventArguments) -> None:
        if e.type == "mousedown":
            self.mouse_down = (e.image_x, e.image_y)
            self.view_at_press = (self.view.centre_x, self.view.centre_y)
            return
        if self.mouse_down is None:
            return
        px, py = self.mouse_down
        if self.mouse_mode == "pan":
            self.view.pan(self.view_at_press, e.image_x - px, e.image_y - py)
            self.view_dirty = True
            if e.type == "mouseup":
                self.mouse_down = None
            return
        if e.type == "mousemove":
            self.overlay.set_content(
                f'<circle cx="{px:.1f}" cy="{py:.1f}" r="6" fill="#1565c0"/>'
                f'<line x1="{px:.1f}" y1="{py:.1f}" x2="{e.image_x:.1f}" y2="{e.image_y:.1f}" '
                'stroke="#1565c0" stroke-width="3"/>'
            )
        elif e.type == "mouseup":
            self.mouse_down = None
            self.overlay.set_content("")
            await self.set_pose(px, py, e.image_x, e.image_y)

    async def set_pose(self, px: float, py: float, to_px: float, to_py: float) -> None:
        """Put the selected robot at pixel (px, py), heading towards (to_px, to_py) when the drag
        was long enough (else keeping its heading)."""
        st, ns = self.tab.robot(), self.tab.selected
        if st is None or ns is None:
            return
        x, y = self.view.to_world(px, py)
        if math.hypot(to_px - px, to_py - py) >= SET_POSE_MIN_DRAG_PX:
            theta = math.atan2(-(to_py - py), to_px - px)
        else:
            theta = st.pose[2] if st.pose else 0.0
        try:
            accepted, message = await self.tab.ros.set_pose(ns, x, y, theta)
        except TimeoutError as error:
            ui.notify(str(error), type="warning")
            return
        if accepted:
            st.track.clear()  # no line across the jump
        ui.notify(message, type=None if accepted else "warning")
