"""`robot_sims batch`: whatever a student's controller does, it is that episode's error row, the
sweep goes on, and the table is the same on one worker, two, and Ray.

The students are the shipped ``examples/students/misbehaving.py``: one drives well, the others
raise, call ``sys.exit(3)``, ``os._exit(7)``, segfault, loop forever or allocate without end."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from batch_support import ctrl_c, start_batch, wait_while_running
from test_batch import RAY_CLUSTER, ROOT, batch, rows, write_sweep

SWEEP = """
    worlds: [{map: create/example.map}]
    controllers:
      - students.misbehaving:Driver
      - students.misbehaving:Raises
      - students.misbehaving:Quits
      - students.misbehaving:Exits
      - students.misbehaving:Crashes
      - students.misbehaving:Hangs
      - students.misbehaving:Hogs
    poses: [[0.0, 0.0, 0.0]]
    duration_s: 1
    time_limit_s: 6
    memory_limit_mb: 450
"""
#: What each student's row says (a worker uses about 250 MB by itself: 450 MB leaves room).
REASONS = {
    "Raises": "ValueError: the student's bug (at misbehaving.py:",
    "Quits": "SystemExit: the controller called sys.exit(3) (at misbehaving.py:",
    "Exits": "the episode's process exited with code 7",
    "Crashes": "the episode's process was killed by SIGSEGV",
    "Hangs": "time limit 6.0 s: the episode was stopped",
    "Hogs": "memory limit 450 MB: the episode was stopped",
}


def _sweep_folder(folder: Path) -> Path:
    shutil.copytree(ROOT / "examples" / "students", folder / "students")
    return write_sweep(folder, "sweep.yaml", SWEEP)


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    folder = tmp_path_factory.mktemp("one_worker")
    done = batch(str(_sweep_folder(folder)), "--workers", "1", "--out", "out", "--no-plots", cwd=folder, timeout=120)
    return folder / "out", done


def test_every_way_a_controller_fails_becomes_its_error_row_and_the_sweep_goes_on(one_worker) -> None:
    out, done = one_worker
    assert done.returncode == 0, done.stderr
    table = {r["controller"].split(":")[1]: r for r in rows(out / "episodes.csv")}
    assert len(table) == 7
    assert table["Driver"]["status"] == "ok" and float(table["Driver"]["distance_m"]) > 0.1
    for student, reason in REASONS.items():
        row = table[student]
        assert row["status"] == "error" and row["error"].startswith(reason), (student, row["error"])
        assert row["error"].endswith(f"[log: logs/{row['key']}.log]")


def test_episode_logs_hold_what_the_controllers_printed_and_the_terminal_only_the_progress(one_worker) -> None:
    out, done = one_worker
    table = {r["controller"].split(":")[1]: r for r in rows(out / "episodes.csv")}
    log = {student: (out / "logs" / f"{row['key']}.log").read_text() for student, row in table.items()}
    assert "[create_world]" in log["Driver"]  # the world's start-up line: in its log, not the terminal
    assert "giving up" in log["Quits"]  # the student's print before sys.exit
    assert "Segmentation fault" in log["Crashes"] and "misbehaving.py" in log["Crashes"]  # the crash's stack
    terminal = done.stdout + done.stderr
    assert "[INFO]" not in terminal and "giving up" not in terminal and "Traceback" not in terminal


def test_two_workers_interrupted_and_resumed_give_the_table_of_one_worker(tmp_path: Path, one_worker) -> None:
    sweep = _sweep_folder(tmp_path)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = start_batch([str(sweep), "--workers", "2", "--out", "out", "--no-plots"], tmp_path, env)
    log = tmp_path / "out" / "episodes.jsonl"
    wait_while_running(run, lambda: log.exists() and len(log.read_text().splitlines()) >= 2, within=90)
    workers = subprocess.run(["pgrep", "-P", str(run.pid)], capture_output=True, text=True).stdout.split()
    err = ctrl_c(run)
    assert run.returncode == 130 and "run the same command to resume" in err
    assert workers and not [pid for pid in workers if Path(f"/proc/{pid}").exists()]
    again = batch(str(sweep), "--workers", "2", "--out", "out", "--no-plots", cwd=tmp_path, timeout=120)
    assert again.returncode == 0, again.stderr
    assert "already done" in again.stderr and "7 episodes (0 already done)" not in again.stderr
    one, _ = one_worker
    assert (tmp_path / "out" / "episodes.csv").read_text() == (one / "episodes.csv").read_text()


def test_on_ray_a_failing_controller_is_an_error_row_too_and_the_table_is_the_same(tmp_path: Path, one_worker) -> None:
    sweep = _sweep_folder(tmp_path)
    short = Path("/tmp") / f"ray{os.getpid()}"  # Ray's socket paths must stay short
    env = {"RAY_AUTH_MODE": "disabled", "RAY_TMPDIR": str(short)}
    done = batch(str(sweep), "--ray", "--workers", "2", "--out", "ray", "--no-plots", cwd=tmp_path, extra_env=env)
    assert done.returncode == 0, done.stderr
    one, _ = one_worker
    assert (tmp_path / "ray" / "episodes.csv").read_text() == (one / "episodes.csv").read_text()
    quits = next(r for r in rows(tmp_path / "ray" / "episodes.csv") if r["controller"].endswith("Quits"))
    assert "giving up" in (tmp_path / "ray" / "logs" / f"{quits['key']}.log").read_text()  # sent back from the node


def test_on_a_two_node_ray_cluster_every_failing_controller_is_its_row_and_the_table_is_the_same(
    tmp_path: Path, one_worker
) -> None:
    sweep = _sweep_folder(tmp_path)
    script = tmp_path / "cluster.py"
    script.write_text(RAY_CLUSTER, encoding="utf-8")
    short = Path("/tmp") / f"rayc{os.getpid()}"  # Ray's socket paths must stay short
    env = dict(os.environ, PYTHONPATH=str(ROOT), RAY_AUTH_MODE="disabled", RAY_TMPDIR=str(short))
    done = subprocess.run(
        [sys.executable, str(script), str(sweep), "--out", "cluster", "--no-plots"],
        cwd=tmp_path,
        env=env,
        text=True,
        capture_output=True,
        timeout=240,
    )
    assert done.returncode == 0, done.stderr
    one, _ = one_worker
    assert (tmp_path / "cluster" / "episodes.csv").read_text() == (one / "episodes.csv").read_text()


@pytest.mark.parametrize(
    ("limit", "field"), [("time_limit_s: 0", "time_limit_s"), ("memory_limit_mb: lots", "memory_limit_mb")]
)
def test_a_bad_limit_is_one_line_naming_the_field(tmp_path: Path, limit: str, field: str) -> None:
    body = f"worlds: [{{map: create/example.map}}]\ncontrollers: [create_bump_turn]\nduration_s: 1\n{limit}\n"
    sweep = write_sweep(tmp_path, "bad.yaml", body)
    done = batch(str(sweep), cwd=tmp_path, timeout=60)
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1
    assert done.stderr.startswith(f"error: {sweep}: field '{field}'")


CONSTRUCTORS = """
import os
from rclpy.node import Node


class ExitsWhenBuilt(Node):
    def __init__(self, **kwargs):
        super().__init__("exits_when_built", **kwargs)
        print("building", flush=True)
        os._exit(5)


class HangsWhenBuilt(Node):
    def __init__(self, **kwargs):
        super().__init__("hangs_when_built", **kwargs)
        while True:
            pass
"""


def _constructor_sweep(folder: Path, student: str, extra: str = "") -> Path:
    (folder / "builders.py").write_text(CONSTRUCTORS, encoding="utf-8")
    body = f"worlds: [{{map: create/example.map}}]\ncontrollers: [builders:{student}]\nduration_s: 1\n{extra}"
    return write_sweep(folder, "sweep.yaml", body)


def test_a_controller_that_calls_os_exit_while_it_is_built_is_one_error_naming_it_not_the_end_of_the_cli(
    tmp_path: Path,
) -> None:
    sweep = _constructor_sweep(tmp_path, "ExitsWhenBuilt")
    done = batch(str(sweep), "--out", "out", cwd=tmp_path, timeout=120)
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith(f"error: {sweep}: field 'controllers[0]' (builders:ExitsWhenBuilt): ")
    assert "the check's process exited with code 5 while building it" in line
    assert "its last output: building" in line  # its own output, quoted
    assert not (tmp_path / "out").exists()


def test_a_controller_whose_constructor_never_returns_is_stopped_at_the_sweeps_time_limit(tmp_path: Path) -> None:
    from sim_runtime.errors import InputError
    from sim_tools.batch.isolated_load import load_sweep_isolated

    sweep = _constructor_sweep(tmp_path, "HangsWhenBuilt", "time_limit_s: 4\n")
    expected = r"field 'controllers\[0\]' \(builders:HangsWhenBuilt\): time limit 4.0 s: stopped while building it"
    with pytest.raises(InputError, match=expected):
        load_sweep_isolated(str(sweep), out=str(tmp_path / "out"))
    assert not (tmp_path / "out").exists()


def test_a_limit_stop_names_the_students_function_and_the_sim_time_and_its_log_every_line(one_worker) -> None:
    out, _ = one_worker
    by_name = {r["controller"].split(":")[1]: r for r in rows(out / "episodes.csv")}
    for name, lines in (("Hangs", (66, 67)), ("Hogs", (73, 74))):  # its loop, wherever the stop found it
        row = by_name[name]
        assert (
            row["error"]
            .split(" [log: ")[0]
            .endswith("the episode was stopped at sim time 0.5 s, in fail() of misbehaving.py")
        )
        assert row["sim_time_s"] == "0.5"  # fail_at 0.5 s: the sim got no further
        log = (out / "logs" / f"{row['key']}.log").read_text()
        assert any(f'misbehaving.py", line {n} in fail' in log for n in lines)  # every thread's stack
    assert "(in misbehaving.py:61 in fail)" in by_name["Crashes"]["error"]  # from the crash's Python stack
