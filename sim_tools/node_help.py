"""``robot_sims <node executable> --help``: usage and every parameter, without starting ROS.

The parameters come from where each node declares them (:meth:`CheckedNode.declare_checked`): the
node's class is built in describe mode (:func:`describing`), where no rcl node exists and every
method of rclpy's ``Node`` does nothing, so the constructor runs through its declarations without
a ROS context, a topic, or a simulation step; a world's constructor stops at
:meth:`CheckedNode.parameters_declared`, before it builds its model (compiling kernels on a cold
numba cache) or loads meshes.
"""

from __future__ import annotations

import contextlib
import importlib
import textwrap
from typing import TYPE_CHECKING, Any

from sim_tools.adapters.contract import WorldAdapter, world_parts
from sim_tools.executables import EXECUTABLES

if TYPE_CHECKING:  # rclpy is imported only to describe a node: `robot_sims urdf` runs without ROS
    from sim_runtime.params import CheckedNode, ParameterInfo


def _owners() -> dict[str, WorldAdapter]:
    """Node executable → the adapter of the simulator that has it (``NODE_EXECUTABLES``)."""
    return {exe: part for part in world_parts().values() for exe in part.NODE_EXECUTABLES}


def node_executables() -> dict[str, tuple[str, str]]:
    """Node executable → (its node class as ``module:Class``, what follows the name in its usage),
    from every registered simulator's adapter."""
    return {exe: part.NODE_EXECUTABLES[exe] for exe, part in _owners().items()}


def __getattr__(name: str) -> Any:
    # NODE_EXECUTABLES is read from the registry when first asked for, not when this is imported:
    # every `robot_sims` command imports this module.
    if name == "NODE_EXECUTABLES":
        return node_executables()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def wants_help(argv: list[str]) -> bool:
    """Whether ``-h`` or ``--help`` is among the arguments before ``--ros-args``."""
    ours = argv[: argv.index("--ros-args")] if "--ros-args" in argv else argv
    return "-h" in ours or "--help" in ours


class _Nothing:
    """What every rclpy call returns in describe mode: accepts any use and does nothing."""

    def __getattr__(self, _name: str) -> _Nothing:
        return self

    def __call__(self, *_args: Any, **_kwargs: Any) -> _Nothing:
        return self

    def __iter__(self):
        return iter(())

    def __bool__(self) -> bool:
        return False


_NOTHING = _Nothing()
_KEEP = {"get_namespace", "get_name"}  # text the constructors build names from


def _nothing(*_args: Any, **_kwargs: Any) -> _Nothing:
    return _NOTHING


def describing(cls: type[CheckedNode]) -> type[CheckedNode]:
    """A subclass of ``cls`` whose instances declare their parameters and nothing else."""
    from rclpy.node import Node

    members: dict[str, Any] = {"describe_only": True, "get_namespace": lambda _self: "/"}
    members["get_name"] = lambda _self: cls.__name__
    for name, member in vars(Node).items():
        if name.startswith("_") or name in _KEEP:
            continue
        if isinstance(member, property):
            members[name] = property(_nothing)
        elif callable(member):
            members[name] = _nothing
    return type(f"Describing{cls.__name__}", (cls,), members)


def node_class(executable: str) -> type[CheckedNode]:
    module, name = node_executables()[executable][0].split(":")
    return getattr(importlib.import_module(module), name)


def declared_parameters(executable: str) -> list[ParameterInfo]:
    """Every parameter the node of ``executable`` declares, in declaration order."""
    kwargs = _owners()[executable].describe_kwargs(executable)  # a stand-in world where one is needed
    cls = describing(node_class(executable))
    node = cls.__new__(cls)
    # What a constructor does after its declarations may need ROS and fail: the declarations stay.
    with contextlib.suppress(Exception):
        type(node).__init__(node, **kwargs)
    return list(getattr(node, "described", []))


def type_name(value: Any) -> str:
    """The ROS parameter type of a default value, as ``ros2 param describe`` names it."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "double"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list | tuple):
        return f"{type_name(value[0]) if value else 'double'}[]"
    return type(value).__name__


def _line(info: ParameterInfo) -> str:
    facts = [type_name(info.default), f"default {info.default!r}"]
    if info.bounds is not None:
        facts.append("..".join(f"{b:g}" if isinstance(b, float) else str(b) for b in info.bounds))
    if info.live:
        facts.append("live")
    wrapped = textwrap.fill(info.description, width=96, initial_indent="      ", subsequent_indent="      ")
    return f"  {info.name} ({', '.join(facts)})\n{wrapped}"


def help_text(executable: str) -> str:
    """Usage, what the executable does, and each parameter: name, type, default, description."""
    usage = node_executables()[executable][1]
    parameters = declared_parameters(executable)
    return "\n".join(
        [
            f"usage: robot_sims {executable} {usage}",
            f"       ros2 run robot_sims {executable} {usage}",
            "",
            EXECUTABLES[executable][1] if executable in EXECUTABLES else f"the {executable} node",
            "",
            "parameters (-p NAME:=VALUE at start; 'live' ones also later with `ros2 param set`):",
            *(_line(info) for info in parameters),
        ]
    )
