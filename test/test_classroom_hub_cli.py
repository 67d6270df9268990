"""`robot_sims classroom init` and `serve` as a teacher meets them before a hub runs: what they
write, what they refuse, and what they say is missing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sim_tools.classroom.hub_config import closed_folders
from sim_tools.cli import executable_command

pytest.importorskip("jupyterhub", reason="the classroom extra: pip install 'robot_sims[classroom]'")


def classroom(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        executable_command("classroom", list(args)), capture_output=True, text=True, timeout=600, env=env
    )


def test_init_writes_a_private_folder_with_a_config_naming_the_teacher_and_the_limits(tmp_path):
    course = tmp_path / "course"
    done = classroom("init", str(course), "--admin", "teacher", "--domains", "3-9", "--memory", "2G",
                     "--python", sys.executable)  # fmt: skip
    assert done.returncode in (0, 1), done.stderr  # 1: students cannot run this interpreter (below)
    assert course.stat().st_mode & 0o777 == 0o700
    text = (course / "jupyterhub_config.py").read_text()
    compile(text, "jupyterhub_config.py", "exec")
    for line in (
        'c.Authenticator.admin_users = {"teacher"}',
        'c.ClassroomSpawner.domains = "3-9"',
        'c.ClassroomSpawner.memory_limit = "2G"',
        "c.NativeAuthenticator.allowed_failed_logins = 3",
        'c.Spawner.ip = "127.0.0.1"',
        '"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"',
    ):
        assert line in text, line
    again = classroom("init", str(course), "--admin", "teacher")
    assert again.returncode == 2 and "--force" in again.stderr  # an edited config is not overwritten


def test_init_says_which_folder_keeps_students_from_the_venv(tmp_path):
    done = classroom("init", str(tmp_path / "c"), "--admin", "teacher", "--python", sys.executable)
    closed = closed_folders(Path(sys.executable))
    if closed:  # this checkout's venv lies under /root (0700): students could not run it
        assert done.returncode == 1, done.stdout + done.stderr
        assert f"others may not enter {closed[0]}" in done.stderr and "chmod o+x" in done.stderr
        assert "python3 -m venv /opt/robot_sims" in done.stderr
    else:
        assert done.returncode == 0, done.stderr
        assert "students run" in done.stdout


@pytest.mark.parametrize(
    ("option", "value", "says"),
    [
        ("--domains", "50-300", "0 <= FIRST <= LAST <= 232"),
        ("--domains", "many", "expected FIRST-LAST"),
        ("--memory", "lots", "expected a size"),
        ("--admin", "Root Teacher", "must be a Unix user name"),
    ],
)
def test_init_refuses_a_bad_value_naming_it(tmp_path, option, value, says):
    args = {"--admin": "teacher", option: value}
    done = classroom("init", str(tmp_path / "c"), *[word for pair in args.items() for word in pair])
    assert done.returncode == 2 and says in done.stderr and value in done.stderr, done.stderr
    assert not (tmp_path / "c" / "jupyterhub_config.py").exists()


def test_serve_says_what_to_run_when_the_proxy_is_missing(tmp_path):
    course = tmp_path / "c"
    classroom("init", str(course), "--admin", "teacher")
    env = dict(os.environ, PATH=str(tmp_path / "empty"))  # neither configurable-http-proxy nor npm
    done = classroom("serve", str(course), env=env)
    assert done.returncode == 1 and "npm install -g configurable-http-proxy" in done.stderr, done.stderr


def test_serve_without_a_config_says_to_run_init(tmp_path):
    done = classroom("serve", str(tmp_path))
    assert done.returncode == 2 and "robot_sims classroom init" in done.stderr, done.stderr


def test_classroom_lists_its_subcommands():
    done = classroom("--help")
    assert done.returncode == 0 and "init" in done.stdout and "serve" in done.stdout
    unknown = classroom("teach")
    assert unknown.returncode == 2 and "unknown subcommand 'teach'" in unknown.stderr
