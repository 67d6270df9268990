"""The Config maker page (the original's ConfigMakerGUI): noise per sensor and com_delay; load, save, apply."""

from __future__ import annotations

import warnings

from nicegui import ui

from create_sim.configfile import SENSORS, NoiseConfig, parse_config
from sim_runtime.errors import InputError
from studio.create.file_page import FilePage
from studio.shell.app import Studio
from studio.shell.kit import checked_number, nav

MEANINGS = {
    "wall": "offset of the IR range (m)",
    "cliff": "added to the signal (%)",
    "odometry": "proportional (0.02 = 2 %)",
    "sonar": "added to the distance (m)",
    "lidar": "added to each distance (m)",
    "camera": "proportional (distance and angle)",
}


def register(studio: Studio) -> None:
    @ui.page("/config")
    def config_maker_page() -> None:
        ConfigMakerPage(studio)


class ConfigMakerPage(FilePage):
    message_class = "studio-config-message"

    def __init__(self, studio: Studio) -> None:
        super().__init__(studio)
        self.fields: dict[str, tuple] = {}
        nav("/config")
        with ui.column().classes("p-4 gap-2"):
            ui.label("Noise: mean and standard deviation per sensor; all zero = an ideal robot").classes(
                "text-gray-700"
            )
            with ui.grid(columns=4).classes("items-center gap-x-4 gap-y-1"):
                for head in ("sensor", "mean", "std", "meaning"):
                    ui.label(head).classes("font-bold")
                for name in SENSORS:
                    ui.label(name)
                    mean = ui.number(value=0.0, format="%g", step=0.01).classes(f"w-28 studio-{name}-mean")
                    std = checked_number(value=0.0, format="%g", step=0.01, minimum=0.0).classes(
                        f"w-28 studio-{name}-std"
                    )
                    ui.label(MEANINGS[name]).classes("text-sm text-gray-600")
                    self.fields[name] = (mean, std)
                ui.label("com_delay")
                self.delay = checked_number(value=0.0, format="%g", step=0.01, minimum=0.0).classes(
                    "w-28 studio-com-delay"
                )
                ui.label("")
                ui.label("seconds, commands and readings").classes("text-sm text-gray-600")
            self.file_controls(
                "config file",
                "my.cfg",
                "config",
                "w-96",
                lambda: ui.button("Reset to zero", on_click=lambda: self.show(NoiseConfig())).props("dense outline"),
            )
            self.apply_controls("config")
        for field in (*(f for pair in self.fields.values() for f in pair), self.delay):
            field.on_value_change(self.note_draft)
        self.guard_drafts()

    def draft(self) -> object:
        try:
            return self.config().to_text()
        except InputError as err:  # a bad value is a change too
            return str(err)

    def config(self) -> NoiseConfig:
        """The form as a NoiseConfig; InputError naming the field for a bad value."""
        noise = {}
        for name, (mean, std) in self.fields.items():
            m, s = mean.value, std.value
            if m is None or s is None:
                raise InputError(f"{name}: mean and std need numbers")
            if s < 0:
                raise InputError(f"{name} std {s!r} must be >= 0")
            noise[name] = (float(m), float(s))
        delay = self.delay.value
        if delay is None or delay < 0:
            raise InputError(f"com_delay {delay!r} must be a number >= 0")
        return NoiseConfig(noise=noise, com_delay=float(delay))

    def show(self, config: NoiseConfig) -> None:
        for name, (mean, std) in self.fields.items():
            mean.set_value(config.noise[name][0])
            std.set_value(config.noise[name][1])
        self.delay.set_value(config.com_delay)

    def load(self) -> None:
        name = (self.file_name.value or "").strip()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                text, _ = self.studio.workspace.read_text(name, "config")
                config = parse_config(text, name)
            except InputError as err:
                self.say(f"error: {err}", error=True)
                return
        self.show(config)
        self.draft_saved()
        self.own_file = name
        notes = "; ".join(str(w.message) for w in caught)
        self.say(f"loaded {name}" + (f" (warnings: {notes})" if notes else ""), error=bool(notes))

    def save(self) -> bool:
        try:
            text = self.config().to_text()
        except InputError as err:  # a field that is not a number
            self.say(f"error: {err}", error=True)
            return False
        return self.save_text(text)

    async def apply_to_world(self) -> None:
        await self.apply_file("config_file", "config")
