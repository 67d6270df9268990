"""``robot_sims <exe> [args] [--ros-args ...]``: the one command of a pip install."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

from sim_runtime.inputfile import shown
from sim_tools.executables import EXECUTABLES
from sim_tools.node_help import NODE_EXECUTABLES, wants_help
from sim_tools.node_help import help_text as node_help_text

USAGE = "usage: robot_sims <executable> [arguments] [--ros-args -p name:=value ...]"


def executables() -> dict[str, str]:
    """Executable name → ``module:function``, as declared once in :mod:`sim_tools.executables`."""
    return {name: target for name, (target, _what) in EXECUTABLES.items()}


def help_text() -> str:
    """What ``robot_sims --help`` prints: each executable with one line on what it does."""
    width = max(len(name) for name in EXECUTABLES) + 2
    lines = [USAGE, "", "executables:"]
    lines += [f"  {name:{width}s}{what}" for name, (_target, what) in EXECUTABLES.items()]
    lines += [
        "",
        "On a ROS 2 install, `ros2 run robot_sims <executable>` is the same command.",
        "World parameters are set with --ros-args -p name:=value (see `ros2 param describe`).",
    ]
    return "\n".join(lines)


def run(name: str, argv: list[str]) -> int:
    """Run executable ``name`` with ``argv`` as its command-line arguments."""
    if name not in EXECUTABLES:
        print(f"robot_sims: unknown executable '{name}'. Known: {', '.join(EXECUTABLES)}", file=sys.stderr)
        return 2
    if name in NODE_EXECUTABLES and wants_help(argv):  # rclpy ignores --help: the node would start
        print(node_help_text(name))
        return 0
    if name in NODE_EXECUTABLES:
        _offer_live_view()
    module, function = EXECUTABLES[name][0].split(":")
    main = getattr(importlib.import_module(module), function)
    # Nodes read sys.argv (rclpy.init, argparse): make it look like a direct call.
    sys.argv = [name, *argv]
    try:
        result = main()
    except OSError as error:  # the system refused a file (an output name too long, a full disk)
        where = f": {shown(error.filename)}" if error.filename else ""
        print(f"{name}: error: {error.strerror or error}{where}", file=sys.stderr)
        return 2
    return int(result or 0)


def _offer_live_view() -> None:
    """Worlds started with ``-p rerun:=true`` show themselves in Rerun (imported only then)."""
    from sim_runtime.run import live_viewers  # a node: rclpy is loaded anyway

    def attach(world):
        from sim_tools.rerun_view.live import attach_live_view

        return attach_live_view(world)

    live_viewers[:] = [attach]


RUN_EXECUTABLE = "import sys; from sim_tools.cli import run; sys.exit(run(sys.argv[1], sys.argv[2:]))"


def executable_command(name: str, args: Sequence[str] = ()) -> list[str]:
    """argv running ``robot_sims <name> <args>`` with this interpreter, whether or not the
    ``robot_sims`` script is on the PATH (a subprocess of a test, the studio, a benchmark)."""
    return [sys.executable, "-c", RUN_EXECUTABLE, name, *args]


def main() -> int:
    """Dispatch ``robot_sims <exe> ...``; with no executable, list them."""
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(help_text())
        return 0 if len(sys.argv) >= 2 else 2
    return run(sys.argv[1], sys.argv[2:])
