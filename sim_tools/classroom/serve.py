"""``robot_sims classroom serve DIR``: run the course server configured by ``classroom init DIR``.

JupyterHub runs in the foreground (Ctrl-C stops it and every student's server), in DIR, with
configurable-http-proxy found on the PATH or in npm's global prefix; if it is missing, what to run
is said. As root: each student's server runs as their own Unix user.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from sim_tools.classroom.hub_config import CONFIG

PROXY = "configurable-http-proxy"
INSTALL_PROXY = "npm install -g configurable-http-proxy"


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="robot_sims classroom serve",
        description="Start the course server (JupyterHub) configured in DIR by `robot_sims classroom init`.",
    )
    parser.add_argument("dir", help="the course folder")
    return parser.parse_args(list(argv))


def npm_bin() -> Path | None:
    """npm's global bin folder, where ``npm install -g`` puts commands, or None without npm."""
    npm = shutil.which("npm")
    if npm is None:
        return None
    try:
        done = subprocess.run([npm, "prefix", "-g"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return Path(done.stdout.strip()) / "bin" if done.returncode == 0 and done.stdout.strip() else None


def find_proxy(path: str) -> Path | None:
    """configurable-http-proxy on ``path`` (a PATH string) or in npm's global bin folder."""
    found = shutil.which(PROXY, path=path)
    if found:
        return Path(found)
    folder = npm_bin()
    if folder is not None and os.access(folder / PROXY, os.X_OK):
        return folder / PROXY
    return None


def jupyterhub_command() -> list[str]:
    """JupyterHub run with this interpreter (its package is beside robot_sims)."""
    return [sys.executable, "-m", "jupyterhub"]


def main(argv: Sequence[str]) -> int:
    args = parse_args(argv)
    course = Path(args.dir).absolute()
    config = course / CONFIG
    if not config.is_file():
        print(
            f"classroom serve: {config} not found: first run robot_sims classroom init {course} --admin NAME",
            file=sys.stderr,
        )
        return 2
    proxy = find_proxy(os.environ.get("PATH", os.defpath))
    if proxy is None:
        where = "" if shutil.which("npm") else " (npm comes with Node.js: apt-get install nodejs npm)"
        print(
            f"classroom serve: {PROXY} not found on the PATH nor in npm's prefix: run {INSTALL_PROXY}{where}",
            file=sys.stderr,
        )
        return 1
    if os.geteuid() != 0:
        print(
            "classroom serve: run it as root: each student's server runs as their own Unix user "
            "(the hub makes the accounts)",
            file=sys.stderr,
        )
        return 1
    env = dict(os.environ, PATH=f"{proxy.parent}{os.pathsep}{os.environ.get('PATH', os.defpath)}")
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.chdir(course)
    command = [*jupyterhub_command(), "-f", str(config)]
    print(f"classroom serve: {' '.join(command)}  (in {course}; Ctrl-C stops it)", flush=True)
    os.execve(command[0], command, env)  # the hub itself gets the signals
    return 0  # not reached
