"""``robot_sims classroom submit ASSIGNMENT FILE``: a student hands in a controller.

The drop area of an assignment (made by the teacher's ``robot_sims classroom grade --open``)::

    <course>/submissions/<assignment>/          teacher's, 0711: anyone may pass, nobody may list
        assignment.json                         0644: the public part (deadline, form; no hidden world)
        <student>/                              the student's, 0700: only they (and the teacher) get in
            controller.py | controller.m        0600: the latest submission (each one replaces it)
            submitted.json                      0600: who, when, the file's name and SHA-256

No student can list the drop area (no read bit on it) nor enter another's folder (0700), so none
can read, list, replace or block another's submission. What the grading trusts is the file
system, not ``submitted.json`` (which its student could edit): the folder's owner is the student,
the file's change time (``st_ctime``, which no user can set back) is when it was handed in.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import pwd
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_runtime.inputfile import shown

PUBLIC_FILE = "assignment.json"
RECEIPT_FILE = "submitted.json"
#: The submitted file's name in the student's folder (plus the form's suffix).
STEM = "controller"
#: A controller is a program a person writes, not a data set.
MAX_BYTES = 1 << 20
#: Where a course's folder is found when ASSIGNMENT is a name (the hub sets it for every student).
COURSE_ENV = "ROBOT_SIMS_COURSE"


@dataclass(frozen=True)
class Receipt:
    """A submission as stored."""

    assignment: str
    student: str
    path: Path
    time: datetime.datetime
    late: bool
    sha256: str

    def sentence(self) -> str:
        late = " (after the deadline: marked late)" if self.late else ""
        when = self.time.isoformat(timespec="seconds")
        return f"submitted {self.path.name} for {self.assignment} as {self.student} at {when}{late}"


def current_user() -> str:
    """The Unix user running this (the student); a uid without an account (a container's) goes by
    ``$USER``: claiming another's name gains nothing, their folder is theirs (0700)."""
    try:
        return pwd.getpwuid(os.geteuid()).pw_name
    except KeyError:
        return os.environ.get("USER") or str(os.geteuid())


def find_drop(ref: str, course: str | None = None) -> Path:
    """The drop folder of assignment ``ref``: a folder holding ``assignment.json``, the teacher's
    assignment file (when readable), or a name in the course's ``submissions/``."""
    path = Path(ref)
    if (path / PUBLIC_FILE).is_file():
        return path
    if path.is_file() and path.suffix in (".yaml", ".yml"):
        from sim_tools.classroom.assignment import load_assignment

        return load_assignment(path).submissions
    root = course or os.environ.get(COURSE_ENV)
    if root and (Path(root) / "submissions" / ref / PUBLIC_FILE).is_file():
        return Path(root) / "submissions" / ref
    where = f" in {shown(root)}/submissions" if root else f" (no --course and no {COURSE_ENV} set)"
    raise InputError(f"no assignment {ref!r}{where}: ask your teacher for its name, or whether it is open yet")


def read_public(drop: Path) -> dict[str, Any]:
    try:
        data: dict[str, Any] = json.loads((drop / PUBLIC_FILE).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{shown(drop / PUBLIC_FILE)}: cannot read the assignment: {exc}") from None
    return data


def submit(
    ref: str, file: str | os.PathLike[str], *, course: str | None = None, now: datetime.datetime | None = None
) -> Receipt:
    """Copy ``file`` into this user's folder of assignment ``ref``; the :class:`Receipt`.

    Refused (InputError, a sentence saying why) for a file of the wrong form, too big or not a
    regular file, after the deadline when the assignment refuses late work, and when the
    assignment has no folder of this user's."""
    drop = find_drop(ref, course)
    public = read_public(drop)
    student = current_user()
    source = Path(file)
    suffix = str(public.get("suffix", ".py"))
    if source.suffix != suffix:
        raise InputError(f"{shown(source)}: {public['name']} takes a {public['form']} controller (a {suffix} file)")
    if not source.is_file():
        raise InputError(f"{shown(source)}: no such file (or not a regular file)")
    data = source.read_bytes()
    if len(data) > MAX_BYTES:
        raise InputError(f"{shown(source)}: {len(data)} bytes; a controller may have at most {MAX_BYTES}")
    when = now or datetime.datetime.now(datetime.UTC)
    deadline = datetime.datetime.fromisoformat(public["deadline"])
    late = when > deadline
    if late and public.get("late") != "mark":
        raise InputError(
            f"{public['name']} closed at its deadline, {deadline.isoformat()}: "
            "submissions are no longer taken (your teacher may reopen it)"
        )
    mine = drop / student
    if not mine.is_dir() or mine.stat().st_uid != os.geteuid():
        raise InputError(f"{public['name']} has no folder for {student}: ask your teacher to add you to it")
    target = mine / f"{STEM}{suffix}"
    _write_private(target, data)
    for other in mine.glob(f"{STEM}.*"):
        if other != target and other.suffix in (".py", ".m"):
            other.unlink()  # the latest submission is the one graded, whatever its form
    digest = hashlib.sha256(data).hexdigest()
    receipt = {"student": student, "time": when.isoformat(), "file": source.name, "sha256": digest, "late": late}
    _write_private(mine / RECEIPT_FILE, json.dumps(receipt, indent=1).encode())
    return Receipt(str(public["name"]), student, target, when, late, digest)


def _write_private(target: Path, data: bytes) -> None:
    """Write ``target`` (mode 0600) whole or not at all: a crash leaves the previous one."""
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW, 0o600)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o600)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def main(argv: Sequence[str] | None = None) -> int:
    """``robot_sims classroom submit ASSIGNMENT FILE``."""
    parser = argparse.ArgumentParser(
        prog="robot_sims classroom submit", description="Hand in a controller for an assignment."
    )
    parser.add_argument("assignment", help=f"the assignment's name (in ${COURSE_ENV}/submissions) or its folder")
    parser.add_argument("file", help="your controller: a Python module (.py) or an m-file (.m)")
    parser.add_argument("--course", help=f"the course's folder (default: ${COURSE_ENV})")
    args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    try:
        receipt = submit(args.assignment, args.file, course=args.course)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(receipt.sentence())
    return 0
