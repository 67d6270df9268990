"""What the studio benchmarks share (imported by bench/studio*.py; `make bench` does not run it)."""

from __future__ import annotations

import os
import socket
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = "/usr/lib/chromium/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


def new_driver(height: int = 1600):  # selenium's WebDriver (imported here only)
    """Headless Chromium, 1400 px wide and ``height`` tall (the whole page of the bench's studio)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size=1400,{height}"):
        options.add_argument(arg)
    os.environ["SE_CHROMEDRIVER"] = CHROMEDRIVER
    return webdriver.Chrome(options=options, service=Service(CHROMEDRIVER))


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` so far (from /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def use_local_ros() -> None:
    """Unless the caller chose otherwise: DDS on this machine only, the project's fast-discovery
    profile, and a ROS domain of this run's own (a benchmark must not see another run's worlds)."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))
    os.environ.setdefault("ROS_DOMAIN_ID", str(50 + os.getpid() % 50))
