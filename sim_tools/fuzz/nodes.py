"""The world nodes as a command line builds them: the ``node_parameters`` target, and the one ROS
context of a worker process."""

from __future__ import annotations

import importlib
import random
from pathlib import Path
from typing import Any

from sim_tools.fuzz.corpus import Seeds, fuzz_parts, world_nodes
from sim_tools.fuzz_kit import Case, check_finite

_PARAMETER_VALUES = (
    *("0", "-1", "1", "0.5", "1e300", "-1e300", ".nan", ".inf", "-.inf", "1e-300", "9" * 400, "-" + "9" * 30),
    *("true", "false", "''", "abc", "[]", "[1.0, 2.0]", "[.nan, 0.0, 0.0]", "[1e300, 0.0, 0.0]", "[0.0, 0.0, 0.0]"),
    *("[a, b]", "{a: 1}", "'/no/such/file'", "'~'", "'.'", "'config/simrobot/demo_map.png'", "[1, 2, 3]"),
)
_parameter_names: dict[str, list[str]] = {}
_ROS_READY = False


def ensure_ros() -> None:
    """rclpy initialised once per worker: a context per input made and shut down a DDS participant each time."""
    global _ROS_READY
    if not _ROS_READY:
        import rclpy

        rclpy.init(args=[])
        _ROS_READY = True


def required_args(exe: str) -> list[str]:
    """What the world ``exe`` cannot start without (fuzzed ``-p`` values come after, so may replace it)."""
    for part in fuzz_parts():
        if exe in part.required_args:
            return list(part.required_args[exe])
    return []


def file_parameters() -> list[tuple[str, str]]:
    """(world executable, a file parameter of it), of every simulator."""
    return [pair for part in fuzz_parts() for pair in part.file_parameters]


def node_parameters_case(rng: random.Random, seeds: Seeds, folder: Path) -> Case:
    """``robot_sims <world> --ros-args -p name:=value ...``: one to three of the world's own
    parameters set to type-confused, huge, non-finite or missing-file values, parsed by rcl as on
    the command line; the world must build and step with finite state or refuse with InputError."""
    exe = rng.choice(sorted(world_nodes()))
    names = _declared_parameters(exe)
    args = ["--ros-args", *required_args(exe)]
    for name in rng.sample(names, k=min(len(names), rng.randint(1, 3))):
        args += ["-p", f"{name}:={rng.choice(_PARAMETER_VALUES)}"]
    (folder / "argv.txt").write_text("\n".join([exe, *args]) + "\n", encoding="utf-8")
    return Case(folder, lambda: run_world_node(exe, args, steps=3))


def _declared_parameters(exe: str) -> list[str]:
    """The parameters a default world of ``exe`` declares (ROS's own use_sim_time excluded)."""
    if exe not in _parameter_names:
        node = _build_world_node(exe, ["--ros-args", *required_args(exe)])
        try:
            _parameter_names[exe] = sorted(n for n in node._parameters if n != "use_sim_time")
        finally:
            node.destroy_node()
    return _parameter_names[exe]


def _build_world_node(exe: str, args: list[str]) -> Any:
    """The world node of ``exe`` with ``args`` as its own command-line arguments (rcl parses the
    ``-p`` rules as on the command line), in the worker's one ROS context."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    from sim_runtime.errors import InputError

    ensure_ros()
    module, cls = world_nodes()[exe].split(":")
    try:
        return getattr(importlib.import_module(module), cls)(cli_args=list(args))
    except _rclpy.RCLError as error:  # as init_ros does for the executables
        raise InputError(f"invalid ROS arguments {args!r}: {error}") from None


def run_world_node(exe: str, args: list[str], steps: int) -> None:
    """Build the world ``exe`` from ``args``, step it, and require a finite sim time and pose."""
    node = _build_world_node(exe, args)
    try:
        node.step(steps)
        check_finite(node.sim_time, f"{exe} sim time")
        model = getattr(node, "model", None)
        pose = getattr(model, "pose", None)
        if pose is not None:
            check_finite(pose, f"{exe} pose")
    finally:
        node.destroy_node()
