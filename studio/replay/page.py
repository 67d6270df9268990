"""The Replay page (the original's ReplayGUI): a recorded bag drawn as the live view, played or stepped.

A Create or SIMROBOT run is drawn on the map view as the simulator pages draw it; an arm run in 3D
with its meshes, scene objects and end-effector frames, by the Arm page's own view
(:class:`~studio.arm.scene.ArmScene`).

Play, pause, stop, ¼ speed forwards and backwards, a timeline, the arrow keys (left/up one frame back,
right/down one forward; held, they repeat). The side panel shows the time, each robot's pose, the
commands sent up to now and every topic's latest message. Seeks go through a
:class:`~sim_runtime.bag.index.BagIndex`, so any instant of a long bag is shown at once.
"""

from __future__ import annotations

import asyncio
import base64
import io
import math
import time
import warnings
from html import escape
from pathlib import Path

import numpy as np
from nicegui import run, ui

from sim_runtime.errors import InputError
from sim_tools.cli import executable_command
from studio.arm.scene import ArmScene
from studio.create import draw
from studio.replay.frames import Frame, Replay, RobotFrame, planar
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, ZoomableView, nav, view_image
from studio.shell.workspace import Workspace

FRAME_PERIOD_S = 0.04
"""Playback redraws at most this often (25 frames/s)."""
SPEEDS = {"rewind": -0.25, "slow": 0.25, "play": 1.0}
SPEED_TEXT = {0.0: "paused", 1.0: "playing", 0.25: "playing at ¼ speed", -0.25: "backwards at ¼ speed"}
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
KEY_STEPS = {"ArrowLeft": -1, "ArrowUp": -1, "ArrowRight": 1, "ArrowDown": 1}
"""The original's keys: up and left step one frame back, down and right one forward."""
TRACK_POINTS_DRAWN = 2000
"""A long track is drawn through this many of its points (a 10-minute run has ~8,000): the frame
sent to the browser stays ~25 kB however long the run."""
TOPICS_LISTED = 120
"""The side panel lists at most this many topics (a 200-robot SIMROBOT bag has a thousand)."""
OPENED_KEPT = 4
_opened: dict[tuple[str, float], Replay] = {}  # (bag path, newest file time) → indexed bag, for every tab


def bag_names(workspace: Workspace) -> list[str]:
    """The bags in the workspace: folders of .mcap splits (rosbag2's layout) and lone .mcap files."""
    names = []
    for name in workspace.files((".mcap",)):
        path = workspace.path(name)
        folder = path.parent
        is_folder_bag = folder != workspace.root and (
            (folder / "metadata.yaml").exists() or path.name.startswith(folder.name + "_")
        )
        bag = workspace.relative(folder) if is_folder_bag else name
        if bag not in names:
            names.append(bag)
    return names


def open_replay(path: Path) -> tuple[Replay, list[str]]:
    """The bag indexed (kept for the next tab that opens it) and the warnings reading it gave."""
    files = [path] if path.is_file() else sorted(path.glob("*.mcap"))
    key = (str(path), max((f.stat().st_mtime for f in files), default=0.0))
    if key in _opened:
        return _opened[key], []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        replay = Replay.open(path)
    _opened[key] = replay
    while len(_opened) > OPENED_KEPT:
        _opened.pop(next(iter(_opened))).index.close()
    return replay, list(dict.fromkeys(str(w.message) for w in caught))


def grid_image_svg(view: svg.View, grid) -> str:
    """A SIMROBOT OccupancyGrid as an embedded PNG placed in the view (walls black, unknown grey)."""
    from PIL import Image

    info = grid.info
    cells = np.asarray(grid.data, dtype=np.int8).reshape(info.height, info.width)
    grey = np.where(cells < 0, 200, np.where(cells >= 50, 0, 255)).astype(np.uint8)[::-1]  # row 0 = lowest y
    buf = io.BytesIO()
    Image.fromarray(grey, "L").save(buf, "PNG")
    x0, y0 = info.origin.position.x, info.origin.position.y
    left, top = view.to_px(x0, y0 + info.height * info.resolution)
    width, height = info.width * info.resolution * view.scale, info.height * info.resolution * view.scale
    return (
        f'<image x="{float(left):.1f}" y="{float(top):.1f}" width="{width:.1f}" height="{height:.1f}" '
        f'preserveAspectRatio="none" style="image-rendering:pixelated" '
        f'href="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}"/>'
    )


def drawn_track(track: np.ndarray | None) -> np.ndarray | None:
    """The track thinned to TRACK_POINTS_DRAWN points, its first and last kept."""
    if track is None or len(track) <= TRACK_POINTS_DRAWN:
        return track
    return track[np.linspace(0, len(track) - 1, TRACK_POINTS_DRAWN).round().astype(int)]


def markers_svg(view: svg.View, markers) -> str:
    """Line and point markers (SIMROBOT's ``/robots`` outlines) in their colours, on the map."""
    parts = []
    for m in markers.markers:
        if m.action != 0 or not m.points:
            continue
        x0, y0, yaw = planar(m.pose)
        local = np.array([(p.x, p.y) for p in m.points], dtype=float)
        c, s = math.cos(yaw), math.sin(yaw)
        px, py = view.to_px(x0 + c * local[:, 0] - s * local[:, 1], y0 + s * local[:, 0] + c * local[:, 1])
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(px.tolist(), py.tolist(), strict=True))
        colour = svg.rgb_hex((m.color.r, m.color.g, m.color.b))
        parts.append(f'<polyline class="outline" points="{pts}" fill="none" stroke="{colour}" stroke-width="2"/>')
    return "".join(parts)


def small_robot_svg(view: svg.View, rf: RobotFrame, radius_m: float = 0.05) -> str:
    """A SIMROBOT (or any non-Create) robot: disc, heading, name, its track; red when crashed."""
    parts = []
    track = drawn_track(rf.track)
    if track is not None and len(track) > 1:
        tx, ty = view.to_px(track[:, 0], track[:, 1])
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(tx.tolist(), ty.tolist(), strict=True))
        parts.append(f'<polyline points="{pts}" fill="none" stroke="#8e44ad" stroke-width="1.5"/>')
    if rf.pose is None:
        return "".join(parts)
    x, y, th = rf.pose
    px, py = view.to_px(x, y)
    hx, hy = view.to_px(x + radius_m * math.cos(th), y + radius_m * math.sin(th))
    r = max(radius_m * view.scale, 4.0)
    fill = "#e74c3c" if rf.crashed else "#3498db"
    parts.append(
        f'<circle cx="{px:.1f}" cy="{py:.1f}" r="{r:.1f}" fill="{fill}" fill-opacity="0.5" stroke="#000"/>'
        f'<line x1="{px:.1f}" y1="{py:.1f}" x2="{hx:.1f}" y2="{hy:.1f}" stroke="#000" stroke-width="2"/>'
        f'<text x="{px:.1f}" y="{py - r - 3:.1f}" font-size="12" text-anchor="middle">{escape(rf.robot.label)}</text>'
    )
    return "".join(parts)


def joints_svg(frame: Frame) -> str:
    """Each arm's joints as gauges in the view's corner: a bar from 0 to the angle on a ±π scale."""
    parts = []
    y = 24.0
    half = 150.0  # px for π
    for arm, joints in frame.joints.items():
        parts.append(f'<text x="10" y="{y:.0f}" font-size="14" font-weight="bold">arm {escape(arm or "/")}</text>')
        y += 10
        for name, position in joints:
            y += 22
            x0 = 120 + half
            end = x0 + half * max(-1.0, min(1.0, position / math.pi))
            parts.append(
                f'<text x="10" y="{y + 4:.0f}" font-size="12">{escape(name)}</text>'
                f'<line x1="120" y1="{y:.0f}" x2="{120 + 2 * half:.0f}" y2="{y:.0f}" stroke="#ddd" stroke-width="8"/>'
                f'<line class="joint" x1="{x0:.0f}" y1="{y:.0f}" x2="{end:.1f}" y2="{y:.0f}" stroke="#1565c0" '
                f'stroke-width="8"/><text x="{130 + 2 * half:.0f}" y="{y + 4:.0f}" font-size="12" '
                f'font-family="monospace">{position:+.3f} rad</text>'
            )
        y += 30
    return "".join(parts)


def _num(value: float | None, digits: int = 3) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def panel_html(frame: Frame) -> str:
    """The side panel: poses, arms, commands so far and every topic's latest message."""
    rows = []
    for rf in frame.robots:
        pose = rf.pose or (None, None, None)
        rows.append(
            f"<tr><td class='pr-3 text-gray-600'>{escape(rf.robot.label)} pose x, y, θ</td>"
            f"<td class='font-mono studio-replay-pose'>{_num(pose[0])} {_num(pose[1])} {_num(pose[2])}</td></tr>"
        )
        if rf.velocity is not None:
            rows.append(
                f"<tr><td class='pr-3 text-gray-600'>{escape(rf.robot.label)} v, ω</td>"
                f"<td class='font-mono'>{_num(rf.velocity[0])} {_num(rf.velocity[1])}</td></tr>"
            )
    for arm, joints in frame.joints.items():
        values = "<br>".join(f"{escape(n)} {p:.3f} rad" for n, p in joints)
        rows.append(
            f"<tr><td class='pr-3 text-gray-600'>{escape(arm or '/')} joints</td>"
            f"<td class='font-mono'>{values}</td></tr>"
        )
        if arm in frame.end_effectors:
            x, y, z = frame.end_effectors[arm][:3]
            rows.append(
                f"<tr><td class='pr-3 text-gray-600'>{escape(arm or '/')} end effector</td>"
                f"<td class='font-mono'>{x:.3f} {y:.3f} {z:.3f}</td></tr>"
            )
    commands = "".join(
        f"<tr><td class='pr-2 font-mono'>{t:.3f}</td><td class='pr-2'>{escape(topic)}</td>"
        f"<td class='font-mono'>{escape(text)}</td></tr>"
        for t, topic, text in frame.commands
    )
    latest = "".join(
        f"<tr><td class='pr-2'>{escape(topic)}</td><td class='pr-2 font-mono text-gray-500'>{age:.2f}</td>"
        f"<td class='font-mono'>{escape(text)}</td></tr>"
        for topic, age, text in frame.latest[:TOPICS_LISTED]
    )
    if len(frame.latest) > TOPICS_LISTED:
        latest += f"<tr><td colspan='3'>… and {len(frame.latest) - TOPICS_LISTED} more topics</td></tr>"
    return (
        f"<table class='text-sm'>{''.join(rows)}</table>"
        "<div class='font-bold mt-2'>Commands sent (newest first)</div>"
        f"<table class='text-sm studio-replay-commands'>{commands or '<tr><td>none yet</td></tr>'}</table>"
        "<div class='font-bold mt-2'>Messages at this instant (topic, age s, value)</div>"
        f"<table class='text-xs studio-replay-latest'>{latest}</table>"
    )


def register(studio: Studio) -> None:
    @ui.page("/replay")
    def replay_page() -> None:
        ReplayPage(studio)


class ReplayPage(ZoomableView):
    """One tab's replay: its bag, time, speed and view."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.view = svg.View(*VIEW_SIZE, scale=60.0)
        self.layers = set(LAYERS)
        self.replay: Replay | None = None
        self.t_ns = 0
        self.speed = 0.0
        self.last_tick = time.monotonic()
        self.shown_t: int | None = None
        self.base_dirty = True
        self.mouse_down: tuple[float, float] | None = None
        self.view_at_press = (0.0, 0.0)
        self.moving_slider = False
        self.grid_cache: tuple[tuple, str] | None = None
        self.build()

    @property
    def speed(self) -> float:
        """Bag seconds per second (0 = paused, negative = backwards)."""
        return self._speed

    @speed.setter
    def speed(self, value: float) -> None:
        self._speed = value
        if hasattr(self, "speed_label"):
            self.speed_label.set_text(SPEED_TEXT[value])

    # ---------------------------------------------------------------- layout
    def build(self) -> None:
        nav("/replay")
        # As on the simulator page: a clicked button gives the focus back, so the arrows keep stepping.
        ui.add_body_html(
            "<script>document.addEventListener('pointerup', (e) => {"
            " const c = e.target.closest && e.target.closest('button, .q-toggle, .q-checkbox, .q-btn, .q-slider');"
            " if (c) setTimeout(() => document.activeElement && document.activeElement.blur(), 0); });</script>"
        )
        ui.keyboard(on_key=self.on_key, ignore=["input", "select", "textarea"])
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.image = view_image(self.on_mouse, self.on_wheel, "studio-replay-view", "#fafafa")
                self.dynamic = self.image.add_layer()
                self.arm_view = ArmScene(VIEW_SIZE, "studio-replay-arm-view")  # an arm bag's meshes, as live
                self.arm_view.set_shown(False)
                with ui.row().classes("items-center gap-1"):
                    for text, icon, action, css, tip in (
                        ("", "stop", self.stop, "stop", "Stop: back to the start"),
                        ("¼", "fast_rewind", lambda: self.play("rewind"), "rewind", "backwards at ¼ speed"),
                        ("", "pause", self.pause, "pause", "Pause"),
                        ("¼", "play_arrow", lambda: self.play("slow"), "slow", "forwards at ¼ speed"),
                        ("", "play_arrow", lambda: self.play("play"), "play", "Play"),
                    ):
                        with (
                            ui.button(text, icon=icon, on_click=action)
                            .props("dense flat")
                            .classes(f"studio-replay-{css}")
                        ):
                            ui.tooltip(tip).props("delay=600")
                    self.time_label = ui.label("no bag open").classes("font-mono studio-replay-time ml-2")
                    self.speed_label = ui.label("").classes("text-sm text-gray-600 studio-replay-speed")
                self.slider = (
                    ui.slider(min=0, max=1, step=0.001, value=0, on_change=self.on_slider)
                    .props("label")
                    .classes("w-[800px] studio-replay-slider")
                )
                with ui.column().classes("gap-1") as self.plan_controls:  # the map view's
                    with ui.row().classes("items-center gap-2"):
                        ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
                        ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
                        ui.button("Fit", on_click=self.fit).props("dense flat")
                    with ui.row().classes("gap-3"):
                        for key, text in LAYERS.items():
                            ui.checkbox(text, value=True, on_change=lambda e, k=key: self.toggle_layer(k, e.value))
            with ui.column().classes("gap-2 w-[460px]"):
                with ui.card().classes("w-full"):
                    ui.label("Bag").classes("font-bold")
                    with ui.row().classes("items-center gap-2 no-wrap"):
                        self.bag_select = ui.select(
                            bag_names(self.studio.workspace), label="bag in the workspace", with_input=True
                        ).classes("w-72 studio-replay-bag")
                        ui.button("↻", on_click=self.refresh).props("dense flat").tooltip("look for new bags")
                        ui.button("Open", on_click=self.open_bag).props("dense").classes("studio-replay-open")
                    self.bag_label = ui.label("").classes("text-sm break-all studio-replay-message")
                    with ui.row().classes("items-center gap-2"):
                        ui.button("Export to Rerun", on_click=self.export_rerun).props("dense outline").classes(
                            "studio-replay-rerun"
                        )
                        ui.button("Draw tracks", on_click=self.draw_tracks).props("dense outline").classes(
                            "studio-replay-tracks"
                        )
                    self.output_label = ui.label("").classes("text-sm break-all studio-replay-output")
                self.panel = ui.html("", sanitize=False).classes("w-full studio-replay-panel")
        ui.timer(FRAME_PERIOD_S, self.tick)

    # ---------------------------------------------------------------- bag
    def refresh(self) -> None:
        names = bag_names(self.studio.workspace)
        self.bag_select.set_options(names, value=self.bag_select.value if self.bag_select.value in names else None)

    async def open_bag(self) -> None:
        name = self.bag_select.value
        if not name:
            self.bag_label.set_text("choose a bag first")
            return
        self.bag_label.set_text(f"indexing {name}…")
        try:
            path = self.studio.workspace.path(name)
            started = time.monotonic()
            opened = await run.io_bound(open_replay, path)
        except InputError as err:
            self.bag_label.set_text(f"error: {err}")
            return
        if opened is None:
            return  # the studio is shutting down
        replay, problems = opened
        self.replay = replay
        self.arm_view.clear()
        self.arm_view.set_shown(bool(replay.arm_marker_topics))
        plan_view = replay.has_plan_view or not replay.arm_marker_topics
        self.image.set_visibility(plan_view)
        self.plan_controls.set_visibility(plan_view)
        self.speed = 0.0
        self.t_ns = replay.first_frame_ns
        self.shown_t = None
        self.base_dirty = True
        self.grid_cache = None
        self.slider.props(f"max={max(replay.duration_s, 0.001)}")
        robots = ", ".join(f"{r.label} ({r.kind})" for r in replay.robots) or "no robots"
        arms = f"; arms {', '.join(a or '/' for a in replay.arms)}" if replay.arms else ""
        self.bag_label.set_text(
            f"{name}: {replay.duration_s:.2f} s, {replay.index.message_count} messages, {len(replay.frames)} frames; "
            f"{robots}{arms} (indexed in {time.monotonic() - started:.2f} s)"
            + (f"; {len(problems)} warnings: {problems[0]}" if problems else "")
        )
        self.fit()
        self.show()

    async def export_rerun(self) -> None:
        """``robot_sims bag_to_rerun`` on the open bag, in a process of its own: Rerun keeps some
        threads of every recording a process makes, which the studio would gather export by export."""
        from sim_tools.rerun_view.convert import default_output

        if self.replay is None:
            self.output_label.set_text("open a bag first")
            return
        out = default_output(self.replay.path)
        self.output_label.set_text(f"writing {self.studio.workspace.relative(out)}…")
        command = executable_command("bag_to_rerun", [str(self.replay.path), "-o", str(out), "--no-progress"])
        process = await asyncio.create_subprocess_exec(
            *command, stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE
        )
        _, stderr = await process.communicate()
        if process.returncode != 0:
            lines = stderr.decode(errors="replace").strip().splitlines() or [f"exit status {process.returncode}"]
            self.output_label.set_text(f"error: {lines[-1].removeprefix('bag_to_rerun: error: ')}")
            return
        self.output_label.set_text(f"wrote {self.studio.workspace.relative(out)} (open it with: rerun {out.name})")

    async def draw_tracks(self) -> None:
        from sim_runtime.track_plot import draw_tracks
        from sim_tools.rerun_view.tracks import tracks_from_bag

        if self.replay is None:
            self.output_label.set_text("open a bag first")
            return
        path = self.replay.path
        out = path.with_name(path.stem + "_tracks.png")

        def drawn() -> Path:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                data = tracks_from_bag(path)
            if not data.tracks:
                raise InputError.at(path, None, "no robot poses (overhead_pose, pose or odom) in this bag")
            draw_tracks(data.image, data.resolution, data.origin, data.tracks, data.colors, out)
            return out

        try:
            written = await run.io_bound(drawn)
        except InputError as err:
            self.output_label.set_text(f"error: {err}")
            return
        if written is None:
            return  # the studio is shutting down
        self.output_label.set_text(f"wrote {self.studio.workspace.relative(written)}")

    # ---------------------------------------------------------------- transport
    def play(self, how: str) -> None:
        if self.replay is None:
            return
        self.speed = SPEEDS[how]
        if self.speed > 0 and self.t_ns >= self.replay.end_ns:
            self.t_ns = self.replay.first_frame_ns  # play again from the start
        self.last_tick = time.monotonic()

    def pause(self) -> None:
        self.speed = 0.0

    def stop(self) -> None:
        self.speed = 0.0
        if self.replay is not None:
            self.seek(self.replay.first_frame_ns)

    def seek(self, t_ns: int) -> None:
        if self.replay is not None:
            self.t_ns = self.replay.clamp(t_ns)
            self.show()

    def on_key(self, e) -> None:
        if not e.action.keydown or e.modifiers.ctrl or e.modifiers.alt or e.modifiers.meta:
            return
        if e.key.name == " " and not e.action.repeat:
            self.pause() if self.speed else self.play("play")
            return
        steps = KEY_STEPS.get(e.key.name)
        if steps is not None and self.replay is not None:
            self.speed = 0.0
            self.seek(self.replay.step(self.t_ns, steps))

    def on_slider(self, e) -> None:
        if self.moving_slider or self.replay is None or e.value is None:
            return
        self.speed = 0.0
        self.seek(self.replay.start_ns + round(float(e.value) * 1e9))

    def tick(self) -> None:
        now = time.monotonic()
        elapsed, self.last_tick = now - self.last_tick, now
        replay = self.replay
        if replay is None:
            return
        if self.speed:
            self.t_ns = replay.clamp(self.t_ns + round(elapsed * self.speed * 1e9))
            if self.t_ns in (replay.start_ns, replay.end_ns):
                self.speed = 0.0  # the end (or, backwards, the start)
        if self.base_dirty or self.t_ns != self.shown_t or self.arm_view.stale:
            self.show()

    # ---------------------------------------------------------------- drawing
    def show(self) -> None:
        replay = self.replay
        if replay is None:
            return
        frame = replay.frame(self.t_ns)
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
        if frame.outlines is not None:
            parts.append(markers_svg(v, frame.outlines))
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
        frame = replay.frame(replay.end_ns)
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
        for robot in replay.robots:
            finite = robot.track[np.isfinite(robot.track).all(axis=1)]
            xs.append(finite[:, 0])
            ys.append(finite[:, 1])
        if xs:
            self.view.fit(np.concatenate(xs), np.concatenate(ys), margin_m=0.5)
        self.base_dirty = True
