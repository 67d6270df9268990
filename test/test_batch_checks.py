"""`robot_sims batch` meets a teacher's mistakes and a class's broken submissions: every one is
found before any episode runs, named with its field (and file:line), all of them in one run; the
broken ones can be graded as error rows; nothing of a run is left behind after Ctrl-C.

Each sweep runs as a teacher runs it (``robot_sims batch`` in its own process) or through the
Python API (``load_sweep``); episodes are a fraction of a sim second."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from batch_support import ctrl_c, start_batch, wait_while_running
from test_batch import ROOT, batch, rows, write_sweep

from sim_runtime.errors import InputError
from sim_tools.batch.sweep import load_sweep

#: Students' submissions: one that works (and declares ``turn_s``), and one per way of breaking
#: before the first step.
BUILDERS = """
import ctypes

import numpy as np
from geometry_msgs.msg import Twist
from rclpy.node import Node


class Fine(Node):
    def __init__(self, **kwargs):
        super().__init__("fine", **kwargs)
        self.turn_s = self.declare_parameter("turn_s", 1.0).value
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)


class Raises(Node):
    def __init__(self, **kwargs):
        super().__init__("raises", **kwargs)
        raise ValueError("forgot to set the gains")


class Segfaults(Node):
    def __init__(self, **kwargs):
        super().__init__("segfaults", **kwargs)
        ctypes.string_at(0)


class Hangs(Node):
    def __init__(self, **kwargs):
        super().__init__("hangs", **kwargs)
        while True:
            pass


class Hogs(Node):
    def __init__(self, **kwargs):
        super().__init__("hogs", **kwargs)
        self.hoard = [np.ones(50_000_000 // 8) for _ in range(60)]  # 3 GB
"""
CREATE = "worlds: [{map: create/example.map}]\nduration_s: 0.2\n"


def line_of(code: str) -> int:
    """The line number of ``code`` in builders.py."""
    return next(n for n, line in enumerate(BUILDERS.splitlines(), start=1) if code in line)


def _class_folder(folder: Path) -> Path:
    (folder / "builders.py").write_text(BUILDERS, encoding="utf-8")
    (folder / "typo.py").write_text("import numpyy\n", encoding="utf-8")
    return folder


@pytest.mark.parametrize(
    ("controllers", "worlds", "field", "says"),
    [
        (
            "[{name: alice, use: 'builders:Fine'}, {name: alice, use: create_bump_turn}]",
            "[{map: create/example.map}]",
            "controllers[1].name",
            "name 'alice' is given twice (also at controllers[0].name)",
        ),
        (
            "[create_bump_turn, create_bump_turn]",
            "[{map: create/example.map}]",
            "controllers[1]",
            "name 'create_bump_turn' is given twice (also at controllers[0])",
        ),
        (
            "[create_bump_turn]",
            "[{map: create/example.map}, {map: create/example.map}]",
            "worlds[1]",
            "name 'example' is given twice (also at worlds[0])",
        ),
    ],
)
def test_two_controllers_or_worlds_of_one_name_are_refused_before_any_episode_naming_the_field(
    tmp_path: Path, controllers: str, worlds: str, field: str, says: str
) -> None:
    _class_folder(tmp_path)
    sweep = write_sweep(tmp_path, "sweep.yaml", f"worlds: {worlds}\ncontrollers: {controllers}\nduration_s: 0.2\n")
    done = batch(str(sweep), "--out", "out", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith(f"error: {sweep}: field '{field}': {says}: give every"), line
    assert not (tmp_path / "out").exists()  # nothing ran


@pytest.mark.parametrize(
    ("lines", "field", "says"),
    [
        ("seeds: [0, 1, 0]\n", "seeds[2]", "seed 0 is given twice (also at seeds[0])"),
        ("poses: [[0, 0, 0], [0.0, 0.0, 0.0]]\n", "poses[1]", "pose (0.0, 0.0, 0.0) is given twice (also at poses[0])"),
        ("grid: {turn_s: [0.5, 0.5]}\n", "grid.turn_s[1]", "value 0.5 is given twice (also at grid.turn_s[0])"),
        ("poses: [[-10, 0, 0]]\n", "poses[0]", "[-10.0, 0.0, 0.0]: outside the map (its walls span x -2..4 m"),
        ("poses: [[-2.0, 0, 0]]\n", "poses[0]", "[-2.0, 0.0, 0.0]: the robot (a circle of radius 0.1"),
    ],
)
def test_a_value_given_twice_or_a_start_pose_off_the_map_is_refused_by_load_sweep(
    tmp_path: Path, lines: str, field: str, says: str
) -> None:
    sweep = write_sweep(_class_folder(tmp_path), "sweep.yaml", CREATE + "controllers: ['builders:Fine']\n" + lines)
    with pytest.raises(InputError) as caught:
        load_sweep(sweep)
    assert str(caught.value).startswith(f"{sweep}: field '{field}': {says}"), caught.value


def test_a_map_row_that_does_not_parse_fails_the_sweep_with_file_and_line_unless_told_to_warn(tmp_path: Path) -> None:
    (tmp_path / "room.map").write_text("wall -2 -2 2 -2\nwal 2 -2 2 2\nwall -2 2 2 2\n", encoding="utf-8")
    body = "worlds: [{map: room.map}]\ncontrollers: [create_bump_turn]\nposes: [[0, 0, 0]]\nduration_s: 0.2\n"
    sweep = write_sweep(tmp_path, "sweep.yaml", body)
    done = batch(str(sweep), "--out", "out", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.strip().splitlines()
    where = f"{(tmp_path / 'room.map').resolve()}:2: unrecognized row 'wal 2 -2 2 2' skipped"
    assert line.startswith(f"error: {sweep}: field 'worlds[0].map': {where}"), line
    assert "file_warnings: warn" in line and not (tmp_path / "out").exists()

    sweep.write_text(body + "file_warnings: warn\n", encoding="utf-8")
    done = batch(str(sweep), "--out", "out", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    first, second = done.stderr.splitlines()[:2]
    assert first == f"warning: worlds[0].map: {where} (expected wall, line, beacon or virtwall)"
    assert second.startswith(f"{sweep}: 1 episodes (0 already done)")  # said before any episode
    assert [r["status"] for r in rows(tmp_path / "out" / "episodes.csv")] == ["ok"]


def test_a_class_of_30_with_5_broken_submissions_names_all_5_in_one_run(tmp_path: Path) -> None:
    _class_folder(tmp_path)
    students = [f"{{name: s{k:02d}, use: 'builders:Fine'}}" for k in range(25)]
    broken = {
        3: ("Raises", f"ValueError: forgot to set the gains (at builders.py:{line_of('raise ValueError')})"),
        8: ("Segfaults", f"killed by SIGSEGV while building it, in builders.py:{line_of('string_at')} in __init__"),
        13: ("Hangs", "time limit 8.0 s: stopped while building it, in __init__() of builders.py"),
        18: ("Hogs", "memory limit 600 MB: stopped while building it, in "),  # __init__ or its list's frame
        23: ("typo", "cannot import 'typo:Node': ModuleNotFoundError: No module named 'numpyy'"),
    }
    for k, (student, _) in sorted(broken.items()):
        use = "typo:Node" if student == "typo" else f"builders:{student}"
        students.insert(k, f"{{name: {student.lower()}, use: '{use}'}}")
    body = CREATE + f"controllers: [{', '.join(students)}]\ntime_limit_s: 8\nmemory_limit_mb: 600\n"
    sweep = write_sweep(tmp_path, "sweep.yaml", body)
    done = batch(str(sweep), "--out", "out", cwd=tmp_path, timeout=300)
    assert done.returncode == 2, done.stderr
    head, *named = done.stderr.strip().splitlines()
    assert head.startswith(f"error: {sweep}: 5 of 30 controllers cannot run (fix them, or run with --broken-as-rows")
    assert len(named) == 5
    for line, (k, (student, reason)) in zip(named, sorted(broken.items()), strict=True):
        assert line.startswith(f"  field 'controllers[{k}]"), line
        assert f"({student.lower()}): " in line and reason in line, line
    assert not (tmp_path / "out").exists()  # nothing ran


def test_broken_as_rows_grades_them_as_error_rows_and_summary_txt_lists_every_failure(tmp_path: Path) -> None:
    (tmp_path / "course").mkdir()
    folder = _class_folder(tmp_path / "course")
    body = CREATE + textwrap.dedent(
        """\
        controllers: [create_bump_turn, {name: alice, use: 'builders:Fine'}, {name: bob, use: 'builders:Raises'},
                      {name: carol, use: 'typo:Node'}]
        grid: {turn_s: [0.5, 1.5]}
        poses: [[0, 0, 0]]
        out: results
        """
    )
    sweep = write_sweep(folder, "sweep.yaml", body)
    done = batch(str(sweep), "--broken-as-rows", cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    out = folder / "results"
    table = rows(out / "episodes.csv")
    # create_bump_turn does not declare turn_s: once, not once per value
    assert [(r["controller"], r["param.turn_s"]) for r in table] == [
        ("create_bump_turn", ""),
        ("alice", "0.5"),
        ("alice", "1.5"),
        ("bob", "0.5"),
        ("bob", "1.5"),
        ("carol", "0.5"),
        ("carol", "1.5"),
    ]
    assert [r["status"] for r in table] == ["ok"] * 3 + ["error"] * 4
    bob = "refused before the sweep: field 'controllers[2]': bob failed before its first step: ValueError: forgot"
    assert all(r["error"].startswith(bob) for r in table[3:5])
    carol = "refused before the sweep: field 'controllers[3].use': cannot import 'typo:Node': ModuleNotFoundError"
    assert all(r["error"].startswith(carol) for r in table[5:])
    summary = (out / "summary.txt").read_text()
    assert summary.startswith("7 episodes: 3 ok, 4 failed\n")
    for r in table[3:]:
        assert f"  episode {r['episode']} ({r['controller']} on example): {r['error']}\n" in summary
    assert "grid turn_s: swept for alice; not for create_bump_turn (it does not declare it" in summary
    assert "spread per group" in summary and (out / "plots" / "distance_m.png").exists()
    assert "refused, graded as error rows: field 'controllers[2]' (bob)" in done.stderr

    # the folder moved elsewhere resumes: its keys do not hold its absolute path
    moved = tmp_path / "elsewhere" / "course"
    moved.parent.mkdir()
    shutil.move(folder, moved)
    again = batch(str(moved / "sweep.yaml"), "--broken-as-rows", "--no-plots", cwd=tmp_path, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "7 episodes (3 already done)" in again.stderr
    assert rows(moved / "results" / "episodes.csv") == table
    assert len((moved / "results" / "episodes.jsonl").read_text().splitlines()) == 3  # refused: checked again


def test_ctrl_c_while_a_submission_is_being_checked_leaves_no_scratch_folder(tmp_path: Path) -> None:
    _class_folder(tmp_path)
    sweep = write_sweep(tmp_path, "sweep.yaml", CREATE + "controllers: ['builders:Hangs']\n")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = dict(os.environ, PYTHONPATH=str(ROOT), TMPDIR=str(scratch))
    run = start_batch([str(sweep), "--out", "out"], tmp_path, env)
    # building Hangs now
    wait_while_running(run, lambda: next(iter(scratch.glob("robot_sims-sweep-*/stage.json")), None), within=90)
    err = ctrl_c(run)
    assert run.returncode == 130, err
    assert list(scratch.iterdir()) == []


def test_ctrl_c_on_ray_leaves_no_scratch_folder_of_its_workers(tmp_path: Path) -> None:
    shutil.copytree(ROOT / "examples" / "students", tmp_path / "students")
    body = CREATE.replace("0.2", "1") + "controllers: ['students.misbehaving:Hangs']\ntime_limit_s: 120\n"
    sweep = write_sweep(tmp_path, "sweep.yaml", body)
    scratch, short = tmp_path / "tmp", Path("/tmp") / f"rayk{os.getpid()}"  # Ray's socket paths must stay short
    scratch.mkdir()
    env = dict(os.environ, PYTHONPATH=str(ROOT), TMPDIR=str(scratch), RAY_AUTH_MODE="disabled", RAY_TMPDIR=str(short))
    run = start_batch([str(sweep), "--ray", "--workers", "1", "--out", "out"], tmp_path, env)
    try:
        # a Ray worker runs it
        wait_while_running(run, lambda: next(iter(scratch.glob("robot_sims_batch_*/*/episode.log")), None), 180)
        err = ctrl_c(run)
        assert run.returncode == 130, err
        assert list(scratch.iterdir()) == []
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
        shutil.rmtree(short, ignore_errors=True)


STUCK = """
import rclpy
from rclpy.node import Node


def main():
    rclpy.init()
    node = Node("stuck")
    rclpy.spin_once(node, timeout_sec=0.1)
    count = 0
    while True:
        count += 1
"""
#: The Python API in a process of its own, with main()'s wall-time allowance cut to 2 s.
RUN_FIRST_EPISODE = """
import json, sys
from sim_tools.batch import forms
forms.TURN_TIMEOUT = 2.0
from sim_tools.batch.episode import run_episode
from sim_tools.batch.sweep import load_sweep
print(json.dumps(run_episode(load_sweep(sys.argv[1]).episodes[0])["row"].columns()))
"""


def test_a_main_that_never_comes_back_to_spin_names_its_own_function_and_the_sim_time(tmp_path: Path) -> None:
    import json

    (tmp_path / "stuck.py").write_text(STUCK, encoding="utf-8")
    sweep = write_sweep(tmp_path, "sweep.yaml", CREATE + "controllers: ['stuck:main']\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run(
        [sys.executable, "-c", RUN_FIRST_EPISODE, str(sweep)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 0, done.stderr
    row = json.loads(done.stdout.strip().splitlines()[-1])
    assert row["status"] == "error"
    assert row["error"].startswith("MainStuck: stuck:main ran 2 s of wall time without coming back to a spin call")
    assert row["error"].endswith(f"; main() is in main() of stuck.py, at sim time {row['sim_time_s']:g} s")
    assert 'stuck.py", line 1' in done.stderr  # its stack, lines included, in the episode's output
    assert 0 < row["sim_time_s"] < 0.2 and "forms.py" not in row["error"]
