"""The SIMROBOT simulator page (the original's Simulator window): watch a running world, run/pause/step,
real-time factor, the step counter and sim time, a replay of the steps seen (at least the world's
``replay_step_time`` a step), a robot's info with power and clear crash, draw tracks to PNG.

The view redraws at most every FRAME_PERIOD_S and only when a new ``robots`` message came in. The
browser counts the frames it actually shows (a requestAnimationFrame loop watching the frame number
the page writes into the drawing) and shows frames/s under the view: what the benchmark reads.
"""

from __future__ import annotations

import json

import numpy as np
from nicegui import events, ui

from sim_runtime.track_plot import draw_tracks
from simrobot_sim.world_file import WorldSpec
from studio.shell import svg
from studio.shell.app import Studio
from studio.shell.kit import VIEW_SIZE, nav, stop_started_world, view_image
from studio.simrobot.family import side
from studio.simrobot.view import SimrobotView, info_html

FRAME_PERIOD_S = 0.05
"""How often the page looks for a new step (it redraws only when one came). Looking every 25 ms
drew no more frames on a busy machine: the browser then skips some."""
RTF_OPTIONS = {0.25: "0.25×", 0.5: "0.5×", 1.0: "1× (real time)", 2.0: "2×", 4.0: "4×", 0.0: "as fast as possible"}
LAYERS = {"beams": "Beams and hits", "tracks": "Tracks", "names": "Names"}
FPS_JS = """
<script>
(() => {
  let last = null, shown = 0, t0 = performance.now();
  window.simrobotFrames = 0;
  function count() {
    const g = document.querySelector('.simrobot-view g.frame');
    const n = g && g.dataset.n;
    if (n && n !== last) { last = n; window.simrobotFrames++; shown++; }
    const now = performance.now();
    if (now - t0 >= 1000) {
      const label = document.querySelector('.simrobot-fps');
      if (label) label.textContent = (shown * 1000 / (now - t0)).toFixed(1) + ' frames/s';
      shown = 0; t0 = now;
    }
    requestAnimationFrame(count);
  }
  requestAnimationFrame(count);
})();
</script>
"""


TAB_WORLD_KEY = "robot_sims.studio.simrobot_world"
"""Where a tab keeps its choice of world: the browser's sessionStorage, one per tab, kept over a
reload (the studio's "last picked" is every tab's: a reloaded tab would take another tab's world)."""


def register(studio: Studio) -> None:
    @ui.page("/simrobot")
    async def simrobot_page() -> None:
        page = SimrobotPage(studio)
        await page.restore_choice()


class SimrobotPage(SimrobotView):
    """One tab's view of one SIMROBOT world."""

    def __init__(self, studio: Studio) -> None:
        self.studio = studio
        self.side = side(studio)
        self.view = svg.View(*VIEW_SIZE, scale=200.0)
        self.ns: str | None = None
        self.layers = set(LAYERS)
        self.robot: int | None = None
        self.drawn_seq = -1
        self.drawn_map: WorldSpec | None = None  # the spec whose map is drawn
        self.view_dirty = True
        self.frames = 0
        self.map_url = ""
        self.mouse_down: tuple[float, float, float, float] | None = None  # pixel, view centre at the press
        self.tracks_drawn = 0.0
        self.restored = False  # the tab's own choice is read back from the browser (until then: none)
        self.build()
        ui.timer(FRAME_PERIOD_S, self.tick)
        ui.timer(0.5, self.slow_tick)

    def build(self) -> None:
        nav("/simrobot")
        ui.add_body_html(FPS_JS)
        with ui.row().classes("w-full no-wrap items-start gap-4 p-2"):
            with ui.column().classes("gap-1"):
                self.image = view_image(self.on_mouse, self.on_wheel, "simrobot-view", "#fff")
                self.track_layer = self.image.add_layer()  # redrawn once a second: history changes slowly
                self.dynamic = self.image.add_layer()
                with ui.row().classes("items-center gap-2"):
                    ui.button("−", on_click=lambda: self.zoom(1 / 1.25)).props("dense flat")
                    ui.button("+", on_click=lambda: self.zoom(1.25)).props("dense flat")
                    ui.button("Fit map", on_click=self.fit).props("dense flat")
                    for key, text in LAYERS.items():
                        ui.checkbox(text, value=True, on_change=lambda e, k=key: self.toggle(k, e.value))
                    ui.label("").classes("simrobot-fps font-mono text-sm text-gray-600")
                self.status = ui.label("").classes("simrobot-status font-mono text-sm")
            with ui.column().classes("gap-2 w-[420px]"):
                with ui.row().classes("items-center gap-2 w-full"):
                    self.world_select = ui.select({}, label="World (namespace)", on_change=self.on_world).classes(
                        "w-48 simrobot-world"
                    )
                    self.no_world = ui.label("no SIMROBOT world found yet").classes("text-orange-700 text-sm")
                ui.link("Build one in the editor", "/simrobot/editor").classes("text-sm")
                with ui.card().classes("w-full"):
                    ui.label("Run").classes("font-bold")
                    self.steps_label = ui.label("").classes("simrobot-steps font-mono text-sm")
                    with ui.row().classes("items-center gap-2"):
                        self.pause_switch = ui.switch("Pause", on_change=self.on_pause).classes("simrobot-pause")
                        ui.button("Step", on_click=self.step).props("dense outline").classes("simrobot-step")
                        self.rtf_select = ui.select(
                            RTF_OPTIONS, value=1.0, label="Speed (real_time_factor)", on_change=self.on_rtf
                        ).classes("w-48")
                    with ui.row().classes("items-center gap-2"):
                        ui.button("Run replay", on_click=self.run_replay).props("dense outline").classes(
                            "simrobot-replay"
                        )
                        ui.button("Stop replay", on_click=self.stop_replay).props("dense flat")
                        self.replay_label = ui.label("").classes("text-sm text-gray-600")
                    with ui.row().classes("items-center gap-2"):
                        ui.button("Stop world", on_click=self.stop_world).props("dense outline color=red")
                        self.world_label = ui.label("").classes("text-sm break-all")
                with ui.card().classes("w-full"):
                    ui.label("Robot (click it in the view)").classes("font-bold")
                    self.info = ui.html("", sanitize=False)
                    with ui.row().classes("items-center gap-2"):
                        ui.button("Power on", on_click=lambda: self.power(True)).props("dense outline")
                        ui.button("Power off", on_click=lambda: self.power(False)).props("dense outline")
                        ui.button("Clear crash", on_click=self.clear_crash).props("dense outline")
                with ui.card().classes("w-full"):
                    ui.label("Tracks").classes("font-bold")
                    with ui.row().classes("items-center gap-2"):
                        self.tracks_name = ui.input("PNG file", value="simrobot_tracks.png").classes(
                            "w-48 simrobot-tracks-name"
                        )
                        ui.button("Draw tracks", on_click=self.draw_tracks).props("dense outline")
                        ui.button("Clear", on_click=self.clear_tracks).props("dense flat")
                    self.tracks_label = ui.label("").classes("text-sm break-all simrobot-tracks-message")
                    self.tracks_image = ui.image().classes("w-full")
                    self.tracks_image.set_visibility(False)

    async def restore_choice(self) -> None:
        """The world this tab picked before a reload (a new tab: the studio's last picked): until it
        is known the tab lists no world, so no command reaches another tab's world."""
        try:
            await ui.context.client.connected(timeout=30.0)
            stored = await ui.run_javascript(f"return sessionStorage.getItem({json.dumps(TAB_WORLD_KEY)})")
        except TimeoutError:
            stored = None
        if isinstance(stored, str) and self.ns is None:
            self.ns = json.loads(stored)
        self.restored = True

    def slow_tick(self) -> None:
        ros = self.side.client
        if ros is None:
            return
        names = ros.namespaces() if self.restored else []
        if names != list(self.world_select.options):
            current = self.ns if self.ns in names else self.side.selected if self.side.selected in names else None
            value = current if current is not None else (names[0] if names else None)
            self.world_select.set_options({ns: ns or "/" for ns in names}, value=value)
            self.ns = value
            self.view_dirty = True
        self.no_world.set_visibility(not names)
        st = self.world()
        if st is not None and self.robot is not None and self.robot < len(st.names):
            self.info.set_content(info_html(st, self.robot))
        child = self.side.worlds.get(self.ns or "")
        if child is not None and not child.running:
            self.world_label.set_text(f"{child.label}: {child.error_line()}")
        elif st is not None and st.problem:
            self.world_label.set_text(st.problem)

    def on_world(self, e) -> None:
        self.ns = e.value
        if e.value is not None:
            self.side.selected = e.value
            ui.run_javascript(f"sessionStorage.setItem({json.dumps(TAB_WORLD_KEY)}, {json.dumps(json.dumps(e.value))})")
        self.robot = None
        self.drawn_map = None
        self.view_dirty = True

    # ---------------------------------------------------------------- commands
    async def ask(self, call) -> None:
        try:
            result = await call
        except (TimeoutError, KeyError, IndexError) as err:
            ui.notify(str(err), type="negative")
            return
        if isinstance(result, list):
            for reason in result:
                ui.notify(reason, type="negative")
        elif isinstance(result, tuple):
            ui.notify(result[1], type="positive" if result[0] else "negative")
        else:
            ui.notify(result)

    async def on_pause(self, e: events.ValueChangeEventArguments) -> None:
        if (to := self.commanded()) is not None:
            await self.ask(to[0].set_world_parameters(to[1], {"paused": bool(e.value)}))

    async def step(self) -> None:
        if (to := self.commanded()) is not None:
            await self.ask(to[0].step_world(to[1]))

    async def on_rtf(self, e: events.ValueChangeEventArguments) -> None:
        if (to := self.commanded()) is not None and e.value is not None:
            await self.ask(to[0].set_world_parameters(to[1], {"real_time_factor": float(e.value)}))

    async def power(self, on: bool) -> None:
        if (to := self.commanded()) is not None and self.robot is not None:
            await self.ask(to[0].set_power(to[1], self.robot, on))

    async def clear_crash(self) -> None:
        if (to := self.commanded()) is not None and self.robot is not None:
            await self.ask(to[0].clear_crash(to[1], self.robot))

    def run_replay(self) -> None:
        refusal = self.start_replay()
        if refusal:
            ui.notify(refusal, type="warning")
            return
        loaded = self.loaded()
        step_time = loaded[1].replay_step_time if loaded is not None else 0.0
        self.replay_label.set_text(f"step time {step_time:g} s (the world file's replay_step_time)")

    async def stop_world(self) -> None:
        await stop_started_world(self.side.worlds, self.ns or "")

    def clear_tracks(self) -> None:
        st = self.world()
        if st is not None:
            st.clear_tracks()
            self.view_dirty = True

    def draw_tracks(self) -> None:
        loaded = self.loaded()
        if loaded is None:
            return
        st, spec = loaded
        ws = self.studio.workspace
        name = (self.tracks_name.value or "").strip()
        try:
            path = ws.path(name)
            if path.suffix.lower() != ".png":
                raise ValueError(f"{name!r}: name the file .png")
            tracks = {st.names[i]: np.array(list(t)).reshape(-1, 2) for i, t in enumerate(st.tracks)}
            colors = {r.name: r.color for r in spec.robots}
            # draw_tracks takes OccupancyGrid layout: rows along y, row 0 the lowest
            draw_tracks(spec.walls.T, spec.resolution, spec.origin, tracks, colors, path, title=st.ns or "/")
        except (ValueError, OSError) as err:
            self.tracks_label.set_text(f"error: {err}")
            return
        self.tracks_label.set_text(f"saved {ws.relative(path)}")
        self.tracks_image.set_source(path)
        self.tracks_image.force_reload()
        self.tracks_image.set_visibility(True)
