"""``robot_sims classroom init DIR --admin NAME``: write a ready course server configuration.

DIR gets ``jupyterhub_config.py`` (from :mod:`.template`: readable, commented, every setting a
plain line) and is made private (0700: the hub's database and cookie secret live there). Then the
students' interpreter is tried as an unprivileged user: a venv under a private home (``/root`` is
0700) cannot be run by students, and what to fix is said.
"""

from __future__ import annotations

import argparse
import os
import pwd
import stat
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from sim_runtime.errors import InputError
from sim_runtime.paths import config_dir
from sim_tools.classroom.domains import parse_range
from sim_tools.classroom.limits import parse_bytes
from sim_tools.classroom.template import TEMPLATE
from sim_tools.classroom.users import UNIX_NAME

CONFIG = "jupyterhub_config.py"
STUDENT_IMPORTS = "import jupyterhub.singleuser, jupyterlab, sim_tools.cli"


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="robot_sims classroom init",
        description="Write a JupyterHub configuration for a course: every student a Unix user with "
        "their own ROS domain and limits (docs/classroom.md).",
    )
    parser.add_argument("dir", help="the course folder (made; holds the config, database, logs)")
    parser.add_argument("--admin", required=True, help="the teacher's hub user name (approves sign-ups)")
    parser.add_argument("--bind-url", default="http://127.0.0.1:8000/", help="public address (default: %(default)s)")
    parser.add_argument("--hub-port", type=int, default=8081, help="the hub's internal API port on 127.0.0.1")
    parser.add_argument("--proxy-api-port", type=int, default=8001, help="the proxy's API port on 127.0.0.1")
    parser.add_argument(
        "--python", default=sys.executable, help="the interpreter students run (a venv with robot_sims[classroom])"
    )
    parser.add_argument("--domains", default="1-101", help="ROS domain ids for running servers (default: %(default)s)")
    parser.add_argument("--group", default="robot_sims_students", help="Unix group of the students' accounts")
    parser.add_argument("--memory", default="4G", help="memory per student process (RLIMIT_AS; cgroup total)")
    parser.add_argument("--processes", type=int, default=512, help="processes + threads per student (RLIMIT_NPROC)")
    parser.add_argument("--nice", type=int, default=5, help="nice level of the students' servers")
    parser.add_argument("--max-worlds", type=int, default=2, help="worlds one student may run at once")
    parser.add_argument("--idle-timeout", type=int, default=3600, help="seconds before an idle server is stopped")
    parser.add_argument("--force", action="store_true", help="overwrite an existing configuration")
    return parser.parse_args(list(argv))


def render(args: argparse.Namespace, course: Path) -> str:
    """The configuration text for ``args`` (checked: a bad value is an InputError naming it)."""
    if not UNIX_NAME.match(args.admin):
        raise InputError(f"--admin {args.admin!r}: must be a Unix user name (lower-case letters, digits, _ and -)")
    parse_range(args.domains)
    parse_bytes(args.memory)
    for option in ("hub_port", "proxy_api_port", "processes", "max_worlds", "idle_timeout"):
        if getattr(args, option) < 1:
            raise InputError(f"--{option.replace('_', '-')} {getattr(args, option)}: must be >= 1")
    return TEMPLATE.substitute(
        course=course,
        admin=args.admin,
        bind_url=args.bind_url,
        hub_port=args.hub_port,
        proxy_api_port=args.proxy_api_port,
        student_python=args.python,
        hub_python=sys.executable,
        domains=args.domains,
        group=args.group,
        memory=args.memory,
        processes=args.processes,
        nice=args.nice,
        max_worlds=args.max_worlds,
        idle_timeout=args.idle_timeout,
        fastdds_profile=config_dir() / "fastdds_localhost.xml",
        ament_prefix=os.environ.get("AMENT_PREFIX_PATH", sys.prefix),
    )


def closed_folders(path: Path) -> list[Path]:
    """The folders on the way to ``path`` (and to what its symlinks point to) that others may not enter."""
    targets = {path, path.resolve()}
    cfg = path.parent.parent / "pyvenv.cfg"  # a venv: its base interpreter's prefix too
    if cfg.is_file():
        for line in cfg.read_text().splitlines():
            key, _, value = line.partition("=")
            if key.strip() == "home":
                targets.add(Path(value.strip()))
    closed = set()
    for target in targets:
        for folder in [*reversed(target.parents), target]:
            try:
                mode = folder.stat().st_mode
            except OSError:
                continue
            if stat.S_ISDIR(mode) and not mode & stat.S_IXOTH:
                closed.add(folder)
    return sorted(closed)


def student_python_problem(python: str) -> str | None:
    """Why an unprivileged user (``nobody``) cannot run ``python`` with the classroom's packages, or None."""
    if os.geteuid() != 0:
        closed = closed_folders(Path(python))
        return f"others may not enter {', '.join(map(str, closed))}" if closed else None
    nobody = pwd.getpwnam("nobody")

    def become_nobody() -> None:
        os.setgroups([])
        os.setgid(nobody.pw_gid)
        os.setuid(nobody.pw_uid)

    try:
        done = subprocess.run(
            [python, "-c", STUDENT_IMPORTS],
            preexec_fn=become_nobody,
            capture_output=True,
            text=True,
            timeout=300,
            cwd="/",
            env={"PATH": "/usr/bin:/bin", "HOME": "/nonexistent"},
        )
    except OSError as error:
        done = subprocess.CompletedProcess([python], 126, "", str(error))
    if done.returncode == 0:
        return None
    closed = closed_folders(Path(python))
    why = f"others may not enter {', '.join(map(str, closed))}" if closed else done.stderr.strip()[-400:]
    return why


def fix_advice(python: str, why: str) -> str:
    return (
        f"students cannot run {python}: {why}.\n"
        "Fix one of:\n"
        "  - install robot_sims in a venv outside any home, e.g.\n"
        "      python3 -m venv /opt/robot_sims && /opt/robot_sims/bin/pip install 'robot_sims[classroom]'\n"
        "    then: robot_sims classroom init DIR --python /opt/robot_sims/bin/python --force ...\n"
        "  - or let others pass through the closed folders (they may then open files in them whose\n"
        "    names they know, not list them): chmod o+x <each folder above>"
    )


def main(argv: Sequence[str]) -> int:
    args = parse_args(argv)
    course = Path(args.dir).absolute()
    target = course / CONFIG
    if target.exists() and not args.force:
        print(f"classroom init: {target} exists (--force to overwrite it)", file=sys.stderr)
        return 2
    try:
        text = render(args, course)
    except InputError as error:
        print(f"classroom init: error: {error}", file=sys.stderr)
        return 2
    course.mkdir(parents=True, exist_ok=True)
    course.chmod(0o700)  # the database (password hashes) and the cookie secret
    target.write_text(text)
    print(f"wrote {target}")
    problem = student_python_problem(args.python)
    if problem:
        print(f"classroom init: warning: {fix_advice(args.python, problem)}", file=sys.stderr)
        return 1
    print(f"students run {args.python} (tried as user nobody)")
    print(f"next: robot_sims classroom serve {course}   (as root), then sign up as {args.admin!r} at {args.bind_url}")
    return 0
