"""A huge world starts visibly and stops on Ctrl-C while it starts (a subprocess, as users run it)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from sim_runtime.world_node import startup_phase

CEILING_S = 60.0  # a busy machine's ceiling; the world stops within a kernel chunk of the signal


def _million_wall_map(path: Path) -> None:
    rng = np.random.default_rng(3)
    start = rng.uniform(-100.0, 100.0, (1_000_000, 2))
    with path.open("w") as f:
        np.savetxt(f, np.hstack([start, start + rng.normal(0.0, 0.5, start.shape)]), fmt="wall %.4f %.4f %.4f %.4f")


def test_ctrl_c_while_a_million_wall_world_starts_ends_it_cleanly(tmp_path):
    map_path = tmp_path / "million.map"
    _million_wall_map(map_path)
    exe = Path(sys.executable).with_name("robot_sims")
    world = subprocess.Popen(
        [str(exe), "create_world", "--ros-args", "-p", f"map_file:={map_path}", "-p", "initial_pose:=[150.0,0.0,0.0]"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1", "RCUTILS_LOGGING_BUFFERED_STREAM": "0"},
    )
    lines: list[str] = []
    reading = threading.Event()

    def read() -> None:
        assert world.stdout is not None
        for line in world.stdout:
            lines.append(line)
            if "reading map" in line:
                reading.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        assert reading.wait(CEILING_S), "".join(lines)  # said at once: a 38 MB map takes seconds to read
        world.send_signal(signal.SIGINT)
        code = world.wait(timeout=CEILING_S)
    finally:
        if world.poll() is None:
            world.kill()
            world.wait()
    reader.join(timeout=10)
    text = "".join(lines)
    assert code == 130, text
    assert "stopped while starting" in text
    assert "ready:" not in text and "Traceback" not in text


def test_a_start_up_phase_that_lasts_says_what_it_is_and_how_far_it_got():
    said: list[str] = []
    with startup_phase(said.append, "rasterising walls") as phase:
        phase.progress(250, 1000)
        deadline = time.monotonic() + CEILING_S
        while not said and time.monotonic() < deadline:
            time.sleep(0.05)
    assert said and said[0].startswith("rasterising walls: 250 of 1,000 (25 %)")


def test_a_quick_phase_says_nothing():
    said: list[str] = []
    with startup_phase(said.append, "nothing much"):
        pass
    assert said == []
