"""``robot_sims classroom grade ASSIGNMENT``: every latest submission through ``robot_sims batch``.

``--open`` first makes the drop folders (:func:`open_assignment`); then ``grade`` gives each
student's submission a run folder of its own (``grading/<assignment>/runs/<student>/``: the
submission as ``submission.py`` or ``submission.m``, copies of the visible and hidden worlds' files — the hidden ones
renamed ``hidden_N`` — and the sweep), runs ``robot_sims batch`` there contained
(:mod:`.contain`), reads its table, and writes the gradebook (``grading/<assignment>/gradebook.csv``,
0600) and each student's feedback (:mod:`.feedback`). An m-file (``controller: {form: mfile}``) is
batch's m-file controller: GNU Octave against the episode's MATLAB bridge, the world at real time
(so its rows are not bit-reproducible). One student's run that fails in any way
(a crash of batch itself included) is that student's error row; the others are graded normally.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import datetime
import grp
import importlib.util
import json
import os
import pwd
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from sim_runtime.errors import InputError
from sim_tools.classroom import contain
from sim_tools.classroom.assignment import SUFFIXES, Assignment, load_assignment, public_part
from sim_tools.classroom.gradebook import Grade, Student, gradebook_row, write_gradebook
from sim_tools.classroom.submit import PUBLIC_FILE, STEM

#: Grading uids are ``UID_BASE + ROS domain``: no account has them, so all their processes are ours.
UID_BASE = 1_900_000_000
#: Wall seconds a whole run may take beyond its episodes' time limits (batch's start-up, the check).
RUN_MARGIN_S = 240.0
#: The packages whose numba caches a run gets a copy of (:func:`_numba_cache`): the base's, and
#: the simulator's of the worlds (known by the key naming their file), and where.
CACHED_BASE = ("sim_runtime",)
CACHED_BY_WORLD_KEY = {"map": "create_sim", "world_file": "simrobot_sim", "robot_config": "arm_sim"}
NUMBA_FOLDER = ".numba"
#: The submission's name in its run folder (``.py`` or ``.m``: :data:`SUFFIXES`); an m-file is
#: called by its file's name, whatever its ``function`` line says.
SUBMISSION = "submission"
#: The world files batch reads (copied into each run folder).
WORLD_FILE_KEYS = ("map", "config", "world_file", "robot_config")


def user(name: str, homes: Path | None = None) -> Student:
    """Student ``name``: their Unix account, or (``homes``) ``homes/<name>`` and its owner."""
    if homes is not None:
        home = homes / name
        st = home.stat()
        return Student(name, st.st_uid, st.st_gid, home)
    try:
        entry = pwd.getpwnam(name)
    except KeyError:
        raise InputError(f"student {name!r}: no such Unix user (add them, or give --homes)") from None
    return Student(name, entry.pw_uid, entry.pw_gid, Path(entry.pw_dir))


def roster(a: Assignment, homes: Path | None = None) -> list[Student]:
    """The assignment's students: its ``students`` list and its ``group``'s members."""
    names = list(a.students)
    if a.group:
        try:
            names += [n for n in grp.getgrnam(a.group).gr_mem if n not in names]
        except KeyError:
            raise InputError(f"{a.source}: field 'group': no Unix group {a.group!r}") from None
    if not names:
        raise InputError(f"{a.source}: no students: give 'students: [...]' or 'group: NAME'")
    return [user(n, homes) for n in names]


def open_assignment(a: Assignment, students: Sequence[Student]) -> Path:
    """Make the drop folders: the assignment's (0711, the teacher's), its public part, one 0700
    folder per student owned by them. Run again to add students; nothing submitted is touched."""
    drop = a.submissions
    drop.mkdir(parents=True, exist_ok=True)
    drop.parent.chmod(0o711)
    drop.chmod(0o711)
    public = drop / PUBLIC_FILE
    public.write_text(json.dumps(public_part(a), indent=1))
    public.chmod(0o644)
    for s in students:
        mine = drop / s.name
        mine.mkdir(exist_ok=True)
        if os.geteuid() == 0:
            os.chown(mine, s.uid, s.gid)
        mine.chmod(0o700)
    return drop


def latest_submission(a: Assignment, s: Student) -> tuple[Path | None, str]:
    """The student's submitted file (or None and why not)."""
    mine = a.submissions / s.name
    try:
        st = os.lstat(mine)
    except FileNotFoundError:
        return None, "no drop folder (run grade --open)"
    if not os.path.isdir(mine) or os.path.islink(mine) or st.st_uid != s.uid:
        return None, f"its drop folder {mine} is not a folder owned by {s.name}"
    files = [p for p in mine.iterdir() if p.name in {f"{STEM}{x}" for x in SUFFIXES.values()}]
    files = [p for p in files if p.is_file() and not p.is_symlink() and p.lstat().st_uid == s.uid]
    if not files:
        return None, "nothing submitted"
    return max(files, key=lambda p: p.lstat().st_ctime), ""


def grade(
    a: Assignment,
    students: Sequence[Student],
    *,
    domains: Sequence[int],
    jobs: int = 2,
    ray: str | None = None,
    feedback: bool = True,
) -> tuple[Path, list[Grade]]:
    """Grade every student's latest submission; the gradebook's path and the grades."""
    if len(domains) < len(students):
        raise InputError(f"{len(students)} students but {len(domains)} ROS domains for grading: give more (--domains)")
    a.grading.mkdir(parents=True, exist_ok=True)
    a.grading.parent.chmod(0o711)
    a.grading.chmod(0o711)  # runs' uids pass through to their own folder; nothing here is listable
    (a.grading / "runs").mkdir(exist_ok=True)
    (a.grading / "runs").chmod(0o711)
    contain.allow_runs()
    pool = concurrent.futures.ThreadPoolExecutor(max(1, jobs))
    try:
        grades = list(pool.map(lambda sd: _grade_one(a, sd[0], sd[1], ray), zip(students, domains, strict=False)))
    except BaseException:  # Ctrl-C: every run stops now (and its uid's processes), none is waited for
        pool.shutdown(wait=False, cancel_futures=True)
        contain.stop_all()
        raise
    pool.shutdown()
    book = write_gradebook(a, grades)
    if feedback:
        from sim_tools.classroom.feedback import write_feedback

        for g in grades:
            try:
                write_feedback(a, g)
            except OSError as exc:  # a student without a home: the others still get theirs
                g.feedback_error = str(exc)
    return book, grades


def _grade_one(a: Assignment, s: Student, domain: int, ray: str | None) -> Grade:
    path, why = latest_submission(a, s)
    if path is None:
        return Grade(s, None, False, error=why)
    when = datetime.datetime.fromtimestamp(path.lstat().st_ctime, datetime.UTC)
    late = a.is_late(when)
    g = Grade(s, when, late)
    if late and a.late == "refuse":
        g.error = f"submitted after the deadline ({when.isoformat(timespec='seconds')} > {a.deadline.isoformat()})"
        return g
    try:
        g.run, g.rows, g.error = _run(a, s, path, domain, ray)
    except OSError as exc:
        g.error = f"grading failed: {exc}"
    return g


def _run(a: Assignment, s: Student, path: Path, domain: int, ray: str | None) -> tuple[Path, list[dict[str, Any]], str]:
    run = a.grading / "runs" / s.name
    if run.exists():
        shutil.rmtree(run)
    run.mkdir(mode=0o700)
    shutil.copyfile(path, run / f"{SUBMISSION}{SUFFIXES[a.form]}")
    names = _write_sweep(a, s, run)
    from sim_tools.batch.supervisor import worker_environment

    uid = UID_BASE + domain if contain.contained() else None
    env = worker_environment()
    if uid is not None:
        _numba_cache(run / NUMBA_FOLDER, _simulator_packages(a))
        env["NUMBA_CACHE_DIR"] = f"{contain.INSIDE}/{NUMBA_FOLDER}"
        _chown_tree(run, uid, uid)
    n = len(names) * _seed_count(a)
    limit = float(a.sweep.get("time_limit_s", max(60.0, 3 * float(a.sweep.get("duration_s", 60)))))
    command = [sys.executable, "-m", "sim_tools.batch.cli", "sweep.yaml", "--out", "out", "--workers", "1"]
    command += ["--broken-as-rows", "--quiet", "--no-plots"] + (["--ray", ray] if ray is not None else [])
    log = a.grading / "runs" / f"{s.name}.log"
    log.unlink(missing_ok=True)
    log.touch(mode=0o600)  # the teacher's: not another run's to read (its name is guessable)
    outcome = contain.run_contained(
        command,
        run,
        env,
        contain.Jail(uid, uid, domain, network=bool(ray)),
        n * limit + RUN_MARGIN_S,
        log,
    )
    if uid is not None:
        _chown_tree(run, os.geteuid(), os.getegid())  # its processes are gone: nothing changes it now
    rows = _read_rows(run / "out" / "episodes.csv", names)
    if outcome.timed_out:
        return run, rows, f"its grading run did not end in {n * limit + RUN_MARGIN_S:.0f} s and was stopped"
    if outcome.returncode != 0 or not rows:
        tail = _tail(log)
        return run, rows, f"its grading run failed (exit status {outcome.returncode}): {tail}"
    return run, rows, ""


def _simulator_packages(a: Assignment) -> list[str]:
    worlds = [*a.worlds, *a.hidden_worlds]
    found = {pkg for key, pkg in CACHED_BY_WORLD_KEY.items() if any(key in w for w in worlds)}
    return [*CACHED_BASE, *sorted(found or CACHED_BY_WORLD_KEY.values())]


def _numba_cache(folder: Path, packages: Sequence[str]) -> None:
    """Copies of the simulators' compiled kernels (numba's cache beside their sources) where
    numba looks for them when ``NUMBA_CACHE_DIR`` is ``folder``: a run's uid may not write beside
    the sources, and compiling every kernel again took a run 4 times as long. A run can spoil
    only its own copies."""
    import hashlib

    for package in packages:
        spec = importlib.util.find_spec(package)
        if spec is None or spec.origin is None:
            continue
        for cache in Path(spec.origin).parent.rglob("__pycache__"):
            files = [*cache.glob("*.nbi"), *cache.glob("*.nbc")]
            if not files:
                continue
            source = str(cache.parent)  # numba names the folder after its sources' folder
            target = folder / f"{os.path.basename(source)}_{hashlib.sha1(source.encode()).hexdigest()}"
            target.mkdir(parents=True, exist_ok=True)
            for f in files:
                shutil.copyfile(f, target / f.name)


def _seed_count(a: Assignment) -> int:
    seeds = a.sweep.get("seeds", [0])
    return int(seeds.get("count", 1)) if isinstance(seeds, dict) else max(1, len(seeds))


def _write_sweep(a: Assignment, s: Student, run: Path) -> dict[str, str]:
    """The run's sweep file; returns each world's name in the sweep → its name in feedback."""
    from sim_runtime.paths import config_dir

    (run / "worlds").mkdir()
    worlds, names = [], {}
    for k, world in enumerate([*a.worlds, *a.hidden_worlds]):
        hidden = k >= len(a.worlds)
        label = f"hidden_{k - len(a.worlds) + 1}" if hidden else str(world.get("name") or f"world_{k + 1}")
        shown = label.replace("_", " ") if hidden else label
        entry = dict(world, name=label)
        for key in WORLD_FILE_KEYS:
            value = world.get(key)
            if not value:
                continue
            source = a.source.parent / str(value)
            if not source.exists():
                source = config_dir() / str(value)
            copy = f"worlds/{label}_{key}{Path(str(value)).suffix}"
            shutil.copyfile(source, run / copy)
            entry[key] = copy
        worlds.append(entry)
        names[label] = shown
    sweep = {
        "worlds": worlds,
        "controllers": [{"name": s.name, "use": _use(a)}],
        **a.sweep,
        "keep_bags": "all",
    }
    (run / "sweep.yaml").write_text(yaml.safe_dump(sweep, sort_keys=False))
    return names


def _use(a: Assignment) -> str:
    """The sweep's ``use`` of the submission: ``submission:<entry>``, or the m-file itself."""
    return f"{SUBMISSION}.m" if a.form == "mfile" else f"{SUBMISSION}:{a.entry}"


def _chown_tree(root: Path, uid: int, gid: int) -> None:
    """``chown -R`` that never follows a link (a run may leave links to anywhere)."""
    os.chown(root, uid, gid, follow_symlinks=False)
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            os.chown(os.path.join(folder, name), uid, gid, follow_symlinks=False)


def _read_rows(table: Path, names: dict[str, str]) -> list[dict[str, Any]]:
    """The run's table, only if it is a regular file (not a link the run left), worlds renamed."""
    if not table.is_file() or table.is_symlink() or table.parent.is_symlink():
        return []
    rows = []
    with table.open(newline="") as f:
        for row in csv.DictReader(f):
            out: dict[str, Any] = {}
            for key, value in row.items():
                out[key] = _value(value)
            out["world"] = names.get(str(row.get("world")), "?")
            rows.append(out)
    return rows


def _value(text: str | None) -> Any:
    if text is None or text == "":
        return ""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def _tail(log: Path) -> str:
    try:
        lines = [line for line in log.read_text(errors="replace").splitlines() if line.strip()]
    except OSError:
        return "(no output)"
    return " | ".join(lines[-3:])[-400:] or "(no output)"


def parse_domains(text: str) -> list[int]:
    """``217-231`` or ``217,218,220``."""
    try:
        if "-" in text:
            low, high = (int(x) for x in text.split("-", 1))
            return list(range(low, high + 1))
        return [int(x) for x in text.split(",")]
    except ValueError:
        raise InputError(f"--domains {text!r}: expected FIRST-LAST or a list such as 217,218") from None


def main(argv: Sequence[str] | None = None) -> int:
    """``robot_sims classroom grade ASSIGNMENT [--open] [--ray [ADDRESS]]``."""
    parser = argparse.ArgumentParser(prog="robot_sims classroom grade", description=__doc__.splitlines()[0])
    parser.add_argument("assignment", help="the assignment file (YAML; the teacher's, hidden worlds included)")
    parser.add_argument("--open", action="store_true", help="make the drop folders (and the students' public part)")
    parser.add_argument("--homes", help="students' homes are HOMES/<name>, owned by them (default: their accounts)")
    parser.add_argument("--domains", default="200-231", help="ROS domains for grading runs, one per student")
    parser.add_argument("--jobs", type=int, default=2, help="students graded at once (each one batch worker)")
    parser.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS", help="run episodes on Ray")
    parser.add_argument("--no-feedback", action="store_true", help="write the gradebook only")
    args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    try:
        a = load_assignment(args.assignment)
        students = roster(a, Path(args.homes) if args.homes else None)
        if args.open:
            print(f"opened {open_assignment(a, students)} for {len(students)} students")
            return 0
        book, grades = grade(
            a,
            students,
            domains=parse_domains(args.domains),
            jobs=args.jobs,
            ray=args.ray,
            feedback=not args.no_feedback,
        )
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ninterrupted: every grading run was stopped; no gradebook was written", file=sys.stderr)
        return 130
    for g in grades:
        print(f"{g.student.name}: {gradebook_row(a, g)['score']}" + (f"  ({g.error})" if g.error else ""))
        if g.feedback_error:
            print(f"  no feedback for {g.student.name}: {g.feedback_error}", file=sys.stderr)
    print(f"gradebook: {book}")
    return 0
