"""The Output page: what each world, controller, recorder and Octave program the studio started
has printed, for the student who started it (in a JupyterHub the studio's own output goes to the
hub's log, which students never see). The last lines of each are kept in memory; the whole output
is in the log file named under it, in the workspace's hidden ``.robot_sims/output/`` folder."""

from __future__ import annotations

from studio.shell.processes import PROCESSES, Child

SHOWN_LINES = 400  # the page shows the last lines; the log file has them all
REFRESH_S = 1.0


def state(child: Child) -> str:
    """``running`` or how it ended, as the process list says it."""
    if child.running:
        return "running"
    return f"ended, exit status {child.process.returncode}"


def choice_label(child: Child) -> str:
    return f"{child.label} (pid {child.process.pid}, {state(child)})"


def shown_text(child: Child) -> str:
    lines = list(child.output)[-SHOWN_LINES:]
    return "\n".join(lines) if lines else "(nothing printed yet)"


class OutputView:
    """A process picker (newest first) and its output, brought up to date every second while the
    page is open (only when something changed)."""

    def __init__(self, wanted: int | None) -> None:
        self.wanted = wanted  # the pid asked for in the address (?pid=…), else the newest
        self.shown: tuple[object, ...] = ()

    def build(self) -> None:
        from nicegui import ui

        with ui.column().classes("w-full px-4 gap-2"):
            ui.label("Output of the programs the studio started").classes("text-lg font-bold")
            self.select = (
                ui.select({}, label="process", on_change=lambda _e: self.refresh())
                .classes("w-[40rem] studio-output-select")
                .props("dense")
            )
            self.file = ui.label("").classes("text-sm text-slate-600 break-all studio-output-file")
            self.text = (
                ui.label("")
                .classes("w-full text-xs font-mono bg-slate-50 p-2 overflow-auto studio-output-text")
                .style("max-height: 70vh; white-space: pre-wrap")
            )
        self.refresh()
        ui.timer(REFRESH_S, self.refresh)

    def refresh(self) -> None:
        children = PROCESSES.listed()
        options = {child.process.pid: choice_label(child) for child in children}
        if options != self.select.options:
            self.select.set_options(options)
        if self.select.value not in options and children:
            pids = [child.process.pid for child in children]
            self.select.set_value(self.wanted if self.wanted in pids else pids[0])
        child = next((c for c in children if c.process.pid == self.select.value), None)
        if child is None:
            self.show(("none",), "", "Nothing started yet: worlds, controllers and recorders started here show here.")
            return
        where = f"whole output: {child.log_file}" if child.log_file else "no log file"
        self.show((child.process.pid, child.line_count, child.running), where, shown_text(child))

    def show(self, key: tuple[object, ...], where: str, text: str) -> None:
        if key == self.shown:
            return
        self.shown = key
        self.file.set_text(where)
        self.text.set_text(text)


def register() -> None:
    """The ``/output`` page (every child of the studio is in :data:`PROCESSES`)."""
    from nicegui import ui

    from studio.shell.kit import nav

    @ui.page("/output")
    def output_page(pid: int | None = None) -> None:
        nav("/output")
        OutputView(pid).build()
