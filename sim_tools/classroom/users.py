"""The students' Unix accounts: one per student, made on their first server start, home 0700.

A hub user name becomes a Unix account of the same name. Only accounts of the course's group may be
used: a student who signs up as ``root`` or ``daemon`` (or as any existing account the course did
not make) is refused, otherwise their server would run as that account.
"""

from __future__ import annotations

import grp
import os
import pwd
import re
import signal
import subprocess
import time
from pathlib import Path

UNIX_NAME = re.compile(r"^[a-z_][a-z0-9_-]{0,31}$")


class NotAStudent(RuntimeError):
    """The hub user cannot be (or become) a student account of this course."""


def ensure_group(group: str) -> int:
    """The gid of ``group``, made (a system group) if missing."""
    try:
        return grp.getgrnam(group).gr_gid
    except KeyError:
        subprocess.run(["groupadd", "--system", group], check=True, capture_output=True, text=True)
        return grp.getgrnam(group).gr_gid


def ensure_student(name: str, group: str, home_root: Path = Path("/home")) -> pwd.struct_passwd:
    """The Unix account of student ``name``: made if missing (in ``group``, home ``home_root/name``
    mode 0700), its home made private again if it is not. Raises :class:`NotAStudent`."""
    if not UNIX_NAME.match(name):
        raise NotAStudent(f"user name {name!r} cannot be a Unix account (lower-case letters, digits, _ and -)")
    gid = ensure_group(group)
    try:
        account = pwd.getpwnam(name)
    except KeyError:
        account = None
    if account is None:
        home = home_root / name
        done = subprocess.run(
            ["useradd", "--create-home", "--home-dir", str(home), "--shell", "/bin/bash", "--gid", group, name],
            capture_output=True,
            text=True,
        )
        if done.returncode != 0:
            raise NotAStudent(f"useradd {name}: {done.stderr.strip() or done.returncode}")
        account = pwd.getpwnam(name)
    else:
        members = grp.getgrgid(gid).gr_mem
        if account.pw_gid != gid and name not in members:
            raise NotAStudent(
                f"Unix account {name!r} exists and is not a student of this course (group {group!r}): "
                f"refused, or its server would run as that account. To allow it: usermod -aG {group} {name}"
            )
    if account.pw_uid == 0:
        raise NotAStudent(f"Unix account {name!r} is root: refused")
    home = Path(account.pw_dir)
    home.mkdir(mode=0o700, exist_ok=True)
    os.chown(home, account.pw_uid, account.pw_gid)
    os.chmod(home, 0o700)  # private: no classmate may list or read it
    return account


def processes_of(uid: int) -> list[int]:
    """Pids of every live process (not a zombie awaiting its parent) whose real uid is ``uid``."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
        except OSError:
            continue  # gone meanwhile
        fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
        if fields.get("Uid", "").split()[:1] == [str(uid)] and not fields.get("State", "").strip().startswith("Z"):
            pids.append(int(entry.name))
    return pids


def kill_everything_of(uid: int, gid: int, timeout: float = 10.0) -> list[int]:
    """SIGKILL every process of ``uid`` (never root's), however it was started (its own session, a
    double fork, a daemon): ``kill(-1)`` from a child that has become ``uid`` reaches all of them at
    once, repeated until none is left. Returns the pids that still live after ``timeout`` (none)."""
    if uid == 0:
        raise ValueError("refusing to kill every process of root")
    deadline = time.monotonic() + timeout
    while processes_of(uid) and time.monotonic() < deadline:
        child = os.fork()
        if child == 0:  # only syscalls here: this is a fork of the hub's process
            try:
                os.setgroups([])
                os.setresgid(gid, gid, gid)
                os.setresuid(uid, uid, uid)
                os.kill(-1, signal.SIGKILL)  # every process this uid may signal, this one too
            finally:
                os._exit(0)
        os.waitpid(child, 0)
        time.sleep(0.05)  # let the kernel reap them (their parent may be the hub's server process)
    return processes_of(uid)
