"""Build and install the interface packages of interfaces/ into this Python environment, or say in
one line each why a feature is off.

Run with the environment's interpreter: ``.venv/bin/python interfaces/build_interfaces.py``.
It always exits 0 when a package cannot be built: the simulators work without them (without
tf2_msgs they publish no ``/tf``; without robot_sims_interfaces ``set_pose`` is a topic only).
A package already importable (a ROS distro's, or built before) is skipped.
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
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ENABLE_HINT = "install gcc g++ python3-dev to enable"


@dataclass(frozen=True)
class Interfaces:
    """One interface package: its folder here, and what the worlds lose without it."""

    name: str  # the ROS package, also its Python package
    off: str  # the feature that is off, as the log line starts: "<off> is off: ..."
    without: str  # what the worlds do without it

    @property
    def source(self) -> Path:
        return HERE / self.name

    def off_line(self, reason: str) -> str:
        return f"{self.off} is off: {self.name} is not built, so {self.without}, because {reason}; {ENABLE_HINT}"


PACKAGES = (
    Interfaces("tf2_msgs", "TF", "the worlds publish no /tf"),
    Interfaces("robot_sims_interfaces", "The set_pose service", "the worlds take set_pose as a topic only"),
)


def project_field(source: Path, field: str) -> str:
    """A ``field = "..."`` of <source>/pyproject.toml (read without tomllib, which Python 3.10 lacks)."""
    match = re.search(rf'^{field} = "([^"]+)"', (source / "pyproject.toml").read_text(), re.MULTILINE)
    return match.group(1) if match else ""


def project_version(source: Path = HERE / "tf2_msgs") -> str:
    """The version in <source>/pyproject.toml."""
    return project_field(source, "version")


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
    """Why interface packages cannot be compiled here, or None when they can."""
    missing = []
    if find_compiler("CC", ("cc", "gcc", "clang")) is None:
        missing.append(f"no C compiler ({os.environ.get('CC') or 'cc/gcc/clang'} not found)")
    if find_compiler("CXX", ("c++", "g++", "clang++")) is None:
        missing.append(f"no C++ compiler ({os.environ.get('CXX') or 'c++/g++/clang++'} not found)")
    headers = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not headers.is_file():
        missing.append(f"no Python headers ({headers} not found)")
    return ", ".join(missing) or None


def installed(package: Interfaces) -> str | None:
    """Where an importable ``package`` comes from, as the log says it, or None when it is not."""
    spec = importlib.util.find_spec(package.name)
    if spec is None or spec.origin is None:  # absent, or only a namespace package (no generated code)
        return None
    try:
        ours = importlib.metadata.version(project_field(package.source, "name")) == project_version(package.source)
    except importlib.metadata.PackageNotFoundError:
        ours = False
    return f"{'the one built before' if ours else 'the installed one'} ({Path(spec.origin).parent})"


def build(package: Interfaces) -> str | None:
    """pip-install ``package`` from its folder; None when built, else why not."""
    log = Path(tempfile.gettempdir()) / f"robot_sims-{package.name}-build.log"
    print(f"{package.name}: building from {package.source} (30-80 s, once per environment; log: {log})", flush=True)
    start = time.monotonic()
    with open(log, "w") as out:
        result = subprocess.run(
            [sys.executable, "-m", "pip", "install", "--force-reinstall", "--no-deps", str(package.source)],
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    elapsed = time.monotonic() - start
    if result.returncode != 0:
        return f"its build failed after {elapsed:.0f} s (see {log})"
    print(f"{package.name}: built and installed in {elapsed:.0f} s")
    return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--force", action="store_true", help="build even when a package is importable (e.g. after editing its files)"
    )
    names = [p.name for p in PACKAGES]
    parser.add_argument("packages", nargs="*", metavar="PACKAGE", help=f"only these of {names} (default: all)")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.packages) - set(names))
    if unknown:
        parser.error(f"unknown package(s) {', '.join(unknown)}: choose from {', '.join(names)}")
    chosen = [p for p in PACKAGES if not args.packages or p.name in args.packages]

    # Not the interface folders beside this script: run as `python interfaces/build_interfaces.py`,
    # Python would import interfaces/tf2_msgs (.msg files only) as a namespace package.
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE]
    reason = None if all(not args.force and installed(p) for p in chosen) else missing_build_tools()
    for package in chosen:
        where = None if args.force else installed(package)
        if where:
            print(f"{package.name}: using {where}")
            continue
        failed = reason or build(package)
        if failed:
            print(package.off_line(failed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
