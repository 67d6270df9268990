"""``robot_sims urdf``: the URDF of an arm's robot config, or of the Create, on stdout."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from arm_sim.robot_config import load_robot_config
from arm_sim.urdf import arm_urdf
from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem
from sim_runtime.paths import config_path


def main(argv: list[str] | None = None) -> int:
    """``robot_sims urdf <robot_config.yaml | create> [--prefix P]``: print the URDF on stdout.

    A robot config is looked up as given, else among the shipped configs (``arm/irb120.yaml``).
    Bad input: one line on stderr naming the file, exit status 2.
    """
    parser = argparse.ArgumentParser(
        prog="robot_sims urdf", description="Print the URDF of an arm's robot config, or of the Create."
    )
    parser.add_argument("robot", help="robot config YAML (a path, or shipped like arm/irb120.yaml), or 'create'")
    parser.add_argument("--prefix", default="", help="prefix of every link name, e.g. arm2/ or robot1/")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        if args.robot == "create":
            from create_sim.urdf import create_urdf  # only this path needs the Create

            text = create_urdf(args.prefix)
        else:
            text = arm_urdf(load_robot_config(_config_file(args.robot)), args.prefix)
    except InputError as exc:
        one_line = " ".join(part.strip() for part in str(exc).splitlines() if part.strip())
        print(f"robot_sims urdf: {one_line}", file=sys.stderr)
        return 2
    sys.stdout.write(text)
    return 0


def _config_file(value: str) -> Path:
    path = Path(value).expanduser()
    if file_problem(path) != "not found" or path.is_absolute():  # loading it says what is wrong
        return path
    shipped = config_path(value)
    if shipped.is_file():
        return shipped
    raise InputError(f"{value}: no such file (looked as a path and in {config_path('')})")


if __name__ == "__main__":
    sys.exit(main())
