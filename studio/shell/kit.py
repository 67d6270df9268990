"""The studio's UI kit: what pages of every family share (navigation, number fields, the pan/zoom
drawing area, the unsaved-draft guard, stopping a world the studio started). NiceGUI is imported
where a widget is made, so the logic here is tested without it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from studio.shell.processes import Child

WHEEL_JS = "(e) => emit({dy: e.deltaY, x: e.offsetX, y: e.offsetY, w: e.target.clientWidth, h: e.target.clientHeight})"
"""A view's wheel events, reduced to what zooming needs (pixel position, scroll direction)."""


async def stop_started_world(worlds: dict[str, Child], key: str) -> None:
    """Stop the world the studio started under ``key`` in ``worlds``, or say it cannot (a world
    started in another terminal is stopped there).

    The wait for the world to end (up to 5 s, then SIGKILL) runs off the event loop, so every
    other tab goes on meanwhile; the world stays in its table until it has ended, so no new
    world starts in its namespace while it still publishes there."""
    import asyncio

    from nicegui import ui

    child = worlds.get(key)
    if child is None:
        ui.notify("this world was not started by the studio (stop it where it runs)", type="warning")
        return
    if child.stopping:
        ui.notify(f"{child.label} is stopping")
        return
    child.stopping = True
    ui.notify(f"stopping {child.label}…")
    try:
        await asyncio.to_thread(child.stop)
    finally:
        if worlds.get(key) is child:
            del worlds[key]
    ui.notify(f"{child.label} stopped")


UNSAVED_GUARD = (
    "<script>window.addEventListener('beforeunload', (e) => {"
    " if (window.studioUnsaved) { e.preventDefault(); e.returnValue = ''; } });</script>"
)
"""The browser asks before a reload or a closed tab drops a draft the page has marked unsaved."""


class DraftGuard:
    """A page whose draft (a map, a config, a world) can be unsaved: it says what its draft is
    (:meth:`draft`); :meth:`note_draft` after each edit tells the browser whether leaving the page
    would lose it, :meth:`draft_saved` after a load or save."""

    saved_draft: object = None
    unsaved = False

    def draft(self) -> object:
        raise NotImplementedError

    def guard_drafts(self) -> None:
        """On building the page: the browser's warning, and the draft as it starts (nothing to lose)."""
        from nicegui import ui

        ui.add_body_html(UNSAVED_GUARD)
        self.saved_draft = self.draft()

    def note_draft(self) -> None:
        unsaved = self.draft() != self.saved_draft
        if unsaved != self.unsaved:
            from nicegui import ui

            self.unsaved = unsaved
            ui.run_javascript(f"window.studioUnsaved = {'true' if unsaved else 'false'}")

    def draft_saved(self) -> None:
        self.saved_draft = self.draft()
        self.note_draft()


def checked_number(label: str | None = None, *, minimum: float, **kwargs: Any):
    """A number field that keeps a value below ``minimum`` and marks it (:func:`at_least`); no
    space is kept under it for the message until there is one (fields in a row stay aligned)."""
    from nicegui import ui

    return ui.number(label, validation=at_least(minimum), **kwargs).props("hide-bottom-space")


def at_least(minimum: float) -> dict:
    """A number field's ``validation``: a value below ``minimum`` stays in the field, in red with
    this message, and the page's check refuses it (a ``min`` would silently clamp it, and that
    clamped value would be saved)."""
    return {f"must be ≥ {minimum:g}": lambda value: value is None or value >= minimum}


VIEW_SIZE = (800, 600)
"""Pixels of the simulator's and the map maker's drawing area."""


def view_image(on_mouse, on_wheel, css_class: str, background: str):
    """The pan/zoom SVG drawing area both the simulator and the map maker draw on."""
    from nicegui import ui

    image = (
        ui.interactive_image(
            size=VIEW_SIZE, events=["mousedown", "mousemove", "mouseup"], on_mouse=on_mouse, sanitize=False
        )
        .classes(css_class)
        .style(f"width:{VIEW_SIZE[0]}px;height:{VIEW_SIZE[1]}px;background:{background};outline:1px solid #bbb")
    )
    image.on("wheel.prevent", on_wheel, js_handler=WHEEL_JS, throttle=0.05)
    return image


def wheel_zoom(view, args: dict) -> bool:
    """Zoom ``view`` about the pixel under the mouse for a wheel event from :func:`view_image`
    (its ``args``: the pointer and the image's drawn size); False when the event had no size."""
    if not (args.get("w") and args.get("h")):
        return False
    px, py = args["x"] * VIEW_SIZE[0] / args["w"], args["y"] * VIEW_SIZE[1] / args["h"]
    view.zoom_at(px, py, 1 / 1.2 if args["dy"] > 0 else 1.2)
    return True


class ZoomableView:
    """Zoom buttons, the mouse wheel and layer checkboxes of a page that draws ``view`` on
    :func:`view_image`; the page says how it redraws in :meth:`view_changed`."""

    view: Any
    layers: set[str]

    def view_changed(self) -> None:
        raise NotImplementedError

    def zoom(self, factor: float) -> None:
        self.view.zoom(factor)
        self.view_changed()

    def on_wheel(self, e) -> None:
        if wheel_zoom(self.view, e.args):
            self.view_changed()

    def toggle_layer(self, key: str, on: bool) -> None:
        (self.layers.add if on else self.layers.discard)(key)
        self.view_changed()


PAGES = (
    ("/", "Simulator", "the Create simulator: live view, driving, worlds, controllers, Save Data (SimulatorGUI)"),
    ("/map", "Map maker", "draw, load and save Create maps, apply one to a running world (MapMakerGUI)"),
    ("/config", "Config maker", "the Create's sensor noise and delays (ConfigMakerGUI)"),
    ("/simrobot", "SIMROBOT", "the SIMROBOT simulator: worlds of robots with their sensors and algorithms"),
    ("/simrobot/editor", "SIMROBOT editor", "SIMROBOT worlds: the map bitmap, robots, sensors, algorithms"),
    ("/arm", "Arm", "arm worlds (IRB120, CSA7, scenes): joints, target poses, trajectories"),
    ("/replay", "Replay", "a recorded bag of any world, played or stepped (ReplayGUI)"),
    ("/submit", "Submit", "hand in a workspace file as a controller for a course's assignment"),
    ("/output", "Output", "what the worlds, controllers, recorders and Octave programs started here printed"),
)
"""Every page: its address, its link text and what it is (the original window it stands for)."""


def pages_help() -> str:
    """The pages, as ``studio --help`` lists them."""
    return "pages (the originals' windows):\n" + "\n".join(
        f"  {text:<16} {target:<17} {what}" for target, text, what in PAGES
    )


def nav(current: str) -> None:
    """The links between the pages (the originals' windows)."""
    from nicegui import ui

    with ui.row().classes("items-center gap-6 w-full bg-slate-100 px-4 py-1"):
        ui.label("robot_sims studio").classes("text-lg font-bold")
        for target, text, _what in PAGES:
            link = ui.link(text, target).classes("text-base")
            if target == current:
                link.classes("font-bold no-underline")
