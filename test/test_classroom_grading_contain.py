"""What a grading run cannot do (sim_tools/classroom/contain.py), tried by real processes, and
the teacher's and student's commands' answers (no batch run: fast)."""

from __future__ import annotations

import json
import os
import shutil
import socket
import stat
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import pytest

from sim_tools.classroom import contain
from sim_tools.classroom.contain import Jail, processes_of, run_contained
from sim_tools.classroom.grade import UID_BASE
from studio.create.submit_page import submit_file
from studio.shell.workspace import Workspace

root_only = pytest.mark.skipif(os.geteuid() != 0, reason="containment needs root")
DOMAIN = 230
UID = UID_BASE + DOMAIN


@pytest.fixture
def folder():
    """A run folder owned by the run's uid, in a folder of /tmp others may pass."""
    top = Path(tempfile.mkdtemp(prefix="contain_", dir="/tmp"))
    top.chmod(0o711)
    run = top / "run"
    run.mkdir(mode=0o700)
    os.chown(run, UID, UID)
    yield top
    shutil.rmtree(top, ignore_errors=True)


def jailed(top: Path, code: str, max_processes: int = 64, timeout_s: float = 60) -> str:
    log = top / "log.txt"
    outcome = run_contained(
        [sys.executable, "-c", code],
        top / "run",
        dict(os.environ),
        Jail(UID, UID, DOMAIN, max_processes),
        timeout_s,
        log,
    )
    assert processes_of(UID) == []  # nothing of the run is left, whatever it started
    return f"exit {outcome.returncode}\n" + log.read_text()


@root_only
def test_a_run_sees_no_other_users_files_no_host_network_and_its_own_domain(folder: Path) -> None:
    private = folder / "bobs_home"
    private.mkdir(mode=0o700)
    (private / "secret.txt").write_text("bob's secret")
    os.chown(private, UID + 1, UID + 1)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]
    code = f"""
import os, socket
print("uid", os.getuid(), "cwd", os.getcwd(), "home", os.environ["HOME"], "domain", os.environ["ROS_DOMAIN_ID"])
print("tmp", sorted(os.listdir("/tmp")))
for path in ({str(private / "secret.txt")!r}, "/root/.bashrc"):
    try:
        print("READ", open(path).read())
    except OSError as exc:
        print("refused", type(exc).__name__)
try:
    socket.create_connection(("127.0.0.1", {port}), timeout=2)
    print("CONNECTED")
except OSError as exc:
    print("no host network", type(exc).__name__)
"""
    out = jailed(folder, code)
    server.close()
    assert out.splitlines()[:2] == ["exit 0", f"uid {UID} cwd /tmp/run home /tmp/run domain {DOMAIN}"]
    # the host's /tmp (other users' scratch) is not there; only the run's folder, and this
    # checkout's or venv's folder where they lie in /tmp (the run's Python is there)
    shown = sorted(["run", *{p.relative_to("/tmp").parts[0] for p in contain.interpreter_in_tmp()}])
    assert f"tmp {shown}" in out
    assert "READ" not in out and out.count("refused") == 2
    assert "CONNECTED" not in out and "no host network ConnectionRefusedError" in out


@root_only
def test_a_fork_loop_is_capped_and_a_daemon_that_left_its_session_is_killed(folder: Path) -> None:
    code = """
import os, time
if os.fork() == 0:          # a daemon: a session of its own, out of reach of the run's group kill
    os.setsid()
    if os.fork() == 0:
        time.sleep(3600)
    os._exit(0)
n = 0
try:
    while True:
        if os.fork() == 0:
            time.sleep(3600)
        n += 1
except OSError as exc:
    print("forks stopped at", n, exc.errno)
"""
    out = jailed(folder, code, max_processes=40)
    forks = int(out.split("forks stopped at ")[1].split()[0])
    assert forks < 40 and out.rstrip().endswith(" 11")  # EAGAIN: RLIMIT_NPROC
    # jailed() asserted that no process of the uid survived, the daemon included


@root_only
def test_a_run_that_never_ends_is_stopped_at_its_time_limit(folder: Path) -> None:
    log = folder / "log.txt"
    outcome = run_contained(
        [sys.executable, "-c", "while True: pass"], folder / "run", dict(os.environ), Jail(UID, UID, DOMAIN), 3.0, log
    )
    assert outcome.timed_out and outcome.returncode == -9
    assert processes_of(UID) == []


def test_submit_names_a_missing_assignment_and_the_wrong_form_in_a_sentence(tmp_path: Path) -> None:
    env = dict(os.environ, ROBOT_SIMS_COURSE=str(tmp_path))
    command = [str(Path(sys.executable).parent / "robot_sims"), "classroom", "submit", "bump_turn", "mine.py"]
    done = subprocess.run(command, env=env, capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert done.returncode == 2
    why = "ask your teacher for its name, or whether it is open yet"
    assert done.stderr == f"error: no assignment 'bump_turn' in {tmp_path}/submissions: {why}\n"
    drop = tmp_path / "submissions" / "bump_turn"
    drop.mkdir(parents=True)
    public = {
        "name": "bump_turn",
        "deadline": "2099-01-01T00:00:00+00:00",
        "late": "refuse",
        "form": "mfile",
        "suffix": ".m",
    }
    (drop / "assignment.json").write_text(json.dumps(public))
    (tmp_path / "mine.py").write_text("x = 1\n")
    done = subprocess.run(command, env=env, capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert (done.returncode, done.stderr) == (2, "error: mine.py: bump_turn takes a mfile controller (a .m file)\n")


def test_the_studio_submit_page_hands_in_a_workspace_file_as_the_command_does(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from sim_tools.classroom.submit import current_user

    course, workspace = tmp_path / "course", tmp_path / "work"
    drop = course / "submissions" / "bump_turn"
    (drop / current_user()).mkdir(parents=True)
    (drop / "assignment.json").write_text(
        json.dumps(
            {
                "name": "bump_turn",
                "deadline": "2099-01-01T00:00:00+00:00",
                "late": "refuse",
                "form": "python",
                "suffix": ".py",
            }
        )
    )
    workspace.mkdir()
    (workspace / "ctl.py").write_text("def main():\n    pass\n")
    monkeypatch.setenv("ROBOT_SIMS_COURSE", str(course))
    ok, said = submit_file(Workspace(workspace), "bump_turn", "ctl.py")
    assert ok and said.startswith(f"submitted controller.py for bump_turn as {current_user()} at ")
    stored = drop / current_user() / "controller.py"
    assert stored.read_text() == "def main():\n    pass\n" and stat.S_IMODE(stored.stat().st_mode) == 0o600
    assert json.loads((drop / current_user() / "submitted.json").read_text())["file"] == "ctl.py"
    assert submit_file(Workspace(workspace), "", "ctl.py") == (
        False,
        "give the assignment's name (your teacher gave it)",
    )
    ok, said = submit_file(Workspace(workspace), "bump_turn", "../outside.py")
    assert not ok and "outside the workspace" in said


@root_only
def test_the_teacher_opens_an_assignment_from_the_command_line(folder: Path) -> None:
    homes = folder / "homes"
    for k, name in enumerate(("alice", "bob")):
        (homes / name).mkdir(parents=True, mode=0o700)
        os.chown(homes / name, UID + 10 + k, UID + 10 + k)
    teacher = folder / "teacher"
    teacher.mkdir(mode=0o700)
    (teacher / "a.yaml").write_text(
        "name: lab1\ndeadline: 2099-01-01T00:00:00Z\nworlds: [{map: create/example.map, config: ''}]\n"
        "hidden_worlds: [{map: create/example.map, config: '', name: the_secret_one}]\n"
        "metrics: [distance_m]\nscore: distance_m\nstudents: [alice, bob]\ncourse: ../course\n"
    )
    command = [str(Path(sys.executable).parent / "robot_sims"), "classroom", "grade", str(teacher / "a.yaml")]
    done = subprocess.run([*command, "--open", "--homes", str(homes)], capture_output=True, text=True, timeout=60)
    drop = folder / "course" / "submissions" / "lab1"
    assert (done.returncode, done.stdout) == (0, f"opened {drop} for 2 students\n"), done.stderr
    assert stat.S_IMODE(drop.stat().st_mode) == 0o711
    assert [(p.name, p.stat().st_uid, stat.S_IMODE(p.stat().st_mode)) for p in sorted(drop.iterdir())] == [
        ("alice", UID + 10, 0o700),
        ("assignment.json", 0, 0o644),
        ("bob", UID + 11, 0o700),
    ]
    public = json.loads((drop / "assignment.json").read_text())
    assert public["hidden_worlds"] == 1 and "the_secret_one" not in (drop / "assignment.json").read_text()
    (teacher / "a.yaml").write_text(
        (teacher / "a.yaml").read_text().replace("score: distance_m", "score: distance_m ** 2")
    )
    done = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.startswith(
        f"error: {teacher / 'a.yaml'}:6: field 'score': 'distance_m ** 2': unsupported expression"
    )


def test_a_late_submission_marked_late_loses_its_penalty_and_failed_episodes_score_zero(tmp_path: Path) -> None:
    import datetime

    from sim_tools.classroom.assignment import load_assignment
    from sim_tools.classroom.gradebook import Grade, Student, gradebook_row

    path = tmp_path / "a.yaml"
    path.write_text(
        "name: lab1\ndeadline: 2026-01-01T00:00:00Z\nlate: mark\nlate_penalty: 0.25\nmax_score: 4\n"
        "worlds: [{map: create/example.map, config: ''}]\nmetrics: [distance_m, bumps]\n"
        "score: distance_m - bumps / 2\ncolumns: [distance_m]\n"
    )
    a = load_assignment(path)
    rows = [
        {"world": "example", "status": "ok", "distance_m": 3.0, "bumps": 2},
        {"world": "hidden 1", "status": "ok", "distance_m": 5.0, "bumps": 0},
        {"world": "hidden 1", "status": "error", "error": "ValueError: x", "distance_m": "", "bumps": ""},
    ]
    when = datetime.datetime(2026, 1, 2, tzinfo=datetime.UTC)
    g = Grade(Student("alice", 1, 1, tmp_path), when, a.is_late(when), rows)
    book = gradebook_row(a, g)
    assert book == {
        "assignment": "lab1",
        "duedate": "2026-01-01T00:00:00+00:00",
        "timestamp": "2026-01-02T00:00:00+00:00",
        "student_id": "alice",
        "raw_score": 2.333333,  # (2 + 5 + 0) / 3
        "late_submission_penalty": 0.583333,
        "score": 1.75,
        "max_score": 4.0,
        "late": True,
        "episodes": 3,
        "failed": 1,
        "score_visible": 2.0,
        "score_hidden": 2.5,
        "distance_m": 4.0,
        "errors": "hidden 1: ValueError: x",
    }


@root_only
def test_ctrl_c_in_the_grader_stops_every_run_at_once_and_leaves_no_process(folder: Path) -> None:
    import signal
    import time

    homes = folder / "homes"
    (homes / "carol").mkdir(parents=True, mode=0o700)
    os.chown(homes / "carol", UID + 20, UID + 20)
    teacher = folder / "teacher"
    teacher.mkdir(mode=0o700)
    (teacher / "a.yaml").write_text(
        "name: lab1\ndeadline: 2099-01-01T00:00:00Z\nworlds: [{map: create/example.map, config: ''}]\n"
        "controller: {form: python, entry: main}\nduration_s: 3600\ntime_limit_s: 600\n"
        "metrics: [distance_m]\nscore: distance_m\nstudents: [carol]\ncourse: ../course\n"
    )
    command = [str(Path(sys.executable).parent / "robot_sims"), "classroom", "grade", str(teacher / "a.yaml")]
    options = ["--homes", str(homes), "--domains", str(DOMAIN - 1)]
    subprocess.run([*command, "--open", *options], check=True, capture_output=True, timeout=60)
    mine = folder / "course" / "submissions" / "lab1" / "carol"
    (mine / "controller.py").write_text("def main():\n    while True:\n        pass\n")  # as if submitted
    os.chown(mine / "controller.py", UID + 20, UID + 20)
    grader = subprocess.Popen([*command, *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    run_uid = UID_BASE + DOMAIN - 1
    deadline = time.monotonic() + 120
    while not processes_of(run_uid):  # carol's run has started
        assert grader.poll() is None and time.monotonic() < deadline, grader.communicate()
        time.sleep(0.1)
    # An hour of sim time: however fast or slow the machine, the run is still going at the Ctrl-C.
    time.sleep(2.0)
    grader.send_signal(signal.SIGINT)
    out, err = grader.communicate(timeout=60)
    assert grader.returncode == 130, (out, err)
    assert err.endswith("interrupted: every grading run was stopped; no gradebook was written\n")
    assert processes_of(run_uid) == []
    assert not (folder / "course" / "grading" / "lab1" / "gradebook.csv").exists()


FLOOD = """
import time
import rclpy
from std_msgs.msg import String

rclpy.init()
node = rclpy.create_node("flood")
pub = node.create_publisher(String, "/flood", 10)
end = time.monotonic() + {seconds}
n = 0
while time.monotonic() < end:
    pub.publish(String(data="x"))
    n += 1
    time.sleep(0.001)
print("published", n)
"""


@root_only
def test_a_run_flooding_dds_reaches_no_one_in_its_domain_outside_it(folder: Path) -> None:
    """The same publisher reaches a listener of its domain when run as is (the control), and
    nothing when run contained: its own network namespace, /dev/shm and domain."""
    from std_msgs.msg import String
    from studio_browser_support import listener_node

    got: list[str] = []
    with listener_node(DOMAIN, "flood_listener") as (executor, node):
        node.create_subscription(String, "/flood", lambda m: got.append(m.data), 10)
        env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        control = subprocess.Popen([sys.executable, "-c", FLOOD.format(seconds=4)], env=env)
        while control.poll() is None:
            executor.spin_once(timeout_sec=0.1)
        assert control.returncode == 0 and len(got) > 10  # a listener that hears the flood uncontained
        got.clear()
        log = folder / "log.txt"
        jail = Jail(UID, UID, DOMAIN)
        runs = threading.Thread(
            target=run_contained,
            args=([sys.executable, "-c", FLOOD.format(seconds=6)], folder / "run", env, jail, 120, log),
        )
        runs.start()
        while runs.is_alive():
            executor.spin_once(timeout_sec=0.1)
    assert int(log.read_text().split("published ")[1].split()[0]) > 10, log.read_text()  # it flooded
    assert got == []


def test_after_a_ctrl_c_no_contained_run_starts_until_a_new_grading_allows_runs(tmp_path: Path) -> None:
    # A grading thread still copying its kernels when the grader's Ctrl-C came would otherwise
    # start its run after every run was stopped, and the grader would wait for it at exit.
    command = [sys.executable, "-c", "print('ran')"]
    jail = Jail(None, None, DOMAIN)
    contain.stop_all()
    try:
        with pytest.raises(contain.RunsStopped, match="the grader was interrupted"):
            run_contained(command, tmp_path, dict(os.environ), jail, 60, tmp_path / "refused.log")
    finally:
        contain.allow_runs()
    assert not (tmp_path / "refused.log").exists()
    outcome = run_contained(command, tmp_path, dict(os.environ), jail, 60, tmp_path / "ran.log")
    assert outcome.returncode == 0 and (tmp_path / "ran.log").read_text() == "ran\n"
