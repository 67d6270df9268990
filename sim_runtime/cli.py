"""``robot_sims <exe> [args] [--ros-args ...]``: the one command of a pip install."""

from __future__ import annotations

import sys
from importlib.metadata import entry_points

USAGE = "usage: robot_sims <executable> [arguments] [--ros-args ...]"


def executables() -> dict[str, str]:
    """Executable name → ``module:function``, as declared once in setup.py."""
    return {ep.name: ep.value for ep in entry_points(group="robot_sims.executables")}


def run(name: str, argv: list[str]) -> int:
    """Run executable ``name`` with ``argv`` as its command-line arguments."""
    table = executables()
    if name not in table:
        print(f"robot_sims: unknown executable '{name}'. Known: {', '.join(sorted(table))}", file=sys.stderr)
        return 2
    entry = next(ep for ep in entry_points(group="robot_sims.executables") if ep.name == name)
    main = entry.load()
    # Nodes read sys.argv (rclpy.init, argparse): make it look like a direct call.
    sys.argv = [name, *argv]
    result = main()
    return int(result or 0)


def main() -> int:
    """Dispatch ``robot_sims <exe> ...``; with no executable, list them."""
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(USAGE)
        print("executables:")
        for name, target in sorted(executables().items()):
            print(f"  {name:18s} {target}")
        return 0 if len(sys.argv) >= 2 else 2
    return run(sys.argv[1], sys.argv[2:])
