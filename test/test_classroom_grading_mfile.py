"""A teacher grades an m-file assignment (``controller: {form: mfile}``): each submission runs in
GNU Octave against the episode's MATLAB bridge, contained like a Python one, into the gradebook
and the students' feedback; a syntax error, an ``exit`` and a program that never returns each
become what they should.

The students are uids without accounts with homes in a 0711 folder of /tmp (as in
test_classroom_grading.py, whose helpers these are). Needs root (the CI container is) and Octave.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from test_batch_forms import toolbox_calls
from test_classroom_grading import as_student, course, make_student, read_csv  # noqa: F401 (course: a fixture)

from sim_tools.classroom.assignment import load_assignment
from sim_tools.classroom.contain import processes_of
from sim_tools.classroom.grade import UID_BASE, grade, open_assignment

pytestmark = [
    pytest.mark.skipif(os.geteuid() != 0, reason="grading as root: runs as other uids"),
    pytest.mark.skipif(shutil.which("octave-cli") is None, reason="octave-cli not installed (CI installs it)"),
]

#: Free grading domains of 217-231 (test_classroom_grading takes 217-221, its _contain 229-230).
DOMAINS = [226, 227, 228, 231]
SPEED = 0.2  # m/s, alice's
DRIVE_S = 1.0  # s, how long alice drives before she stops
DURATION_S = 3.0
FORWARD = f"""\
function lab1(serPort)
% Drive forward, then stop.
SetFwdVelAngVelCreate(serPort, {SPEED}, 0);
pause({DRIVE_S});
SetFwdVelAngVelCreate(serPort, 0, 0);
disp('stopped');
end
"""
SYNTAX_ERROR = """\
function lab1(serPort)
SetFwdVelAngVelCreate(serPort, 0.2, 0);
x = (1 + ;
end
"""
FOREVER = """\
function lab1(serPort)
% Never returns: crawls on, reading the bumpers.
while true
    BumpsWheelDropsSensorsRoomba(serPort);
    SetFwdVelAngVelCreate(serPort, 0.1, 0);
    pause(0.05);
end
end
"""
EXITS = """\
function lab1(serPort)
SetFwdVelAngVelCreate(serPort, 0.2, 0);
exit(0);
end
"""


def write_assignment(folder: Path) -> Path:
    teacher = folder / "teacher"
    teacher.mkdir()
    path = teacher / "lab1.yaml"
    path.write_text(f"""\
name: lab1
deadline: 2099-01-01T00:00:00+00:00
controller: {{form: mfile}}
worlds:
  - {{map: create/example.map, config: "", name: two_rooms}}
seeds: [0]
duration_s: {DURATION_S}
time_limit_s: 60
metrics: [distance_m, bumps]
score: distance_m
students: [alice, bob, carol, dave]
course: ../course
""")
    path.chmod(0o600)
    teacher.chmod(0o700)
    return path


def test_m_file_submissions_are_graded_in_octave_and_broken_ones_are_error_rows(course: Path) -> None:  # noqa: F811
    a = load_assignment(write_assignment(course))
    students = [make_student(course, k, n) for k, n in enumerate(["alice", "bob", "carol", "dave"])]
    drop = open_assignment(a, students)
    for s, program in zip(students, (FORWARD, SYNTAX_ERROR, FOREVER, EXITS), strict=True):
        assert as_student(s, program, ".m", drop).startswith("submitted controller.m for lab1 as ")

    book, grades = grade(a, students, domains=DOMAINS, jobs=4)

    rows = {r["student_id"]: r for r in read_csv(book)}
    alice, bob, carol, dave = (rows[n] for n in ("alice", "bob", "carol", "dave"))
    assert alice["errors"] == "" and alice["episodes"] == "1" and alice["failed"] == "0", alice["errors"]
    assert float(alice["score"]) == float(alice["distance_m"])
    # her two calls, stamped with sim time in her replay: 0.2 m/s for about Octave's 1 s pause (no
    # more: the world never runs ahead of the wall clock; less on a busy machine, where it falls
    # behind), then stopped: not the 0.6 m of driving on to the episode's end
    calls = toolbox_calls(students[0].home / "feedback/lab1/worst_episode.mcap")
    assert [c for _, c in calls] == ["SetFwdVelAngVelCreate(0.200,0.000)", "SetFwdVelAngVelCreate(0.000,0.000)"]
    driven = calls[1][0] - calls[0][0]
    assert 0.2 * DRIVE_S < driven < DRIVE_S + 0.1, calls
    assert abs(float(alice["distance_m"]) - SPEED * driven) < 0.015, (alice["distance_m"], calls)
    assert bob["failed"] == "1" and float(bob["score"]) == 0.0
    assert "OctaveError: parse error near line 3 of file submission.m: syntax error" in bob["errors"], bob["errors"]
    # never returns: stopped at the episode's end, having crawled at 0.1 m/s from its first call
    assert carol["errors"] == "" and carol["failed"] == "0", carol["errors"]
    first = toolbox_calls(students[2].home / "feedback/lab1/worst_episode.mcap")[0][0]
    assert abs(float(carol["distance_m"]) - 0.1 * (DURATION_S - first)) < 0.015, (carol["distance_m"], first)
    assert dave["failed"] == "1" and "submission.m called exit(0) before returning" in dave["errors"], dave["errors"]
    assert all(processes_of(UID_BASE + d) == [] for d in DOMAINS)  # no Octave left running
    episodes = {g.student.name: g.rows for g in grades}
    assert float(episodes["carol"][0]["sim_time_s"]) == DURATION_S
    assert read_csv(students[0].home / "feedback/lab1/episodes.csv")[0]["world"] == "two_rooms"
