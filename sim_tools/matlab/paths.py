"""``robot_sims matlab_path [toolbox]``: print the folder of the shipped m-files, for ``addpath``.

The m-files live in ``matlab/<toolbox>/`` of a checkout, or ``share/robot_sims/matlab/<toolbox>``
when installed (setup.py installs them beside ``config/``)::

    >>> matlab_dir("create").name
    'create'
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sim_runtime.paths import config_dir

DEFAULT_TOOLBOX = "create"


def matlab_dir(toolbox: str = DEFAULT_TOOLBOX) -> Path:
    """The folder of one toolbox's m-files (``create``: the Create toolbox on the bridge)."""
    return config_dir().parent / "matlab" / toolbox


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="robot_sims matlab_path",
        description="Print the folder of the shipped m-files, e.g. addpath(<folder>) in MATLAB/Octave.",
    )
    parser.add_argument("toolbox", nargs="?", default=DEFAULT_TOOLBOX, help="which toolbox (default: create)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    folder = matlab_dir(args.toolbox)
    if not folder.is_dir():
        print(f"matlab_path: error: no toolbox {args.toolbox!r} (no folder {folder})", file=sys.stderr)
        return 2
    print(folder)
    return 0
