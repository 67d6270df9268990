"""Parameters that behave: fixed types, ranges in the descriptor, read-only or live.

Every node of the package declares its parameters through :meth:`CheckedNode.declare_checked`.
A parameter is either

- **read-only** (files, initial pose, frames, seed: what the node was built from):
  ``ros2 param set`` answers "Trying to set a read-only parameter", or
- **live** (``real_time_factor``, publication rates, timeouts, …): a new value is checked and,
  if good, applied at once through the parameter's ``on_change``; a bad one is refused with the
  reason, and the node keeps its old value (``ros2 param get`` then reports what is in use).

Whole numbers are accepted where a float is expected, on the command line
(``-p real_time_factor:=0``) and from ``ros2 param set`` (which sends ``0`` as an integer).
"""

from __future__ import annotations

import array
from collections.abc import Callable
from typing import Any, NamedTuple

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from sim_runtime.errors import InputError


def like(default: Any, value: Any) -> Any:
    """``value`` converted to ``default``'s type where that loses nothing, else None."""
    if isinstance(default, bool) or default is None:
        return value if isinstance(value, bool) or default is None else None
    if isinstance(default, float):
        return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
    if isinstance(default, int):
        return value if isinstance(value, int) and not isinstance(value, bool) else None
    if isinstance(default, str):
        return value if isinstance(value, str) else None
    if isinstance(default, list | tuple):
        if not isinstance(value, list | tuple | array.array):
            return None
        items = list(value)
        if default and isinstance(default[0], float):
            if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in items):
                return None
            return [float(v) for v in items]
        return items
    return value


class _Spec(NamedTuple):
    default: Any
    check: Callable[[Any], bool]
    description: str
    on_change: Callable[[Any], None] | None


class ParameterInfo(NamedTuple):
    """A declared parameter as ``--help`` shows it (see :mod:`sim_tools.node_help`)."""

    name: str
    default: Any
    description: str
    live: bool
    bounds: tuple[float, float] | None


def _descriptor(default: Any, description: str, live: bool, bounds: tuple[float, float] | None) -> ParameterDescriptor:
    descriptor = ParameterDescriptor(description=description, read_only=not live)
    if bounds is not None:
        lo, hi = bounds
        if isinstance(default, float):
            descriptor.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
        elif isinstance(default, int) and not isinstance(default, bool):
            descriptor.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=0)]
    return descriptor


class ParametersDescribed(Exception):
    """Ends a describe-only node's constructor once its parameters are declared."""


class CheckedNode(Node):
    """A node whose parameters are declared with :meth:`declare_checked`."""

    #: True in a class made by :func:`sim_tools.node_help.describing`: no rcl node is created and
    #: each declaration is recorded in ``described`` (``--help`` lists them without starting ROS).
    describe_only = False
    described: list[ParameterInfo]
    _checked: dict[str, _Spec]

    def __init__(self, node_name: str, **node_kwargs: Any) -> None:
        if self.describe_only:
            self._checked = {}
            self._parameter_overrides = {}
            self.described = []
            return
        try:
            super().__init__(node_name, **node_kwargs)
        except ParameterException as err:  # rclpy's own parameters, e.g. use_sim_time:=abc
            raise InputError(f"parameter of node {node_name!r}: {err}") from None
        self._checked = {}
        self.add_pre_set_parameters_callback(self._widen_whole_numbers)
        self.add_on_set_parameters_callback(self._check_and_apply)

    def declare_checked(
        self,
        name: str,
        default: Any,
        check: Callable[[Any], bool] | None,
        description: str,
        *,
        live: bool = False,
        on_change: Callable[[Any], None] | None = None,
        bounds: tuple[float, float] | None = None,
    ) -> Any:
        """Declare parameter ``name`` typed like ``default`` and return its starting value.

        ``check`` (and ``bounds``, inclusive, also shown by ``ros2 param describe``) decide which
        values are good. A bad value given at start raises :class:`InputError` naming the
        parameter, the value and what is expected. With ``live=True`` the parameter can be set
        while the node runs: ``on_change(value)`` applies a good value (it may raise
        :class:`InputError` to refuse it after all, e.g. a map file that does not load).
        """
        if bounds is not None:
            lo, hi = bounds
            inner = check

            def check(v: Any, inner: Callable[[Any], bool] | None = inner, lo: float = lo, hi: float = hi) -> bool:
                return lo <= v <= hi and (inner is None or inner(v))

        spec = _Spec(default, check or (lambda _v: True), description, on_change if live else None)
        if self.describe_only:
            self._checked[name] = spec
            self.described.append(ParameterInfo(name, default, description, live, bounds))
            return default
        override = self._parameter_overrides.get(name)
        if override is not None:
            given = override.value
            value = like(default, given)
            if value is None or not self._passes(spec, value):
                raise InputError(f"parameter '{name}' = {given!r} is invalid: {description}")
            # The override takes the declared type (an integer for a float parameter, say) so
            # that rclpy's fixed-type check accepts it.
            self._parameter_overrides[name] = Parameter(name, value=value)
        declared = self.declare_parameter(name, default, _descriptor(default, description, live, bounds))
        self._checked[name] = spec
        return like(default, declared.value)

    def parameters_declared(self) -> None:
        """A node calls this once it has declared every parameter: a describe-only node (``--help``)
        stops here, before it loads files, builds its model or compiles kernels."""
        if self.describe_only:
            raise ParametersDescribed

    @staticmethod
    def _passes(spec: _Spec, value: Any) -> bool:
        try:
            return bool(spec.check(value))
        except (TypeError, ValueError):
            return False

    def _widen_whole_numbers(self, parameters: list[Parameter]) -> list[Parameter]:
        """``ros2 param set node rate 5`` sends an integer: a float parameter takes it as 5.0."""
        widened = []
        for parameter in parameters:
            spec = self._checked.get(parameter.name)
            if spec is not None and isinstance(spec.default, float | list) and parameter.value is not None:
                value = like(spec.default, parameter.value)
                if value is not None and type(value) is not type(parameter.value):
                    parameter = Parameter(parameter.name, value=value)
            widened.append(parameter)
        return widened

    def _check_and_apply(self, parameters: list[Parameter]) -> SetParametersResult:
        for parameter in parameters:
            spec = self._checked.get(parameter.name)
            if spec is None:
                continue  # parameters of rclpy itself (use_sim_time, qos_overrides, …)
            value = like(spec.default, parameter.value)
            if value is None or not self._passes(spec, value):
                return SetParametersResult(
                    successful=False, reason=f"{parameter.name} = {parameter.value!r} refused: {spec.description}"
                )
        for parameter in parameters:
            spec = self._checked.get(parameter.name)
            if spec is not None and spec.on_change is not None:
                try:
                    spec.on_change(like(spec.default, parameter.value))
                except InputError as error:
                    return SetParametersResult(successful=False, reason=f"{parameter.name} refused: {error}")
        return SetParametersResult(successful=True)
