"""Build and install tf2_msgs into this Python environment, or say in one line why TF is off.

Run with the environment's interpreter: ``.venv/bin/python interfaces/build_tf2_msgs.py``.
It always exits 0 when tf2_msgs cannot be built: the simulators work without TF, they just
publish no ``/tf``. Skipped when tf2_msgs is already importable (a ROS distro's, or built before).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "tf2_msgs"
ENABLE_HINT = "install gcc g++ python3-dev to enable"


def project_version() -> str:
    """The version in tf2_msgs/pyproject.toml (read without tomllib, which Python 3.10 lacks)."""
    match = re.search(r'^version = "([^"]+)"', (SOURCE / "pyproject.toml").read_text(), re.MULTILINE)
    return match.group(1) if match else ""


def find_compiler(env_var: str, candidates: tuple[str, ...]) -> str | None:
    """The compiler CMake would pick: ``$CC``/``$CXX`` when set, else the first one on PATH."""
    chosen = os.environ.get(env_var)
    if chosen:
        words = shlex.split(chosen)
        return shutil.which(words[0]) if words else None
    for name in candidates:
        found = shutil.which(name)
        if found:
            return found
    return None


def missing_build_tools() -> str | None:
    """Why tf2_msgs cannot be compiled here, or None when it can."""
    missing = []
    if find_compiler("CC", ("cc", "gcc", "clang")) is None:
        missing.append(f"no C compiler ({os.environ.get('CC') or 'cc/gcc/clang'} not found)")
    if find_compiler("CXX", ("c++", "g++", "clang++")) is None:
        missing.append(f"no C++ compiler ({os.environ.get('CXX') or 'c++/g++/clang++'} not found)")
    headers = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not headers.is_file():
        missing.append(f"no Python headers ({headers} not found)")
    return ", ".join(missing) or None


def tf_off(reason: str) -> int:
    print(f"TF is off: tf2_msgs is not built, so the worlds publish no /tf, because {reason}; {ENABLE_HINT}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--force", action="store_true", help="build even when tf2_msgs is importable (e.g. after editing its files)"
    )
    args = parser.parse_args(argv)

    if not args.force:
        # Not the interface folder beside this script: run as `python interfaces/build_tf2_msgs.py`,
        # Python would import interfaces/tf2_msgs (.msg files only) as a namespace package.
        here = Path(__file__).resolve().parent
        sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != here]
        spec = importlib.util.find_spec("tf2_msgs")
        if spec is not None and spec.origin is not None:  # a real package, with generated code
            try:
                ours = importlib.metadata.version("ros-jazzy-tf2-msgs") == project_version()
            except importlib.metadata.PackageNotFoundError:
                ours = False
            where = Path(spec.origin or "").parent
            print(f"tf2_msgs: using {'the one built before' if ours else 'the installed one'} ({where})")
            return 0

    reason = missing_build_tools()
    if reason:
        return tf_off(reason)

    log = Path(tempfile.gettempdir()) / "robot_sims-tf2_msgs-build.log"
    print(f"tf2_msgs: building from {SOURCE} (30-80 s, once per environment; log: {log})", flush=True)
    start = time.monotonic()
    with open(log, "w") as out:
        result = subprocess.run(
            [sys.executable, "-m", "pip", "install", "--force-reinstall", "--no-deps", str(SOURCE)],
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    elapsed = time.monotonic() - start
    if result.returncode != 0:
        return tf_off(f"its build failed after {elapsed:.0f} s (see {log})")
    print(f"tf2_msgs: built and installed in {elapsed:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
