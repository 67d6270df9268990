"""Every executable turns bad input into one clear line on stderr and exit status 2, and stops
cleanly on SIGTERM, as a user running it from a terminal or a script relies on."""

from __future__ import annotations

import importlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from rosgraph_msgs.msg import Clock

from sim_runtime.testing import Collector, spin_until
from sim_tools.cli import executable_command
from sim_tools.executables import EXECUTABLES

ROOT = Path(__file__).resolve().parent.parent


def run_exe(name: str, *args: str, **popen) -> subprocess.Popen:
    """``robot_sims <name> args...`` from this checkout, in its own process."""
    return subprocess.Popen(
        executable_command(name, args),
        cwd=ROOT,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        **popen,
    )


@pytest.fixture(scope="module")
def garbage(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bad") / "garbage.yaml"
    path.write_bytes(bytes(range(256)) * 4)
    return path


def bad_inputs(garbage: Path, tmp: Path) -> dict[str, tuple[list[str], str]]:
    existing = tmp / "existing_bag"
    existing.mkdir(exist_ok=True)
    return {
        "create_world": (["--ros-args", "-p", "map_file:=/no/such.map"], "/no/such.map"),
        "simrobot_world": (["--ros-args", "-p", f"world_file:={garbage}"], str(garbage)),
        "arm": (["--ros-args", "-p", f"robot_config_file:={garbage}"], str(garbage)),
        "record": (["-o", str(existing)], str(existing)),
        "replay": (["/no/such/bag"], "/no/such/bag"),
        "bag_to_rerun": (["/no/such/bag"], "/no/such/bag"),
        "draw_tracks": (["/no/such/bag", "-o", str(tmp / "t.png")], "/no/such/bag"),
    }


@pytest.mark.parametrize(
    "name", ["create_world", "simrobot_world", "arm", "record", "replay", "bag_to_rerun", "draw_tracks"]
)
def test_bad_input_exits_2_naming_the_file(name, garbage, tmp_path):
    args, named = bad_inputs(garbage, tmp_path)[name]
    process = run_exe(name, *args)
    _out, err = process.communicate(timeout=120)
    assert process.returncode == 2, err
    assert named in err and "Traceback" not in err, err


@pytest.mark.parametrize(
    ("name", "parameter", "named"),
    [
        ("simrobot_world", "world_file:=0", "'world_file' = 0"),  # a number where a file name goes
        ("create_world", "use_sim_time:=abc", "use_sim_time"),  # one of rclpy's own parameters
        ("create_world", "qos_overrides./scan.publisher.history:=abc", "/scan"),
    ],
)
def test_a_parameter_of_the_wrong_kind_exits_2_naming_it(name, parameter, named):
    process = run_exe(name, "--ros-args", "-p", parameter)
    _out, err = process.communicate(timeout=120)
    assert process.returncode == 2 and named in err and "Traceback" not in err, err


def test_unparsable_ros_arguments_exit_2_without_a_traceback():
    process = run_exe("create_world", "--ros-args", "-p", "map_file:=")  # a parameter rule with no value
    _out, err = process.communicate(timeout=120)
    assert process.returncode == 2 and "invalid ROS arguments" in err and "Traceback" not in err, err


@pytest.mark.parametrize(
    ("name", "args"),
    [
        ("create_world", []),
        ("simrobot_world", ["-p", "world_file:=" + str(ROOT / "config/simrobot/demo.yaml")]),
        ("arm", []),
    ],
)
def test_worlds_stop_cleanly_on_sigterm(name, args, executor, make_node):
    process = run_exe(name, "--ros-args", "-p", "real_time_factor:=1.0", *args)
    try:
        clock = Collector(make_node("probe"), Clock, "/clock", 10)
        assert spin_until(executor, lambda: clock.msgs or process.poll() is not None, timeout=60)
        assert process.poll() is None and clock.msgs, process.communicate()[1]  # it is stepping
        process.send_signal(signal.SIGTERM)
        _out, err = process.communicate(timeout=30)
        assert process.returncode == 0, err
        assert "Traceback" not in err and "FATAL" not in err, err
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()


def test_help_lists_every_executable_with_what_it_does():
    console_script = Path(sys.executable).with_name("robot_sims")
    done = subprocess.run(
        [str(console_script), "--help"],
        capture_output=True,
        text=True,
        timeout=60,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("usage: robot_sims <executable>")
    for name, (target, what) in EXECUTABLES.items():
        (line,) = [line for line in lines if line.split()[:1] == [name]]
        assert line.split(None, 1)[1] == what, line
        assert target not in done.stdout  # what it does, not where it lives


def test_every_declared_executable_has_a_main_and_a_description():
    for name, (target, what) in EXECUTABLES.items():
        module, function = target.split(":")
        assert callable(getattr(importlib.import_module(module), function)), name
        assert what and "\n" not in what and len(what) < 80, name


def test_the_executables_page_lists_each_executable_at_its_entry_point():
    rows = {}
    for line in (ROOT / "docs" / "executables.md").read_text().splitlines():
        cells = [cell.strip().strip("`") for cell in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0] in EXECUTABLES:
            rows[cells[0]] = cells[1]
    assert rows == {name: target for name, (target, _what) in EXECUTABLES.items()}
