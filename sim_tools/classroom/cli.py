"""``robot_sims classroom <subcommand> [arguments]``: a course server and its assignments.

Each subcommand is one line of :data:`SUBCOMMANDS` (name → ``module:function``, what it does); the
function takes the subcommand's arguments (``list[str]``) and returns the exit status. Modules are
imported only when their subcommand runs, so ``--help`` stays fast and one broken module does not
take the others down.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Sequence

SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "init": ("sim_tools.classroom.hub_config:main", "write a ready JupyterHub configuration into DIR"),
    "serve": ("sim_tools.classroom.serve:main", "start the course server configured in DIR"),
    "submit": ("sim_tools.classroom.submit:main", "hand in a controller (Python module or m-file) for ASSIGNMENT"),
    "grade": ("sim_tools.classroom.grade:main", "open ASSIGNMENT's drop folders (--open), or grade every submission"),
}

USAGE = "usage: robot_sims classroom <subcommand> [arguments]   (robot_sims classroom <subcommand> --help)"


def help_text() -> str:
    """The subcommands, one line each."""
    width = max(len(name) for name in SUBCOMMANDS) + 2
    lines = [USAGE, "", "subcommands:"]
    lines += [f"  {name:{width}s}{what}" for name, (_target, what) in SUBCOMMANDS.items()]
    lines += ["", "The teacher's path and the students': docs/classroom.md."]
    return "\n".join(lines)


def subcommand(name: str) -> Callable[[list[str]], int]:
    """The function of subcommand ``name`` (imported now)."""
    module, function = SUBCOMMANDS[name][0].split(":")
    return getattr(importlib.import_module(module), function)


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``robot_sims classroom <subcommand> ...``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        print(help_text())
        return 0 if args else 2
    name, rest = args[0], args[1:]
    if name not in SUBCOMMANDS:
        print(f"robot_sims classroom: unknown subcommand '{name}'. Known: {', '.join(SUBCOMMANDS)}", file=sys.stderr)
        return 2
    return int(subcommand(name)(rest) or 0)
