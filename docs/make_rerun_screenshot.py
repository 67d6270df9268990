"""Regenerate the Rerun screenshots in docs/: each demo's views at its start, middle and end.

Run from the repository root: ``make screenshots``, or::

    .venv/bin/python docs/make_rerun_screenshot.py [DEMO_DIR]

DEMO_DIR is a ``make demo`` output folder (``out/demo/<time>``) holding ``<demo>_bag``
folders; without it the three demos are recorded first. Each bag is converted by
``bag_to_rerun`` and opened in a headless Rerun viewer (``rerun --headless``: no window, no X
server) that the script drives with ``rerun.experimental.ViewerClient``: it picks each tab,
sets the time and asks the viewer for a screenshot. The viewer needs a Vulkan driver; without a
GPU, Mesa's software one: ``apt-get install mesa-vulkan-drivers``. It runs with a private
config home where usage analytics are disabled.

Writes, per demo: ``docs/rerun_<demo>.png`` (the whole viewer at the end of the run, as it opens)
and ``docs/rerun_<demo>_views.png`` (every map or 3-D view at start, middle and end).
"""

from __future__ import annotations

import io
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from PIL import Image, ImageDraw

from sim_tools.rerun_view.analytics import private_rerun_env, rerun_cli
from sim_tools.rerun_view.convert import bag_to_rerun

DOCS = Path(__file__).resolve().parent
DEMOS = ("create", "simrobot", "arm")
WINDOW = (1600, 1000)
FULL_WIDTH = 1400
"""Pixels across of the whole-viewer screenshots kept in docs/."""
TILE = 420
"""Longest side of one view's screenshot in the start/middle/end sheets."""
MOMENTS = (("start", 0.03), ("middle", 0.5), ("end", 1.0))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class HeadlessViewer:
    """A ``rerun --headless`` process and a ViewerClient connected to it."""

    def __init__(self, home: Path) -> None:
        from rerun.experimental import ViewerClient

        env = private_rerun_env(home)
        env["XDG_RUNTIME_DIR"] = str(home)
        self.port = _free_port()
        size = f"{WINDOW[0]}x{WINDOW[1]}"
        cmd = [rerun_cli(), "--headless", "--port", str(self.port), "--window-size", size, "--hide-welcome-screen"]
        # A session of its own: the venv's ``rerun`` is a Python wrapper that starts the viewer
        # binary as a child, which must be stopped with it.
        self.process = subprocess.Popen(
            cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
        )
        url = f"rerun+http://127.0.0.1:{self.port}/proxy"
        deadline = time.monotonic() + 60
        while True:
            try:
                self.client = ViewerClient.connect(url)
                self.client.get_state()
                break
            except (ConnectionError, RuntimeError, TimeoutError):
                if time.monotonic() > deadline or self.process.poll() is not None:
                    self.close()  # not left running when we give up
                    raise
                time.sleep(0.5)

    def close(self) -> None:
        """Stop the wrapper and the viewer it started (its process group)."""
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(self.process.pid, sig)
                self.process.wait(timeout=10)
                return
            except ProcessLookupError:
                return
            except subprocess.TimeoutExpired:
                continue


def _show_tab(viewer, view_id: str) -> None:
    """Make ``view_id`` the active tab of its container (a hidden tab cannot be screenshot)."""
    bp = viewer.client.get_blueprint()
    changed = False
    for value in bp.blueprint.values():
        container = value.get("ContainerBlueprint")
        if container and f"/view/{view_id}" in container.get("contents", []):
            changed |= container.get("active_tab") != f"/view/{view_id}"
            container["active_tab"] = f"/view/{view_id}"
    if changed:
        viewer.client.set_blueprint(bp.blueprint, store_id=bp.store_id)


def _settled(client, view_id: str | None = None, max_size: int | None = None) -> bytes:
    """A screenshot once the picture stops changing: the viewer fetches a recording's chunks on
    demand, so right after a time change some entities are not drawn yet."""
    previous = None
    deadline = time.monotonic() + 60
    while True:
        try:
            png = client.take_screenshot(view_id, max_size=max_size)
        except TimeoutError:  # a busy machine: the software renderer is slow, ask again
            if time.monotonic() > deadline:
                raise
            continue
        if png == previous or (previous is not None and time.monotonic() > deadline):
            return png
        previous = png
        time.sleep(1.0)


def _png(data: bytes) -> Image.Image:
    return Image.open(io.BytesIO(data)).convert("RGB")


def screenshots(viewer: HeadlessViewer, rrd: Path, name: str) -> list[Path]:
    """Open ``rrd``; write the whole viewer at the end and a sheet of every spatial view."""
    client = viewer.client
    opened = client.open(str(rrd.resolve()))
    store = opened.store_ids[0]
    deadline = time.monotonic() + 60
    state = client.get_state()
    while not state.views or state.loading:
        if time.monotonic() > deadline:
            raise RuntimeError(f"{rrd}: the viewer did not finish loading")
        time.sleep(0.5)
        state = client.get_state()
    recording = next(r for r in state.recordings if r.store_id == store)
    timeline = next(t for t in recording.timelines if t.name == "sim_time")
    start, end = timeline.start or 0, timeline.end or 0

    def at(fraction: float) -> None:
        client.set_time("sim_time", duration=(start + fraction * (end - start)) / 1e9, play_state="paused")

    written = []
    opening = client.get_blueprint()  # the layout as the recording opens, restored at the end
    # the map first, then each robot's view by name
    spatial = [v for v in state.views if v.view_class in ("2D", "3D")]
    spatial.sort(key=lambda v: (not v.name.startswith("Map"), v.name))
    rows = []
    for view in spatial:
        _show_tab(viewer, view.view_id)
        tiles = []
        for label, fraction in MOMENTS:
            at(fraction)
            tiles.append((label, _png(_settled(client, view.view_id, TILE))))
        rows.append((view.name, tiles))
    path = DOCS / f"rerun_{name}_views.png"
    _sheet(rows).save(path, optimize=True)
    written.append(path)

    # The whole viewer as it opens (first tab, end of the run), taken last: the viewer's start-up
    # notifications have faded by now.
    client.set_blueprint(opening.blueprint, store_id=opening.store_id)
    at(1.0)
    full = _png(_settled(client))
    full = full.resize((FULL_WIDTH, round(full.height * FULL_WIDTH / full.width)), Image.LANCZOS)
    path = DOCS / f"rerun_{name}.png"
    full.save(path, optimize=True)
    written.append(path)
    client.close(store_ids=[store])
    return written


def _sheet(rows: list[tuple[str, list[tuple[str, Image.Image]]]]) -> Image.Image:
    """Rows of tiles (one row per view: start, middle, end) with a caption above each."""
    caption = 22
    width = max(sum(t.width for _, t in tiles) + 8 * (len(tiles) + 1) for _, tiles in rows)
    height = sum(max(t.height for _, t in tiles) + caption + 8 for _, tiles in rows) + 8
    sheet = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(sheet)
    y = 8
    for view_name, tiles in rows:
        x = 8
        for moment, tile in tiles:
            draw.text((x, y + 4), f"{view_name}: {moment}", fill="black")
            sheet.paste(tile, (x, y + caption))
            x += tile.width + 8
        y += max(t.height for _, t in tiles) + caption + 8
    return sheet


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with tempfile.TemporaryDirectory() as tmp:
        if args:
            demo_dir = Path(args[0])
        else:
            from sim_tools.demo import main as run_demos

            run_demos(["-o", tmp])
            demo_dir = next(p for p in Path(tmp).iterdir() if p.is_dir())
        for name in DEMOS:
            bag = demo_dir / f"{name}_bag"
            if not bag.exists():
                print(f"no {bag}; skipped", file=sys.stderr)
                continue
            rrd = bag_to_rerun(bag, Path(tmp) / f"{name}.rrd", progress=False)
            # A viewer per recording: the viewer keeps one blueprint per application, so a second
            # recording would open in the first one's layout.
            viewer = HeadlessViewer(Path(tmp) / "rerun_home")
            try:
                for path in screenshots(viewer, rrd, name):
                    print(f"wrote {path}", file=sys.stderr)
            finally:
                viewer.close()


if __name__ == "__main__":
    main()
