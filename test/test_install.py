"""Installing the package puts executables and ament resources where ROS 2 tools look."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sim_tools.executables import EXECUTABLES as DECLARED

ROOT = Path(__file__).resolve().parent.parent
EXECUTABLES = list(DECLARED)  # declared once, in sim_tools/executables.py


@pytest.fixture(scope="module")
def prefix(tmp_path_factory):
    prefix = tmp_path_factory.mktemp("prefix")
    subprocess.run(
        # --ignore-installed: never uninstall the developer's editable install on the way.
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--ignore-installed",
            "--prefix",
            str(prefix),
            str(ROOT),
        ],
        check=True,
        timeout=600,
    )
    return prefix


def test_ros2_run_finds_every_executable(prefix):
    for name in EXECUTABLES:
        wrapper = prefix / "lib" / "robot_sims" / name
        assert wrapper.is_file(), name
        assert os.access(wrapper, os.X_OK), name
        assert f'run("{name}"' in wrapper.read_text()


def test_ament_index_and_share_files_are_installed(prefix):
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "robot_sims").is_file()
    assert "<name>robot_sims</name>" in (prefix / "share" / "robot_sims" / "package.xml").read_text()
    assert (prefix / "share" / "robot_sims" / "config" / "fastdds_localhost.xml").is_file()


def test_the_matlab_toolbox_is_installed_beside_config(prefix):
    # `robot_sims matlab_path` finds it there: share/robot_sims/config/../matlab/create
    installed = prefix / "share" / "robot_sims" / "matlab" / "create" / "CreateRobot.m"
    assert installed.read_text() == (ROOT / "matlab" / "create" / "CreateRobot.m").read_text()


def test_umbrella_command_lists_the_executables():
    out = subprocess.run(
        [sys.executable, "-c", "import sys; from sim_tools import cli; sys.argv=['rs', '--help']; cli.main()"],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout
    for name in EXECUTABLES:
        assert name in out
    bad = subprocess.run(
        [sys.executable, "-c", "import sys; from sim_tools.cli import run; sys.exit(run('no_such_exe', []))"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert bad.returncode == 2 and "unknown executable 'no_such_exe'" in bad.stderr
