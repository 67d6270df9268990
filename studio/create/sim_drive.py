"""The Simulator page's Manual control card: arrow keys and buttons, joystick, the Create's
buttons, reset, speed, pause and step (the original's driving controls)."""

from __future__ import annotations

import json

from nicegui import events, ui

from create_sim.teleop import ANGULAR_STEP, LINEAR_STEP, MAX_ANGULAR_STEPS, MAX_LINEAR_STEPS
from studio.create.family import create_family
from studio.create.sim_tab import SimTab

RTF_OPTIONS = {0.25: "0.25×", 0.5: "0.5×", 1.0: "1× (real time)", 2.0: "2×", 4.0: "4×", 0.0: "as fast as possible"}
KEYS = {
    "ArrowUp": (1, 0),
    "w": (1, 0),
    "ArrowDown": (-1, 0),
    "s": (-1, 0),
    "ArrowLeft": (0, 1),
    "a": (0, 1),
    "ArrowRight": (0, -1),
    "d": (0, -1),
    " ": None,
    "Escape": None,
    "Enter": None,
}
"""Key → (linear steps, angular steps) change, None = stop: the keys of ``create_teleop``."""
REFOCUS_JS = (
    "<script>document.addEventListener('pointerup', (e) => {"
    " const c = e.target.closest && e.target.closest('button, .q-toggle, .q-checkbox, .q-btn');"
    " if (c) setTimeout(() => document.activeElement && document.activeElement.blur(), 0); });</script>"
)
"""Keys still drive after a click on a button, switch or checkbox: a clicked control gives the
focus back at once, so Space stops the robot instead of pressing Record again. Only typing in a
text field is left alone."""
NO_SCROLL_JS = (
    "<script>document.addEventListener('keydown', (e) => {"
    " const f = document.activeElement;"
    " if (!document.body.dataset.driving || e.ctrlKey || e.altKey || e.metaKey"
    "  || (f && ['INPUT', 'SELECT', 'TEXTAREA'].includes(f.tagName))) return;"
    " if (%s.includes(e.key.length > 1 ? e.key : e.key.toLowerCase())) e.preventDefault(); });</script>"
)
"""While the tab drives a robot, its driving keys do only that: the arrows and Space would also
scroll the page (Space a whole screen) away from the view the student watches."""


def command_steps(command: tuple[float, float]) -> list[int]:
    """The teleop steps (linear, angular) nearest to a world's last command (m/s, rad/s): a key
    press changes the speed the world was last given, by whichever tab, teleop or controller."""
    return [round(command[0] / LINEAR_STEP), round(command[1] / ANGULAR_STEP)]


class DrivePanel:
    """Driving the selected robot by hand, and its world's run controls."""

    def __init__(self, tab: SimTab) -> None:
        self.tab = tab
        self.driving = False  # what the page was last told (its keys scroll it while False)

    def show_driving(self) -> None:
        """Tell the page whether its keys drive a robot now (then they do not scroll it)."""
        driving = self.tab.picked() is not None
        if driving != self.driving:
            self.driving = driving
            ui.run_javascript(f"document.body.dataset.driving = {json.dumps('1' if driving else '')}")

    def listen_to_keys(self) -> None:
        """The arrows/WASD, space, Escape and Enter anywhere on the page but in a text field."""
        ui.add_body_html(REFOCUS_JS)
        ui.add_body_html(NO_SCROLL_JS % json.dumps(list(KEYS)))
        ui.keyboard(on_key=self.on_key, ignore=["input", "select", "textarea"])

    def build(self) -> None:
        """Manual control: arrows, joystick, Play/Advance/Reset, speed, pause and step."""
        with ui.card().classes("w-full"):
            ui.label("Manual control (arrows/WASD, space = stop)").classes("font-bold")
            with ui.row().classes("items-center gap-6"):
                with ui.grid(columns=3).classes("gap-1 w-40"):
                    ui.element()
                    self.drive_button("▲", 1, 0).classes("studio-forward")
                    ui.element()
                    self.drive_button("◀", 0, 1)
                    self.drive_button("■", 0, 0).props("color=red").classes("studio-stop")
                    self.drive_button("▶", 0, -1)
                    ui.element()
                    self.drive_button("▼", -1, 0)
                ui.joystick(on_move=self.on_joystick, on_end=lambda _: self.stop(), color="#1565c0", size=70).classes(
                    "w-28 h-28 bg-slate-100 rounded-full"
                )
            self.command_label = ui.label("v 0.00 m/s, ω 0.00 rad/s").classes("font-mono text-sm")
            with ui.row().classes("items-center gap-2"):
                ui.switch("Play", on_change=lambda e: self.press(0, e.value))
                ui.switch("Advance", on_change=lambda e: self.press(1, e.value))
                ui.button("Reset", on_click=self.reset).props("dense outline")
            with ui.row().classes("items-center gap-2"):
                self.rtf_select = ui.select(
                    RTF_OPTIONS, value=1.0, label="Speed (real_time_factor)", on_change=self.on_rtf
                ).classes("w-48 studio-rtf")
                self.pause_switch = ui.switch("Pause", on_change=self.on_pause).classes("studio-pause")
                ui.button("Step", on_click=self.step_once).props("dense outline").classes("studio-step")

    async def show_speed(self) -> None:
        """Show the selected world's speed (its ``real_time_factor``) in the speed selector."""
        ns = self.tab.picked()
        if ns is None:
            return
        try:
            rtf = await self.tab.ros.get_parameter(ns, "real_time_factor")
        except TimeoutError:
            return
        if rtf is not None and float(rtf) in RTF_OPTIONS and float(rtf) != self.rtf_select.value:
            self.rtf_select.set_value(float(rtf))

    # ---------------------------------------------------------------- driving
    def on_key(self, e: events.KeyEventArguments) -> None:
        # One step per press: a held key (auto-repeat) does not run the speed up to the limit.
        if not e.action.keydown or e.action.repeat or e.modifiers.ctrl or e.modifiers.alt or e.modifiers.meta:
            return
        name = e.key.name if len(e.key.name) > 1 else e.key.name.lower()
        if name not in KEYS:
            return
        change = KEYS[name]
        if change is None:
            self.stop()
        else:
            self.change(*change)

    def drive_button(self, text: str, linear: int, angular: int) -> ui.button:
        """An arrow button (■ = stop)."""

        def clicked() -> None:
            if linear or angular:
                self.change(linear, angular)
            else:
                self.stop()

        return ui.button(text, on_click=clicked).props("dense")

    def on_joystick(self, e: events.JoystickEventArguments) -> None:
        """Joystick: up/down = forward speed, left/right = turn rate, up to the teleop limits."""
        ns = self.tab.picked()
        if ns is None or e.x is None or e.y is None:
            return
        if self.controller_running():
            return
        v = round(e.y * MAX_LINEAR_STEPS * LINEAR_STEP, 2)
        w = round(-e.x * MAX_ANGULAR_STEPS * ANGULAR_STEP, 2)
        self.tab.ros.drive(ns, v, w)
        self.show_command((v, w))

    def controller_running(self) -> bool:
        child = create_family(self.tab.studio).controllers.get(self.tab.selected or "")
        return child is not None and child.running

    def change(self, linear: int, angular: int) -> None:
        st = self.tab.robot()
        if self.tab.selected is None or st is None:
            ui.notify("no robot selected", type="warning")
            return
        if self.controller_running():
            ui.notify("a controller is driving: Stop it for manual control", type="warning")
            return
        steps = command_steps(st.command)
        steps[0] = max(-MAX_LINEAR_STEPS, min(MAX_LINEAR_STEPS, steps[0] + linear))
        steps[1] = max(-MAX_ANGULAR_STEPS, min(MAX_ANGULAR_STEPS, steps[1] + angular))
        self.send(steps)

    def stop(self) -> None:
        if self.tab.selected is None or self.tab.robot() is None:
            return
        self.send([0, 0])

    def send(self, steps: list[int]) -> None:
        ns = self.tab.picked()
        if ns is None:
            return
        v, w = steps[0] * LINEAR_STEP, steps[1] * ANGULAR_STEP
        self.tab.ros.drive(ns, v, w)
        self.show_command((v, w))

    def show_command(self, command: tuple[float, float]) -> None:
        self.command_label.set_text(f"v {command[0]:.2f} m/s, ω {command[1]:.2f} rad/s")

    # ---------------------------------------------------------------- the world's buttons and run controls
    async def press(self, button: int, down: bool) -> None:
        ns = self.tab.picked()
        if ns is None:
            return
        try:
            ui.notify(await self.tab.ros.press(ns, button, down))
        except TimeoutError as err:
            ui.notify(str(err), type="negative")

    async def reset(self) -> None:
        ns = self.tab.picked()
        if ns is None:
            return
        try:
            ui.notify(await self.tab.ros.reset(ns))
        except TimeoutError as err:
            ui.notify(str(err), type="negative")
        st = self.tab.robot()
        if st is not None:
            st.track.clear()
            st.command = (0.0, 0.0)  # the reset world stands still

    async def on_pause(self, e: events.ValueChangeEventArguments) -> None:
        """Hold or release the selected world (its live ``paused`` parameter)."""
        ns = self.tab.picked()
        if ns is None:
            if e.value:  # nothing was paused: the switch must not say it was
                self.pause_switch.set_value(False)
                ui.notify("no robot selected", type="warning")
            return
        try:
            refused = await self.tab.ros.set_parameters(ns, {"paused": bool(e.value)})
        except TimeoutError as err:
            refused = [str(err)]
        for reason in refused:
            ui.notify(reason, type="negative")

    async def step_once(self) -> None:
        """One physics step of the paused world (SimulatorGUI's step)."""
        ns = self.tab.picked()
        if ns is None:
            return
        try:
            done, message = await self.tab.ros.step(ns)
        except TimeoutError as err:
            done, message = False, str(err)
        ui.notify(message, type="positive" if done else "negative")

    async def on_rtf(self, e: events.ValueChangeEventArguments) -> None:
        ns = self.tab.picked()
        if ns is None or e.value is None:
            return
        try:
            refused = await self.tab.ros.set_parameters(ns, {"real_time_factor": float(e.value)})
        except TimeoutError as err:
            refused = [str(err)]
        for reason in refused:
            ui.notify(reason, type="negative")
