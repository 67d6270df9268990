"""A teacher grades an assignment of several submissions (good, malicious, broken, hanging, an
m-file) into a gradebook and per-student feedback, each student a uid of their own.

The students are uids without accounts (``STUDENT_UID + k``) with homes in a 0711 folder of
/tmp: real users as far as the kernel's permission checks go. Needs root (the CI container is).
"""

from __future__ import annotations

import csv
import datetime
import os
import shutil
import stat
import tempfile
from pathlib import Path

import pytest

from sim_runtime.errors import InputError
from sim_tools.classroom.assignment import load_assignment
from sim_tools.classroom.contain import processes_of
from sim_tools.classroom.grade import UID_BASE, grade, open_assignment
from sim_tools.classroom.gradebook import Student
from sim_tools.classroom.submit import submit

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="grading as root: runs as other uids")

STUDENT_UID = 1_950_000_000
DOMAINS = list(range(217, 232))
GOOD = '''
from geometry_msgs.msg import Twist
from rclpy.node import Node


class Controller(Node):
    """Drive straight at 0.2 m/s."""

    def __init__(self, **kwargs):
        super().__init__("alice", **kwargs)
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_timer(0.05, self.tick)

    def tick(self):
        cmd = Twist()
        cmd.linear.x = 0.2
        self.pub.publish(cmd)
'''
MALICIOUS = '''
import os, time
from rclpy.node import Node


class Controller(Node):
    """Reads the others' files, then forks without end."""

    def __init__(self, **kwargs):
        super().__init__("mallory", **kwargs)
        stolen = []
        for path in {targets!r}:
            try:
                stolen.append(str(os.listdir(path)) if os.path.isdir(path) else open(path).read())
            except OSError:
                pass
        if stolen:
            raise RuntimeError("STOLEN " + " ".join(stolen))
        while True:
            try:
                if os.fork() == 0:
                    time.sleep(3600)
            except OSError:
                time.sleep(0.01)
'''
BROKEN = """
from rclpy.node import Node


class Controller(Node):
    def __init__(self, **kwargs):
        super().__init__("bob", **kwargs)
        raise ValueError("forgot to set the gains")
"""
HANGS = """
from rclpy.node import Node


class Controller(Node):
    def __init__(self, **kwargs):
        super().__init__("carol", **kwargs)
        self.create_timer(0.1, self.tick)

    def tick(self):
        while True:
            pass
"""


@pytest.fixture
def course():
    """A course folder other uids can pass through (pytest's tmp_path is root's 0700)."""
    root = Path(tempfile.mkdtemp(prefix="grading_", dir="/tmp"))
    root.chmod(0o711)
    yield root
    shutil.rmtree(root, ignore_errors=True)


def make_student(course: Path, k: int, name: str) -> Student:
    uid = STUDENT_UID + k
    home = course / "homes" / name
    home.mkdir(parents=True)
    (course / "homes").chmod(0o711)
    (home / "secret.txt").write_text(f"{name}'s secret")
    for path in (home, home / "secret.txt"):
        os.chown(path, uid, uid)
    home.chmod(0o700)
    return Student(name, uid, uid, home)


def as_student(s: Student, source: str, suffix: str, assignment: Path, now=None) -> str:
    """Write ``source`` in the student's home and submit it as them (a forked child with their
    uid); returns what submit said."""
    path = s.home / f"mine{suffix}"
    path.write_text(source)
    os.chown(path, s.uid, s.gid)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child reports through the pipe
        os.close(read)
        try:
            os.setgroups([])
            os.setresgid(s.gid, s.gid, s.gid)
            os.setresuid(s.uid, s.uid, s.uid)
            os.environ["USER"] = s.name  # an account-less uid goes by $USER
            message = submit(str(assignment), path, now=now).sentence()
        except BaseException as exc:
            message = f"refused: {exc}"
        os.write(write, message.encode())
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as f:
        said = f.read()
    os.waitpid(pid, 0)
    return said


def write_assignment(course: Path, **extra: str) -> Path:
    teacher = course / "teacher"
    teacher.mkdir(exist_ok=True)
    shutil.copyfile(Path(__file__).parent.parent / "examples/maps/two_boxes.map", teacher / "secret_maze.map")
    deadline = extra.get("deadline", "2099-01-01T00:00:00+00:00")
    text = f"""\
name: bump_turn
deadline: {deadline}
late: {extra.get("late", "refuse")}
controller: {{form: {extra.get("form", "python")}, entry: Controller}}
worlds:
  - {{map: create/example.map, config: "", name: two_rooms}}
hidden_worlds:
  - {{map: secret_maze.map, config: "", name: secret_maze}}
seeds: [0]
duration_s: 2
time_limit_s: 8
metrics: [distance_m, bumps]
score: distance_m - 0.5 * bumps
max_score: 1
students: [alice, mallory, bob, carol, dave]
course: ../course
"""
    path = teacher / "bump_turn.yaml"
    path.write_text(text)
    (teacher / "bump_turn.yaml").chmod(0o600)
    teacher.chmod(0o700)
    return path


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_a_teacher_grades_good_malicious_broken_and_hanging_submissions(course: Path) -> None:
    path = write_assignment(course)
    a = load_assignment(path)
    students = [make_student(course, k, n) for k, n in enumerate(["alice", "mallory", "bob", "carol", "dave"])]
    alice, mallory, bob, carol, dave = students
    drop = open_assignment(a, students)
    assert stat.S_IMODE(drop.stat().st_mode) == 0o711
    assert stat.S_IMODE((drop / "alice").stat().st_mode) == 0o700
    assert (drop / "alice").stat().st_uid == alice.uid
    assert "secret_maze" not in (drop / "assignment.json").read_text()

    said = as_student(alice, GOOD, ".py", drop)
    assert said.startswith("submitted controller.py for bump_turn as ") and "late" not in said
    targets = [str(drop / "alice" / "controller.py"), str(alice.home / "secret.txt"), str(drop), str(path)]
    assert as_student(mallory, MALICIOUS.format(targets=targets), ".py", drop).startswith("submitted")
    assert as_student(bob, BROKEN, ".py", drop).startswith("submitted")
    assert as_student(carol, HANGS, ".py", drop).startswith("submitted")
    # an m-file to a python assignment is refused; the wrong suffix says which form it takes
    assert "takes a python controller (a .py file)" in as_student(dave, "disp(1)", ".m", drop)
    sub = drop / "alice" / "controller.py"
    assert stat.S_IMODE(sub.stat().st_mode) == 0o600 and sub.stat().st_uid == alice.uid

    book, _ = grade(a, students, domains=DOMAINS, jobs=4)

    rows = {r["student_id"]: r for r in read_csv(book)}
    assert stat.S_IMODE(book.stat().st_mode) == 0o600
    assert list(rows) == ["alice", "mallory", "bob", "carol", "dave"]
    assert list(rows["alice"])[:8] == [
        "assignment", "duedate", "timestamp", "student_id", "raw_score", "late_submission_penalty", "score", "max_score"
    ]  # fmt: skip
    good = rows["alice"]
    assert good["errors"] == "" and good["episodes"] == "2" and good["failed"] == "0"
    assert float(good["distance_m"]) > 0.3 and float(good["score"]) > 0.15
    assert good["score_visible"] and good["score_hidden"]
    bad = rows["mallory"]
    assert float(bad["score"]) == 0.0 and bad["failed"] == "2"
    assert "STOLEN" not in bad["errors"] and "secret" not in bad["errors"]
    assert "time limit 8.0 s" in bad["errors"], bad["errors"]
    assert "ValueError: forgot to set the gains" in rows["bob"]["errors"]
    assert float(rows["bob"]["score"]) == 0.0
    assert "time limit 8.0 s" in rows["carol"]["errors"] and rows["carol"]["failed"] == "2"
    assert rows["dave"]["errors"] == "nothing submitted"
    # nothing of any grading uid is left running (mallory's sleeping children included)
    assert all(processes_of(UID_BASE + d) == [] for d in DOMAINS)

    for s in (alice, mallory, bob, carol):
        folder = s.home / "feedback" / "bump_turn"
        assert stat.S_IMODE(folder.stat().st_mode) == 0o700 and folder.stat().st_uid == s.uid
        names = sorted(p.name for p in folder.iterdir())
        for p in folder.iterdir():
            assert stat.S_IMODE(p.stat().st_mode) == 0o600 and p.stat().st_uid == s.uid
            assert b"secret_maze" not in p.read_bytes()
        episodes = read_csv(folder / "episodes.csv")
        assert [e["world"] for e in episodes] == ["two_rooms", "hidden 1"]
        assert "hidden 1: mean score" in (folder / "summary.txt").read_text()
        # a replay of the worst episode for those whose episodes ran (mallory's and bob's were
        # refused before the sweep: their controllers never got past their constructor)
        replay = ["worst_episode.mcap"] if s in (alice, carol) else []
        assert names == sorted(["episodes.csv", "scores.png", "summary.txt", *replay]), (s.name, names)
    assert (alice.home / "feedback/bump_turn/worst_episode.mcap").read_bytes()[:5] == b"\x89MCAP"
    assert "score " + rows["alice"]["score"] in (alice.home / "feedback/bump_turn/summary.txt").read_text()
    assert not (dave.home / "feedback" / "bump_turn" / "worst_episode.mcap").exists()


def test_a_submission_after_the_deadline_is_refused_with_a_sentence_or_marked_late(course: Path) -> None:
    path = write_assignment(course, deadline="2026-01-01T00:00:00+01:00")
    a = load_assignment(path)
    alice = make_student(course, 0, "alice")
    drop = open_assignment(a, [alice])
    late = datetime.datetime(2026, 1, 2, tzinfo=datetime.UTC)
    said = as_student(alice, GOOD, ".py", drop, now=late)
    assert said == (
        "refused: bump_turn closed at its deadline, 2026-01-01T00:00:00+01:00: "
        "submissions are no longer taken (your teacher may reopen it)"
    )
    path = write_assignment(course, deadline="2026-01-01T00:00:00+01:00", late="mark")
    a = load_assignment(path)
    open_assignment(a, [alice])
    assert as_student(alice, GOOD, ".py", drop, now=late).endswith("(after the deadline: marked late)")


def test_a_bad_assignment_file_names_its_line_and_field(course: Path) -> None:
    path = write_assignment(course)
    text = path.read_text().replace("deadline: 2099-01-01T00:00:00+00:00", "deadline: 2099-01-01T00:00:00")
    path.write_text(text)
    with pytest.raises(InputError, match=r"bump_turn.yaml:2: field 'deadline': .*give its zone"):
        load_assignment(path)
    path.write_text(text.replace("deadline: 2099-01-01T00:00:00", "deadline: 2099-01-01T00:00Z").replace(
        "score: distance_m - 0.5 * bumps", "score: distance_m - 0.5 * bumpz"))  # fmt: skip
    with pytest.raises(InputError, match=r"bump_turn.yaml:13: field 'score': 'bumpz' is not one of the metrics"):
        load_assignment(path)


def test_grading_on_ray_gives_the_gradebook_of_grading_here(course: Path) -> None:
    """``classroom grade --ray``: the contained run starts a Ray of its own (``--ray`` without an
    address; with one, the course's cluster) and its episodes give the scores of a local grading."""
    path = write_assignment(course)
    a = load_assignment(path)
    alice = make_student(course, 0, "alice")
    drop = open_assignment(a, [alice])
    assert as_student(alice, GOOD, ".py", drop).startswith("submitted")
    here, _ = grade(a, [alice], domains=[222], feedback=False)
    local = read_csv(here)
    on_ray, grades = grade(a, [alice], domains=[223], ray="", feedback=False)
    rows = read_csv(on_ray)
    assert "episodes (0 already done) -> out [ray (local)]" in (a.grading / "runs" / "alice.log").read_text()
    assert grades[0].error == "", grades[0].error
    assert rows[0]["errors"] == "" and rows[0]["episodes"] == "2"
    same = ("raw_score", "score", "distance_m", "bumps", "episodes", "failed")
    assert {k: rows[0][k] for k in same} == {k: local[0][k] for k in same}
    assert all(processes_of(UID_BASE + d) == [] for d in (222, 223))
