"""Ctrl-C and Record in the studio, as a student meets them: a studio with a tab open (headless
Chromium) starts N Create worlds from the page, presses Record, then gets Ctrl-C (SIGINT to its
process group, as a terminal sends it).

Prints the seconds from pressing Record to the page saying "recording to" (the recorder has
subscribed to every topic), and from Ctrl-C to the studio's exit, its exit status, whether its
output holds a traceback, and whether the bag was finished (metadata.yaml written).

    .venv/bin/python bench/studio_ctrl_c.py --worlds 5
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _studio_support import ROOT, free_port, use_local_ros


def wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise SystemExit(f"not within {timeout:g} s: {what}")
        time.sleep(0.05)


def accepts(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
    except OSError:
        return False
    return True


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=5, help="Create worlds started from the page (default 5)")
    options = parser.parse_args()
    use_local_ros()
    sys.path.insert(0, str(ROOT / "test"))
    from studio_browser_support import click, find, new_browser, open_page

    workspace = Path(tempfile.mkdtemp(prefix="studio_ctrl_c_"))
    log = workspace / "studio.log"
    port = free_port()
    with log.open("w") as out:
        studio = subprocess.Popen(
            [sys.executable, "-m", "studio", "--workspace", str(workspace), "--port", str(port)],
            stdout=out, stderr=subprocess.STDOUT, cwd=ROOT, start_new_session=True,
        )  # fmt: skip
    try:
        wait_for(lambda: accepts(port), 120.0, "the studio serving")
        with new_browser() as driver:
            open_page(driver, f"http://127.0.0.1:{port}/")
            click(driver, ".studio-new-world")
            for n in range(1, options.worlds + 1):
                click(driver, ".studio-start-world")
                wait_for(lambda n=n: log.read_text().count("studio: following") == n, 120.0, f"world {n}")
            pressed = time.monotonic()
            click(driver, ".studio-record")
            wait_for(lambda: find(driver, ".studio-record-label").text.startswith("recording to"), 60.0, "recording")
            recording_s = time.monotonic() - pressed
            label = find(driver, ".studio-record-label").text
            interrupted = time.monotonic()
            os.killpg(studio.pid, signal.SIGINT)
            status = studio.wait(timeout=60.0)
            exit_s = time.monotonic() - interrupted
    finally:
        if studio.poll() is None:
            os.killpg(studio.pid, signal.SIGKILL)
    bag_done = any(workspace.glob("studio_data/*/metadata.yaml"))
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"{options.worlds} worlds, load average {load} on {os.cpu_count()} CPUs")
    print(f"Record -> 'recording to': {recording_s:.2f} s ({label})")
    print(f"Ctrl-C -> exit: {exit_s:.2f} s, status {status}, traceback: {'Traceback' in log.read_text()}")
    print(f"bag finished (metadata.yaml): {bag_done}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
