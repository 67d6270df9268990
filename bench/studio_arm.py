"""Benchmark the Arm page's first draw in a real browser (Debian's headless Chromium).

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/studio_arm.py [--repeats 3]

The studio and an arm world run as processes of their own; Chromium opens ``/arm`` and a script
injected before the page's own measures, in the page:

- first draw: from navigation start to the frame in which all seven meshes are on the scene
  (goal for the IRB120: <= 2 s);
- the longest gap between two animation frames while loading (the page's worst stall), and
  the total of Chromium's long tasks (main thread busy > 50 ms at a stretch);
- the studio's worst answer time to a tiny HTTP request while the page loads (its event loop
  must not stall while a mesh is read and reduced).

Two worlds: the shipped IRB120, and the same arm with link 2 drawn by a generated 756k-face mesh
(RoboClass's largest model). Each is measured with the page's default display budget (50k faces
per mesh) and, as the baseline, with every face (``/arm?faces=0``); "cold" is the first page
after the world starts (the studio reads and reduces the file), "warm" the median of the next
ones (the studio's cache; the browser's HTTP cache is off throughout).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from _studio_support import CHROMEDRIVER, CHROMIUM, free_port, use_local_ros  # noqa: E402
from _studio_support import new_driver as shared_driver  # noqa: E402

use_local_ros()

from studio.arm.meshes import DISPLAY_FACES, binary_stl  # noqa: E402

GOAL_FIRST_DRAW_S = 2.0
DENSE_FACES = 756_290
MESHES = 7

PROBE_JS = """
window.__bench = {drawn: null, maxGap: 0, longTasks: 0, longest: 0};
(function loop(last) {
  requestAnimationFrame((t) => {
    const b = window.__bench;
    if (b.drawn === null || t - b.drawn < 1000) {
      if (last) b.maxGap = Math.max(b.maxGap, t - last);
      const el = document.querySelector('.studio-arm-view');
      const scene = el && window['scene_' + el.id];
      if (scene && b.drawn === null) {
        let n = 0;
        scene.traverse((o) => {
          if (o.isMesh && o.parent && o.parent.name && o.parent.name.includes('/meshes/')) n++;
        });
        if (n >= MESHES) b.drawn = performance.now();
      }
    }
    loop(t);
  });
})(0);
try {
  new PerformanceObserver((list) => list.getEntries().forEach((e) => {
    window.__bench.longTasks += e.duration; window.__bench.longest = Math.max(window.__bench.longest, e.duration);
  })).observe({type: 'longtask', buffered: true});
} catch (e) {}
""".replace("MESHES", str(MESHES))


def dense_mesh(faces: int, radius: float = 0.06) -> np.ndarray:
    """A bumpy sphere of about ``faces`` triangles (F, 3, 3) float32: a stand-in for a CAD export."""
    n = int(round((faces / 2) ** 0.5))
    theta, phi = np.linspace(0.0, np.pi, n + 1), np.linspace(0.0, 2.0 * np.pi, n + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    r = radius * (1.0 + 0.05 * np.sin(8 * t) * np.cos(6 * p))
    v = np.stack([r * np.sin(t) * np.cos(p), r * np.sin(t) * np.sin(p), r * np.cos(t)], axis=-1)
    a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
    return np.concatenate(
        [np.stack([a, b, c], axis=2).reshape(-1, 3, 3), np.stack([a, c, d], axis=2).reshape(-1, 3, 3)]
    ).astype(np.float32)


def dense_config(folder: Path) -> Path:
    """The IRB120 config with link 2 drawn by a ~756k-face mesh."""
    mesh = folder / "dense_link2.stl"
    triangles = dense_mesh(DENSE_FACES)
    triangles[:, :, 0] += 0.135  # along link 2, roughly where its own mesh is
    mesh.write_bytes(binary_stl(triangles))
    text = (ROOT / "config" / "arm" / "irb120.yaml").read_text()
    text = text.replace("mesh_folder: meshes/irb120", f"mesh_folder: {ROOT / 'config' / 'arm' / 'meshes' / 'irb120'}")
    text = text.replace("mesh: IRB120_link2.stl", f"mesh: {mesh}")
    config = folder / "irb120_dense.yaml"
    config.write_text(text)
    print(f"generated {len(triangles):,} faces in {mesh} ({mesh.stat().st_size / 1e6:.1f} MB)", flush=True)
    return config


class ServerProbe:
    """Asks the studio for a missing mesh every 20 ms: the slowest answer is its worst stall."""

    def __init__(self, url: str) -> None:
        self.url = url + "/studio/mesh/none.stl"
        self.worst = 0.0
        self.running = True
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self) -> None:
        while self.running:
            start = time.perf_counter()
            with contextlib.suppress(urllib.error.HTTPError):  # the answer is a 404: only its time counts
                urllib.request.urlopen(self.url, timeout=30).read()
            self.worst = max(self.worst, time.perf_counter() - start)
            time.sleep(0.02)

    def stop(self) -> float:
        self.running = False
        self.thread.join()
        return self.worst


def open_arm_page(driver, url: str, faces: int) -> dict:
    probe = ServerProbe(url)
    driver.get(f"{url}/arm?faces={faces}")
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline:
        b = driver.execute_script("return window.__bench && window.__bench.drawn !== null && window.__bench")
        if b:
            time.sleep(1.1)  # the stall window runs one second past the first draw
            b = driver.execute_script("return window.__bench")
            b["server_worst"] = probe.stop()
            return b
        time.sleep(0.05)
    probe.stop()
    raise TimeoutError(f"the arm page did not draw {MESHES} meshes within 120 s")


def new_driver():
    """Headless Chromium with its cache off (every load is the studio's work) and the page probe."""
    driver = shared_driver(1000)
    driver.execute_cdp_cmd("Network.enable", {})
    driver.execute_cdp_cmd("Network.setCacheDisabled", {"cacheDisabled": True})
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": PROBE_JS})
    return driver


def wait_for_port(port: int) -> None:
    for _ in range(600):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
            return
        except OSError:
            time.sleep(0.1)


def measure_world(driver, url: str, folder: Path, name: str, config: str, repeats: int, env: dict) -> list[tuple]:
    """Start an arm world with ``config``, wait until the studio follows it, and time the arm page
    at both display budgets: rows (world, faces, cold run, warm runs, load)."""
    code = "import sys; from sim_tools.cli import run; sys.exit(run('arm', sys.argv[1:]))"
    world = subprocess.Popen(
        [sys.executable, "-c", code, "--ros-args", "-p", f"robot_config_file:={config}"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    rows = []
    try:
        for _ in range(600):  # until the studio follows it
            if "following the arm" in (folder / "studio.log").read_text().split("has gone")[-1]:
                break
            time.sleep(0.1)
        time.sleep(1.0)  # its markers have arrived
        for faces in (DISPLAY_FACES, 0):
            cold = open_arm_page(driver, url, faces)
            warm = [open_arm_page(driver, url, faces) for _ in range(repeats)]
            rows.append((name, faces, cold, warm, os.getloadavg()[0]))
            print_case(name, faces, cold, warm)
    finally:
        world.terminate()
        world.wait(timeout=20)
        time.sleep(3.0)  # the studio forgets it
    return rows


def print_case(name: str, faces: int, cold: dict, warm: list[dict]) -> None:
    def w(key: str) -> float:
        return statistics.median(r[key] for r in warm)

    print(
        f"{name:26s} {'every face' if faces == 0 else f'{faces // 1000}k/mesh':>10s}: "
        f"first draw cold {cold['drawn'] / 1000:.2f} s, warm {w('drawn') / 1000:.2f} s; "
        f"longest frame gap {w('maxGap'):.0f} ms, long tasks {w('longTasks'):.0f} ms, "
        f"studio worst answer {cold['server_worst'] * 1000:.0f} ms cold / "
        f"{w('server_worst') * 1000:.0f} ms warm (load {os.getloadavg()[0]:.1f})",
        flush=True,
    )


def print_summary(worlds: dict[str, str], rows: list[tuple]) -> None:
    print("\nside by side (warm medians; ratio = every face / display budget):")
    by = {(r[0], r[1]): r for r in rows}
    for name in worlds:
        budget, full = by[(name, DISPLAY_FACES)], by[(name, 0)]
        for key, label, scale in (
            ("drawn", "first draw (s)", 1000),
            ("maxGap", "longest frame gap (ms)", 1),
            ("longTasks", "long tasks total (ms)", 1),
        ):
            b = statistics.median(r[key] for r in budget[3]) / scale
            f = statistics.median(r[key] for r in full[3]) / scale
            print(f"  {name:26s} {label:24s} budget {b:8.2f}  every face {f:8.2f}  ratio {f / max(b, 1e-9):5.1f}")
    irb = statistics.median(r["drawn"] for r in by[("IRB120", DISPLAY_FACES)][3]) / 1000
    verdict = "met" if irb <= GOAL_FIRST_DRAW_S else "NOT met"
    print(f"goal: IRB120 first draw <= {GOAL_FIRST_DRAW_S:g} s: {verdict} ({irb:.2f} s)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3, help="warm page loads per case (default 3)")
    args = parser.parse_args()
    if not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()):
        print("bench/studio_arm.py skipped: needs Debian's chromium and chromium-driver (apt-get install -y ...)")
        return 0
    folder = Path(tempfile.mkdtemp(prefix="studio_arm_bench_"))
    worlds = {"IRB120": "arm/irb120.yaml", "IRB120 + 756k-face link": str(dense_config(folder))}
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    log = (folder / "studio.log").open("w")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    studio = subprocess.Popen(
        [sys.executable, "-m", "studio", "--workspace", str(folder), "--port", str(port)],
        cwd=ROOT,
        stdout=log,
        stderr=subprocess.STDOUT,
        env=env,
    )
    driver = new_driver()
    rows = []
    try:
        wait_for_port(port)
        for name, config in worlds.items():
            rows += measure_world(driver, url, folder, name, config, args.repeats, env)
    finally:
        driver.quit()
        studio.terminate()
        studio.wait(timeout=20)
        log.close()
    print_summary(worlds, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
