"""Hostile inputs: how long and how much memory refusing a YAML alias bomb takes, and a
1,000,000-wall Create map's time to "ready" and Ctrl-C latency during its start-up.

Run:  .venv/bin/python bench/hostile_inputs.py [--walls 1000000] [--interrupt-at 3] [--skip-map]

Alias bombs: a 10-level bomb (10 aliases a level: 10^10 values in ~400 bytes) at a key of each YAML
format, loaded by its loader in a fresh process (``python -c``); the figure is that process's wall
time from start to exit, minus an empty process's, and its peak memory (``ru_maxrss``).

The map: ``--walls`` random walls (0.5 m long, over 200 m x 200 m) written to a temporary map,
then ``robot_sims create_world`` started on it as a user does: the time from launch to its "ready"
line, the CPU seconds its process used by then, and its progress lines; then started again and
sent SIGINT ``--interrupt-at`` seconds after its first progress line: the time from the signal to
the process's exit. Wall times stretch on a loaded machine (the load is printed beside them; the CPU
seconds say what the work costs).
"""

from __future__ import annotations

import argparse
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
PYTHON = sys.executable
EXE = str(Path(PYTHON).with_name("robot_sims"))

BOMB_CASES = {
    "simrobot world (robots[0].color)": (
        "from simrobot_sim.world_file import load_world as load",
        {"map": str(ROOT / "config/simrobot/demo_map.png"), "robots": [{"name": "r", "position": [0.5, 0.5]}]},
        ("robots", 0, "color"),
    ),
    "simrobot world (map)": (
        "from simrobot_sim.world_file import load_world as load",
        {"map": "m.png", "robots": [{"name": "r", "position": [0.5, 0.5]}]},
        ("map",),
    ),
    "arm config (name)": ("from arm_sim.robot_config import load_robot_config as load", None, ("name",)),
    "arm config (dh.theta)": ("from arm_sim.robot_config import load_robot_config as load", None, ("dh", "theta")),
    "arm scene (objects)": ("from arm_sim.scene import load_scene as load", {"objects": []}, ("objects",)),
    "joint trajectory (points)": (
        "from arm_sim.trajectory_file import load_trajectory as load",
        {"points": [{"time": 1, "positions": [0]}]},
        ("points", 0, "positions"),
    ),
    "sweep (seeds)": (
        "from sim_tools.batch.sweep import load_sweep as load",
        {"worlds": [{"map": str(ROOT / "config/create/example.map")}], "controllers": ["create_bump_turn"]},
        ("seeds",),
    ),
}


def load_average() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load {one:.1f} {five:.1f} {fifteen:.1f}"


def run_child(code: str) -> tuple[float, float, str]:
    """(wall s, peak MB, last stderr line) of ``python -c code``."""
    start = time.monotonic()
    child = subprocess.Popen([PYTHON, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _pid, _status, usage = os.wait4(child.pid, 0)
    wall = time.monotonic() - start
    err = child.stderr.read() if child.stderr else ""
    child.returncode = os.waitstatus_to_exitcode(_status)
    return wall, usage.ru_maxrss / 1024.0, (err.strip().splitlines() or [""])[-1]


def bench_bombs(folder: Path) -> None:
    import yaml

    from sim_tools.fuzz_kit.mutate import bombed_yaml

    arm = yaml.safe_load((ROOT / "config/arm/irb120.yaml").read_text())
    arm["mesh_folder"] = str(ROOT / "config/arm" / arm.get("mesh_folder", "."))
    base_wall, base_mb, _ = run_child("import yaml, numpy")
    print(f"empty process: {base_wall:.2f} s, {base_mb:.0f} MB ({load_average()})")
    print(f"{'10-level alias bomb at':<36}{'refused in':>12}{'peak MB (+ in load)':>20}{'chars':>6}  message")
    for name, (imports, tree, path) in BOMB_CASES.items():
        file = folder / "bomb.yaml"
        file.write_text(bombed_yaml(tree if tree is not None else arm, path))
        code = (
            f"import sys, time, resource\n{imports}\nfrom sim_runtime.errors import InputError\n"
            "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\nt = time.perf_counter()\n"
            f"try:\n    load({str(file)!r})\n    text = 'LOADED'\nexcept InputError as e:\n    text = str(e)\n"
            "dt = time.perf_counter() - t\n"
            "grew = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024\n"
            "print(f'{dt:.4f} {grew:.1f} {len(text)} {text[:90]}', file=sys.stderr)"
        )
        _wall, mb, line = run_child(code)
        dt, grew, chars, text = [*line.split(" ", 3), "0", "0", "0", ""][:4]
        print(f"{name:<36}{float(dt) * 1000:>9.1f} ms{mb:>8.0f} (+{float(grew):.0f}){chars:>6}  {text}")


def write_map(path: Path, walls: int) -> None:
    rng = np.random.default_rng(7)
    start = rng.uniform(-100.0, 100.0, (walls, 2))
    end = start + rng.normal(0.0, 0.5, (walls, 2))
    rows = np.hstack([start, end])
    with path.open("w") as f:
        f.write(f"% {walls} random walls\n")
        np.savetxt(f, rows, fmt="wall %.4f %.4f %.4f %.4f")


class World:
    """``robot_sims create_world`` on a map, its log lines collected as they come."""

    def __init__(self, map_path: Path) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "RCUTILS_LOGGING_BUFFERED_STREAM": "0"}
        args = ["-p", f"map_file:={map_path}", "-p", "initial_pose:=[150.0, 150.0, 0.0]"]
        self.started = time.monotonic()
        self.process = subprocess.Popen(
            [EXE, "create_world", "--ros-args", *args],
            stderr=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        self.lines: list[tuple[float, str]] = []
        self.ready = threading.Event()
        self.progress = threading.Event()
        for stream in (self.process.stderr, self.process.stdout):
            threading.Thread(target=self._read, args=(stream,), daemon=True).start()

    def _read(self, stream) -> None:
        for line in stream:
            self.lines.append((time.monotonic() - self.started, line.rstrip()))
            if "so far)" in line:
                self.progress.set()
            if "ready:" in line:
                self.ready.set()

    def cpu_seconds(self) -> float:
        try:
            with open(f"/proc/{self.process.pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except OSError:
            return float("nan")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def bench_map(folder: Path, walls: int, interrupt_at: float) -> None:
    map_path = folder / "walls.map"
    write_map(map_path, walls)
    print(f"\n{walls:,}-wall map: {map_path.stat().st_size / 1e6:.0f} MB ({load_average()})")
    world = World(map_path)
    try:
        ready = world.ready.wait(timeout=600)
        wall, cpu = time.monotonic() - world.started, world.cpu_seconds()
        for at, line in world.lines:
            if "so far)" in line or "ready" in line or "warn" in line.lower():
                print(f"  {at:6.1f} s  {line[:140]}")
        print(f"time to ready: {wall:.1f} s wall, {cpu:.1f} s CPU ({load_average()})" if ready else "never ready")
    finally:
        world.stop()
    world = World(map_path)
    try:
        if not world.progress.wait(timeout=300):
            print("no progress line to interrupt after")
            return
        time.sleep(interrupt_at)
        if world.ready.is_set():
            print("ready before the interrupt: use a smaller --interrupt-at")
            return
        sent = time.monotonic()
        world.process.send_signal(signal.SIGINT)
        code = world.process.wait(timeout=120)
        latency = time.monotonic() - sent
        tail = world.lines[-1][1] if world.lines else ""
        print(f"Ctrl-C during start-up: exited {latency:.2f} s after SIGINT, status {code} ({tail[:80]})")
        print(f"  ({load_average()})")
    finally:
        world.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walls", type=int, default=1_000_000)
    parser.add_argument("--interrupt-at", type=float, default=3.0, help="seconds after the first progress line")
    parser.add_argument("--skip-map", action="store_true")
    parser.add_argument("--skip-bombs", action="store_true")
    options = parser.parse_args()
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        if not options.skip_bombs:
            bench_bombs(Path(tmp))
        if not options.skip_map:
            bench_map(Path(tmp), options.walls, options.interrupt_at)


if __name__ == "__main__":
    main()
