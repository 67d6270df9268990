"""`--help` of every executable and every benchmark: usage and parameters, exit 0,
without starting ROS or a simulation (rclpy ignores --help: a world used to start instead)."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from rclpy.parameter import Parameter

from sim_tools.cli import executable_command
from sim_tools.executables import EXECUTABLES
from sim_tools.node_help import NODE_EXECUTABLES, declared_parameters

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = sorted(p for p in (ROOT / "bench").glob("*.py") if not p.name.startswith("_"))
HELP_SECONDS = 120.0  # a ceiling (a few seconds alone): --help must answer, not start a world or hang


def run_help(argv: list[str]) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=HELP_SECONDS)


@pytest.fixture(scope="module")
def executable_helps() -> dict[str, subprocess.CompletedProcess]:
    """`robot_sims <exe> --help` for every executable, four at a time."""
    with ThreadPoolExecutor(4) as pool:
        runs = pool.map(lambda name: run_help(executable_command(name, ["--help"])), EXECUTABLES)
        return dict(zip(EXECUTABLES, runs, strict=True))


@pytest.mark.parametrize("name", list(EXECUTABLES))
def test_every_executable_answers_help_with_its_usage_and_exit_0(executable_helps, name):
    done = executable_helps[name]
    assert done.returncode == 0, done.stderr
    assert "usage:" in done.stdout and name in done.stdout.split("\n", 1)[0]
    if name in NODE_EXECUTABLES:
        assert "parameters" in done.stdout


def _real_node(executable: str):
    import numpy as np

    from sim_tools.node_help import node_class
    from simrobot_sim.world_file import RobotSpec, WorldSpec

    cls = node_class(executable)
    if executable == "simrobot_world":
        return cls(WorldSpec(walls=np.zeros((10, 10), dtype=bool), robots=(RobotSpec("r", (0.05, 0.05)),)))
    if executable == "create_world":
        return cls(parameter_overrides=[Parameter("map_file", value="")])
    if executable == "policy_controller":  # it needs a policy file to start
        from sim_tools.rl.policy import MlpPolicy

        path = Path(tempfile.mkdtemp()) / "policy.npz"
        MlpPolicy.zeros(3, (), [-1.0, -1.0], [1.0, 1.0], env_id="robot_sims/CreateNav-v0").save(path)
        return cls(parameter_overrides=[Parameter("policy", value=str(path))])
    return cls()


@pytest.mark.parametrize("executable", list(NODE_EXECUTABLES))
def test_a_nodes_help_lists_every_parameter_the_node_declares_with_type_default_and_description(
    ros, executable, executable_helps
):
    node = _real_node(executable)
    try:
        real = {name: spec for name, spec in node._checked.items()}
    finally:
        node.destroy_node()
    described = {info.name: info for info in declared_parameters(executable)}
    assert set(described) == set(real)  # nothing the node declares is missing from --help
    shown = executable_helps[executable].stdout
    for name, spec in real.items():
        assert described[name].description == spec.description
        assert f"  {name} (" in shown and spec.description.split()[0] in shown


def test_a_nodes_help_starts_no_ros_context():
    code = (
        "import rclpy\nfrom sim_tools.cli import run\n"
        f"for name in {list(NODE_EXECUTABLES)!r}:\n"
        "    assert run(name, ['-h']) == 0\n"
        "    assert not rclpy.ok(), name\n"
    )
    done = run_help([sys.executable, "-c", code])
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize(
    ("executable", "builder"),
    [
        ("create_world", "create_sim.world_node:CreateWorldNode._make_model"),
        ("simrobot_world", "simrobot_sim.world_node:SimrobotWorld.compile_kernels"),
        ("arm", "arm_sim.arm_node:ArmNode._add_arms"),
    ],
)
def test_a_worlds_help_stops_after_its_declarations_before_it_builds_or_compiles_its_model(
    monkeypatch, executable, builder
):
    import importlib

    module, attribute = builder.split(":")
    owner_name, method = attribute.split(".")
    owner = getattr(importlib.import_module(module), owner_name)
    built: list[str] = []
    monkeypatch.setattr(owner, method, lambda *_args, **_kwargs: built.append(method))
    assert declared_parameters(executable)
    assert built == []  # on a cold numba cache building the model would compile for half a minute


def test_help_after_ros_args_is_a_ros_argument_not_ours():
    from sim_tools.node_help import wants_help

    assert wants_help(["--help"]) and wants_help(["-h", "--ros-args", "-p", "a:=1"])
    assert not wants_help(["--ros-args", "-p", "help:=1", "--help"])


@pytest.fixture(scope="module")
def benchmark_helps() -> dict[Path, subprocess.CompletedProcess]:
    """`bench/<script>.py --help` for every benchmark, four at a time."""
    with ThreadPoolExecutor(4) as pool:
        runs = pool.map(lambda script: run_help([sys.executable, str(script), "--help"]), BENCHMARKS)
        return dict(zip(BENCHMARKS, runs, strict=True))


@pytest.mark.parametrize("script", BENCHMARKS, ids=lambda p: p.name)
def test_every_benchmark_answers_help_with_its_usage_and_exit_0_without_running(benchmark_helps, script):
    done = benchmark_helps[script]
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage:")
