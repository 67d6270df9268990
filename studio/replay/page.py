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
import time
import warnings
from pathlib import Path

from nicegui import run, ui

from sim_runtime.errors import InputError
from sim_tools.cli import executable_command
from studio.arm.scene import ArmScene
from studio.create.sim_view import LAYERS  # the replay shows the layers of the live Create view
from studio.replay.frames import Replay
from studio.replay.view import ReplayView
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, nav, view_image
from studio.shell.workspace import Workspace

FRAME_PERIOD_S = 0.04
"""Playback redraws at most this often (25 frames/s)."""
SPEEDS = {"rewind": -0.25, "slow": 0.25, "play": 1.0}
SPEED_TEXT = {0.0: "paused", 1.0: "playing", 0.25: "playing at ¼ speed", -0.25: "backwards at ¼ speed"}
KEY_STEPS = {"ArrowLeft": -1, "ArrowUp": -1, "ArrowRight": 1, "ArrowDown": 1}
"""The original's keys: up and left step one frame back, down and right one forward."""
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


def register(studio: Studio) -> None:
    @ui.page("/replay")
    def replay_page() -> None:
        ReplayPage(studio)


class ReplayPage(ReplayView):
    """One tab's replay: its bag, time, speed and view."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.view = svg.View(*VIEW_SIZE, scale=60.0)
        self.layers = set(LAYERS)
        self.replay: Replay | None = None
        self.world: str | None = None
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
                    self.world_select = ui.select(
                        {}, label="world shown (one at a time: each has its own map and frame)", on_change=self.on_world
                    ).classes("w-full studio-replay-world")
                    self.world_select.set_visibility(False)
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
        self.world = next(iter(replay.worlds)) if len(replay.worlds) > 1 else None
        self.world_select.set_options(
            {ns: f"{ns or '/'} ({replay.world_kind(ns)})" for ns in replay.worlds}, value=self.world
        )
        self.world_select.set_visibility(self.world is not None)
        self.arm_view.clear()
        self.arm_view.set_shown(bool(replay.arm_marker_topics))
        plan_view = replay.has_plan_view or not replay.arm_marker_topics
        self.image.set_visibility(plan_view)
        self.plan_controls.set_visibility(plan_view)
        self.speed = 0.0
        self.t_ns = replay.first_frame_of(self.world)
        self.shown_t = None
        self.base_dirty = True
        self.grid_cache = None
        self.slider.props(f"max={max(replay.duration_s, 0.001)}")
        robots = ", ".join(f"{r.label} ({r.kind})" for r in replay.robots) or "no robots"
        arms = f"; arms {', '.join(a or '/' for a in replay.arms)}" if replay.arms else ""
        self.bag_label.set_text(
            f"{name}: {replay.duration_s:.2f} s, {replay.index.message_count} messages, {len(replay.frames)} frames; "
            f"{robots}{arms}"
            + (f"; {len(replay.worlds)} worlds, shown one at a time" if self.world is not None else "")
            + f" (indexed in {time.monotonic() - started:.2f} s)"
            + (f"; {len(problems)} warnings: {problems[0]}" if problems else "")
        )
        self.fit()
        self.show()

    def on_world(self, e) -> None:
        """Show another of the bag's worlds: its map, its robots, fitted."""
        if self.replay is None or e.value is None or e.value == self.world:
            return
        self.world = e.value
        self.t_ns = max(self.t_ns, self.replay.first_frame_of(self.world))  # not before its first robot pose
        self.shown_t = None
        self.grid_cache = None
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
            self.t_ns = self.replay.first_frame_of(self.world)  # play again from the start
        self.last_tick = time.monotonic()

    def pause(self) -> None:
        self.speed = 0.0

    def stop(self) -> None:
        self.speed = 0.0
        if self.replay is not None:
            self.seek(self.replay.first_frame_of(self.world))

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
            self.seek(self.replay.step(self.t_ns, steps, self.world))

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
