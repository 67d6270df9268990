"""Reading the YAML files users write (world files, robot configs, scenes); no ROS imports.

:func:`load_yaml` parses a file; :class:`FieldReader` (and the ``read_*`` functions it is made
of) checks the parsed tree field by field. Every world, robot-config and scene loader reads
through them, so each rule (what a number is, what a bad key says) lives here once.
"""

from __future__ import annotations

import ast
import math
import operator
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sim_runtime.errors import InputError
from sim_runtime.inputfile import read_input_text


def load_yaml(path: str | os.PathLike[str], what: str) -> Any:
    """Parse the YAML file ``path`` (a ``what``, e.g. "world file", for messages).

    A missing or unreadable file, a FIFO, device or directory, one that is not UTF-8 text, and a
    YAML syntax error all become an :class:`InputError` naming the file (and the line, where YAML
    knows it).
    """
    path = Path(path)
    text = read_input_text(path, what)
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise InputError.at(path, None if mark is None else mark.line + 1, f"invalid YAML: {exc}") from None
    except RecursionError:
        raise InputError.at(path, None, "invalid YAML: nested too deeply") from None
    except (ValueError, TypeError, OverflowError) as exc:  # e.g. a date such as 2024-13-45
        raise InputError.at(path, None, f"invalid YAML value: {exc}") from None


# ---------------------------------------------------------------------------------------------
# Typed reads of a parsed YAML tree. ``where`` names the field for messages, file first
# ("demo.yaml: robots[0] ('r1').position"); :class:`FieldReader` builds it from a file and a
# field path. Whatever the tree holds (huge integers, non-string keys, deep expressions), the
# only error is InputError.
# ---------------------------------------------------------------------------------------------

_CONSTANTS = {"pi": math.pi, "deg": math.pi / 180.0}
_BINARY: dict[type[ast.operator], Callable[[float, float], float]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
}
_UNARY: dict[type[ast.unaryop], Callable[[float], float]] = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_MAX_EXPRESSION_CHARS = 200  # "-pi/2", "165*deg": a formula a person writes, not a program


def _evaluate(node: ast.AST) -> float:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.Name):
        return _CONSTANTS[node.id]
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](_evaluate(node.left), _evaluate(node.right))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_evaluate(node.operand))
    raise ValueError("unsupported expression")


def evaluate_expression(text: str) -> float:
    """The value of an arithmetic expression of numbers, ``pi`` and ``deg`` (+ - * / and brackets).

    ValueError for anything else (names, calls, powers, overlong text, a result beyond float).
    """
    if len(text) > _MAX_EXPRESSION_CHARS:
        raise ValueError("expression too long")
    try:
        return float(_evaluate(ast.parse(text.strip(), mode="eval").body))
    except (SyntaxError, KeyError, ZeroDivisionError, OverflowError, RecursionError, MemoryError):
        raise ValueError("not an expression of numbers, pi and deg") from None


def read_number(
    value: Any,
    where: str,
    *,
    positive: bool = False,
    nonneg: bool = False,
    allow_inf: bool = False,
    expressions: bool = False,
) -> float:
    """A YAML number as a float (ints beyond float range refused); with ``expressions``, also a
    string such as ``-pi/2`` or ``165*deg``."""
    if isinstance(value, bool):
        raise InputError(f"{where}: expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        try:
            x = float(value)
        except OverflowError:
            raise InputError(f"{where}: number out of range, got {_short(value)}") from None
    elif expressions and isinstance(value, str):
        try:
            x = evaluate_expression(value)
        except ValueError:
            raise InputError(
                f"{where}: expected a number or an expression of numbers, pi and deg, got {_short(value)}"
            ) from None
    else:
        raise InputError(f"{where}: expected a number, got {_short(value)}")
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        raise InputError(f"{where}: must be finite, got {_short(value)}")
    if positive and not x > 0:
        raise InputError(f"{where}: must be > 0, got {_short(value)}")
    if nonneg and x < 0:
        raise InputError(f"{where}: must be >= 0, got {_short(value)}")
    return x


def read_integer(value: Any, where: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """A YAML integer (not a bool, not a float) within [minimum, maximum]."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{where}: expected a whole number, got {_short(value)}")
    if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
        bounds = f"{'' if minimum is None else minimum}..{'' if maximum is None else maximum}"
        raise InputError(f"{where}: must be in {bounds}, got {_short(value)}")
    return value


def read_pair(value: Any, where: str, **number_options: Any) -> tuple[float, float]:
    """``[x, y]``: two numbers."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise InputError(f"{where}: expected [x, y], got {_short(value)}")
    return (
        read_number(value[0], f"{where}[0]", **number_options),
        read_number(value[1], f"{where}[1]", **number_options),
    )


def read_bool(value: Any, where: str) -> bool:
    """true/false, 0/1 or on/off."""
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)) and value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.lower() in ("on", "off"):
        return value.lower() == "on"
    raise InputError(f"{where}: expected true/false (or on/off), got {_short(value)}")


def check_keys(entry: dict, allowed: set[str], where: str) -> None:
    """Every key of the mapping is a string among ``allowed``."""
    odd = [k for k in entry if not isinstance(k, str)]
    if odd:
        raise InputError(f"{where}: field names must be text, got {_short(odd[0])}")
    unknown = sorted(set(entry) - allowed)
    if unknown:
        names = ", ".join(map(repr, unknown))
        raise InputError(f"{where}: unknown field(s) {names}; allowed: {', '.join(sorted(allowed))}")


def read_mapping(value: Any, where: str, allowed: set[str] | None = None) -> dict[str, Any]:
    """A YAML mapping whose keys are strings (among ``allowed`` when given)."""
    if not isinstance(value, dict):
        raise InputError(f"{where}: expected a mapping (key: value), got {_short(value)}")
    check_keys(value, allowed if allowed is not None else {k for k in value if isinstance(k, str)}, where)
    return value


def _short(value: Any, limit: int = 80) -> str:
    """repr of a value for a message, cut to ``limit`` characters (a fuzzed file can hold megabytes)."""
    try:
        text = repr(value)
    except (ValueError, RecursionError):  # ints beyond the repr digit limit, self-nesting lists
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


class FieldReader:
    """Typed reads of the fields of one YAML file: each problem is ``InputError('<file>: <field>: …')``.

    ``expressions`` lets numbers be written as formulas of ``pi`` and ``deg`` (the arm formats).
    Field paths are written as the user sees them: ``dh.alpha[2]``, ``links[0].elements[1].color``.
    """

    def __init__(self, path: str | os.PathLike[str], *, expressions: bool = False) -> None:
        self.path = Path(path)
        self.expressions = expressions

    def where(self, field: str) -> str:
        return f"{self.path}: {field}" if field else str(self.path)

    def error(self, field: str, message: str) -> InputError:
        return InputError(f"{self.where(field)}: {message}")

    def number(self, value: Any, field: str, **options: Any) -> float:
        return read_number(value, self.where(field), expressions=self.expressions, **options)

    def integer(self, value: Any, field: str, **options: Any) -> int:
        return read_integer(value, self.where(field), **options)

    def vector(self, value: Any, field: str, length: int | None = None) -> np.ndarray:
        if not isinstance(value, (list, tuple)):
            raise self.error(field, f"expected a list of numbers, got {_short(value)}")
        if length is not None and len(value) != length:
            raise self.error(field, f"expected {length} values, got {len(value)}")
        return np.array([self.number(v, f"{field}[{i}]") for i, v in enumerate(value)], dtype=np.float64)

    def matrix(self, value: Any, field: str, rows: int, cols: int) -> np.ndarray:
        if not isinstance(value, (list, tuple)) or len(value) != rows:
            raise self.error(field, f"expected a {rows}x{cols} matrix (list of {rows} rows), got {_short(value)}")
        return np.array([self.vector(row, f"{field}[{i}]", cols) for i, row in enumerate(value)]).reshape(rows, cols)

    def boolean(self, value: Any, field: str) -> bool:
        return read_bool(value, self.where(field))

    def text(self, value: Any, field: str) -> str:
        """A non-empty string."""
        if not isinstance(value, str) or not value:
            raise self.error(field, f"expected text, got {_short(value)}")
        return value

    def sequence(self, value: Any, field: str) -> list[Any]:
        if not isinstance(value, list):
            raise self.error(field, f"expected a list, got {_short(value)}")
        return value

    def mapping(self, value: Any, field: str, allowed: set[str] | None = None) -> dict[str, Any]:
        return read_mapping(value, self.where(field) if field else str(self.path), allowed)

    def require(self, mapping: dict, key: str, prefix: str = "") -> Any:
        if key not in mapping:
            raise self.error(f"{prefix}{key}", "missing")
        return mapping[key]
