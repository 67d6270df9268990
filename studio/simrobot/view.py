"""The SIMROBOT page's view: the selected world's map, robots, beams and tracks; click a robot
to see its info, drag to pan."""

from __future__ import annotations

import math
import time
from html import escape

import numpy as np
from nicegui import ui
from nicegui.elements.interactive_image import InteractiveImageLayer

from simrobot_sim.world_file import WorldSpec
from studio.shell import svg
from studio.shell.kit import ZoomableView
from studio.simrobot.draw import beams_svg, hit_radius_m, map_data_url, map_svg, robot_svg, track_svg
from studio.simrobot.family import SimrobotFamily
from studio.simrobot.ros_client import SimrobotRos, WorldState

TRACKS_PERIOD_S = 1.0


def steps_text(st: WorldState, spec: WorldSpec) -> str:
    """The original's step counter and the sim time: ``step 37 of 300 · sim time 3.70 s``."""
    step = round(st.sim_time / spec.dt)
    limit = f" of {spec.steps_limit:.0f}" if math.isfinite(spec.steps_limit) else ""
    done = " (steps limit reached: the world stopped)" if step >= spec.steps_limit else ""
    return f"step {step}{limit} · sim time {st.sim_time:.2f} s{done}"


def info_html(st: WorldState, i: int) -> str:
    """The clicked robot's info: pose, power, crashed, every sensor's reading."""
    x, y, h = st.poses[i] if i < len(st.poses) else (math.nan,) * 3
    rows = [
        ("robot", escape(st.names[i])),
        ("x, y (m)", f"{x:.3f}, {y:.3f}"),
        ("heading (°)", f"{math.degrees(h):.1f}"),
        ("power", "on" if st.power[i] else "off"),
        ("crashed", "yes" if st.crashed[i] else "no"),
    ]
    for k, (robot, sensor) in enumerate(st.sensors):
        if robot == i:
            d = st.nearest[k]
            rows.append(
                (f"{escape(sensor.name)} ({sensor.kind}) nearest", f"{d:.3f} m" if math.isfinite(d) else "none")
            )
    body = "".join(f"<tr><td class='pr-3 text-gray-600'>{k}</td><td class='font-mono'>{v}</td></tr>" for k, v in rows)
    return f"<table class='simrobot-info text-sm'>{body}</table>"


class SimrobotView(ZoomableView):
    """The selected world (``ns``) drawn, redrawn by :meth:`tick` when a new step came in."""

    side: SimrobotFamily
    view: svg.View
    ns: str | None  # the selected world's namespace
    layers: set[str]
    robot: int | None  # the clicked robot's index
    drawn_seq: int
    drawn_map: WorldSpec | None  # the spec whose map is drawn
    view_dirty: bool
    frames: int
    map_url: str
    mouse_down: tuple[float, float, float, float] | None  # pixel, view centre at the press
    tracks_drawn: float
    image: ui.interactive_image
    track_layer: InteractiveImageLayer
    dynamic: InteractiveImageLayer
    info: ui.html
    steps_label: ui.label
    replaying: list[tuple[float, np.ndarray]] | None = None  # the steps being replayed (a snapshot)
    replay_k = 0  # the next of them to show
    replay_next = 0.0  # when (monotonic s) to show it: the world's replay_step_time after the last

    def world(self) -> WorldState | None:
        """The selected world once its file is read (:meth:`loaded`)."""
        loaded = self.loaded()
        return loaded[0] if loaded is not None else None

    def loaded(self) -> tuple[WorldState, WorldSpec] | None:
        """The selected world and its spec, once its file is read (before, nothing is drawn)."""
        ros = self.side.client
        if ros is None or self.ns is None:
            return None
        st = ros.worlds.get(self.ns)
        return (st, st.spec) if st is not None and st.spec is not None else None

    def commanded(self) -> tuple[SimrobotRos, str] | None:
        """The client and the namespace a command goes to (None: no world selected)."""
        ros = self.side.client
        return (ros, self.ns) if ros is not None and self.ns is not None and self.world() is not None else None

    # ---------------------------------------------------------------- drawing
    def tick(self) -> None:
        loaded = self.loaded()
        if loaded is None or len(loaded[0].poses) != len(loaded[0].names):
            return
        st, spec = loaded
        if self.replaying is not None:
            if self.drawn_map is spec:
                self.replay_tick(spec)
                return
            self.replaying = None  # another world (or the same restarted): its replay is gone
        if self.drawn_map is not spec:
            self.map_url = map_data_url(spec.walls)
            self.drawn_map = spec
            self.fit()
        if self.view_dirty or time.monotonic() - self.tracks_drawn >= TRACKS_PERIOD_S:
            self.tracks_drawn = time.monotonic()
            self.track_layer.set_content(self.tracks_svg(st, spec) if "tracks" in self.layers else "")
        if self.view_dirty or st.seq != self.drawn_seq:
            self.drawn_seq = st.seq
            self.view_dirty = False
            self.frames += 1
            self.dynamic.set_content(self.dynamic_svg(st, spec))
            self.steps_label.set_text(steps_text(st, spec))

    # ---------------------------------------------------------------- the original's Run replay
    def start_replay(self) -> str | None:
        """Replay the steps seen so far, one at least every ``replay_step_time``; why not, if not."""
        st = self.world()
        if st is None or not st.history:
            return "nothing to replay yet: run the world first (the replay shows the steps this page saw)"
        self.replaying = list(st.history)
        self.replay_k, self.replay_next = 0, 0.0
        return None

    def stop_replay(self) -> None:
        self.replaying = None
        self.view_dirty = True  # the live world again

    def replay_tick(self, spec: WorldSpec) -> None:
        frames, now = self.replaying, time.monotonic()
        if frames is None or self.replay_k >= len(frames) or now < self.replay_next:
            return
        t, poses = frames[self.replay_k]
        self.replay_next = now + spec.replay_step_time
        self.replay_k += 1
        self.frames += 1
        self.dynamic.set_content(self.replay_svg(spec, poses, t))
        done = " (done: Stop replay to watch the world live)" if self.replay_k == len(frames) else ""
        self.steps_label.set_text(
            f"replay: step {round(t / spec.dt)} ({self.replay_k} of {len(frames)} seen) · sim time {t:.2f} s{done}"
        )

    def replay_svg(self, spec: WorldSpec, poses: np.ndarray, t: float) -> str:
        """A replayed step: the robots where they were (the readings are not kept)."""
        v = self.view
        parts = [
            f'<g class="frame replay" data-n="{self.frames}" data-replay-k="{self.replay_k}" data-sim-time="{t!r}" '
            f'data-centre-x="{v.centre_x!r}" data-centre-y="{v.centre_y!r}" data-scale="{v.scale!r}"/>'
        ]
        names = "names" in self.layers
        for i, robot in enumerate(spec.robots):
            label = robot.name if names else ""
            parts.append(robot_svg(v, robot, poses[i], selected=i == self.robot, label=label))
        return "".join(parts)

    def draw_map(self) -> None:
        loaded = self.loaded()
        if loaded is not None and self.map_url:
            spec = loaded[1]
            self.image.set_content(map_svg(self.view, self.map_url, spec.walls.shape, spec.resolution, spec.origin))

    def dynamic_svg(self, st: WorldState, spec: WorldSpec) -> str:
        v = self.view
        parts = [
            f'<g class="frame" data-n="{self.frames}" data-sim-time="{st.sim_time!r}" data-centre-x="{v.centre_x!r}" '
            f'data-centre-y="{v.centre_y!r}" data-scale="{v.scale!r}"/>'
        ]
        robots, poses, model = spec.robots, st.poses, spec.sensor_model
        if "beams" in self.layers:
            nearest = st.nearest.tolist()
            for k, (i, sensor) in enumerate(st.sensors):
                if sensor.kind == "laser":  # every ray to its hit
                    parts.append(beams_svg(v, robots[i], sensor, poses[i], ranges=st.scans.get(k), sensor_model=model))
                else:  # the cone and its nearest hit
                    parts.append(beams_svg(v, robots[i], sensor, poses[i], nearest=nearest[k], sensor_model=model))
        names = "names" in self.layers
        crashed = st.crashed.tolist()
        for i, robot in enumerate(robots):
            label = robot.name if names else ""
            parts.append(robot_svg(v, robot, poses[i], selected=i == self.robot, crashed=crashed[i], label=label))
        return "".join(parts)

    def tracks_svg(self, st: WorldState, spec: WorldSpec) -> str:
        robots = spec.robots
        return "".join(
            track_svg(self.view, np.array(list(track)).reshape(-1, 2), robots[i].color)  # list(): one atomic copy
            for i, track in enumerate(st.tracks)
        )

    def toggle(self, key: str, on: bool) -> None:
        (self.layers.add if on else self.layers.discard)(key)
        self.view_dirty = True

    def fit(self) -> None:
        loaded = self.loaded()
        if loaded is None:
            return
        spec = loaded[1]
        nx, ny = spec.walls.shape
        ox, oy = spec.origin
        w, h = nx * spec.resolution, ny * spec.resolution
        self.view.fit(np.array([ox, ox + w]), np.array([oy, oy + h]), margin_m=0.03 * max(w, h))
        self.draw_map()
        self.view_dirty = True

    def view_changed(self) -> None:
        self.draw_map()
        self.view_dirty = True

    # ---------------------------------------------------------------- mouse: click a robot, drag to pan
    def on_mouse(self, e) -> None:
        if e.type == "mousedown":
            self.mouse_down = (e.image_x, e.image_y, self.view.centre_x, self.view.centre_y)
            return
        if self.mouse_down is None:
            return
        px, py, cx, cy = self.mouse_down
        moved = math.hypot(e.image_x - px, e.image_y - py) >= 4
        if moved:
            self.view.pan((cx, cy), e.image_x - px, e.image_y - py)
            self.draw_map()
            self.view_dirty = True
        if e.type == "mouseup":
            self.mouse_down = None
            if not moved:
                self.pick(*self.view.to_world(e.image_x, e.image_y))

    def pick(self, x: float, y: float) -> None:
        loaded = self.loaded()
        if loaded is None or not len(loaded[0].poses):
            return
        st, spec = loaded
        d = np.hypot(st.poses[:, 0] - x, st.poses[:, 1] - y)
        i = int(np.argmin(d))
        if d[i] > hit_radius_m(self.view, spec.robots[i]) + 4.0 / self.view.scale:
            return
        self.robot = i
        self.info.set_content(info_html(st, i))
        self.view_dirty = True
