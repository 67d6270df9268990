"""The Replay page's plan view: a frame drawn as the simulator pages draw it (the map or
occupancy grid, robots, sensors, tracks), panned, zoomed and fitted to the whole run."""

from __future__ import annotations

import numpy as np
from nicegui import ui
from nicegui.elements.interactive_image import InteractiveImageLayer

from studio.arm.scene import ArmScene
from studio.create import draw
from studio.replay.draw import drawn_track, grid_image_svg, joints_svg, markers_svg, panel_html, small_robot_svg
from studio.replay.frames import Frame, Replay
from studio.shell import svg
from studio.shell.kit import ZoomableView


class ReplayView(ZoomableView):
    """Drawing the frame at ``t_ns`` on the plan view (and the arm view), with the time, panel and
    timeline that go with it."""

    view: svg.View
    layers: set[str]
    replay: Replay | None
    world: str | None  # the world shown (None: the bag's only one)
    t_ns: int
    shown_t: int | None
    base_dirty: bool
    mouse_down: tuple[float, float] | None
    view_at_press: tuple[float, float]
    moving_slider: bool
    grid_cache: tuple[tuple, str] | None
    image: ui.interactive_image
    dynamic: InteractiveImageLayer
    arm_view: ArmScene
    time_label: ui.label
    panel: ui.html
    slider: ui.slider

    def show(self) -> None:
        replay = self.replay
        if replay is None:
            return
        frame = replay.frame(self.t_ns, self.world)
        if self.base_dirty:
            self.base_dirty = False
            base = svg.grid_svg(self.view, 0.5) if "grid" in self.layers else ""
            if frame.map is not None:
                base += draw.map_svg(self.view, frame.map, fields="fields" in self.layers)
            if frame.grid is not None:
                base = self.grid_svg(frame.grid) + base
            self.image.set_content(base)
        self.dynamic.set_content(self.dynamic_svg(frame))
        if replay.arm_marker_topics:
            effectors = {arm: (np.array(e[:3]), np.array(e[3:])) for arm, e in frame.end_effectors.items()}
            self.arm_view.draw(frame.arm_groups, effectors)
        self.shown_t = self.t_ns
        self.time_label.set_text(f"t = {frame.elapsed_s:.3f} s / {replay.duration_s:.3f} s")
        self.panel.set_content(panel_html(frame))
        self.moving_slider = True
        try:
            self.slider.set_value(round(frame.elapsed_s, 3))
        finally:
            self.moving_slider = False

    def grid_svg(self, grid) -> str:
        key = (id(grid), self.view.centre_x, self.view.centre_y, self.view.scale)
        if self.grid_cache is None or self.grid_cache[0] != key:
            self.grid_cache = (key, grid_image_svg(self.view, grid))
        return self.grid_cache[1]

    def dynamic_svg(self, frame: Frame) -> str:
        v = self.view
        parts = [
            f'<g class="view" data-centre-x="{float(v.centre_x)!r}" data-centre-y="{float(v.centre_y)!r}" '
            f'data-scale="{float(v.scale)!r}" data-t="{frame.t_ns}"/>'
        ]
        for markers in (frame.outlines, frame.map_extras):
            if markers is not None:
                parts.append(markers_svg(v, markers))
        for i, rf in enumerate(frame.robots):
            if rf.robot.kind != "create":
                parts.append(small_robot_svg(v, rf))
                continue
            if rf.pose is None:
                continue
            readings = draw.readings_of(rf, drawn_track(rf.track) if "track" in self.layers else None)
            parts.append(draw.sensors_svg(v, readings, self.layers))
            parts.append(draw.robot_svg(v, rf.pose, selected=i == 0, label=rf.robot.ns))
        if frame.joints and not frame.arm_groups:  # no meshes recorded: the joints as gauges
            parts.append(joints_svg(frame))
        return "".join(parts)

    def view_changed(self) -> None:
        self.base_dirty = True

    def on_mouse(self, e) -> None:
        """Drag pans the view."""
        if e.type == "mousedown":
            self.mouse_down = (e.image_x, e.image_y)
            self.view_at_press = (self.view.centre_x, self.view.centre_y)
            return
        if self.mouse_down is None:
            return
        px, py = self.mouse_down
        self.view.pan(self.view_at_press, e.image_x - px, e.image_y - py)
        self.base_dirty = True
        if e.type == "mouseup":
            self.mouse_down = None

    def fit(self) -> None:
        """Fit the map (walls, occupancy grid) and every robot's whole track."""
        replay = self.replay
        if replay is None:
            return
        frame = replay.frame(replay.end_ns, self.world)
        xs, ys = [], []
        if frame.map is not None:
            w = frame.map
            xs += [w.walls[:, 0], w.walls[:, 2], w.lines[:, 0], w.lines[:, 2], w.beacon_xy[:, 0]]
            ys += [w.walls[:, 1], w.walls[:, 3], w.lines[:, 1], w.lines[:, 3], w.beacon_xy[:, 1]]
        if frame.grid is not None:
            info = frame.grid.info
            x0, y0 = info.origin.position.x, info.origin.position.y
            xs.append(np.array([x0, x0 + info.width * info.resolution]))
            ys.append(np.array([y0, y0 + info.height * info.resolution]))
        for robot in replay.robots_of(self.world):
            finite = robot.track[np.isfinite(robot.track).all(axis=1)]
            xs.append(finite[:, 0])
            ys.append(finite[:, 1])
        if xs:
            self.view.fit(np.concatenate(xs), np.concatenate(ys), margin_m=0.5)
        self.base_dirty = True
