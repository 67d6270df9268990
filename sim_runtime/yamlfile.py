"""Reading the YAML files users write (world files, robot configs, scenes); no ROS imports.

:func:`load_yaml` parses a file; :class:`FieldReader` (and the ``read_*`` functions it is made
of) checks the parsed tree field by field. Every world, robot-config and scene loader reads
through them, so each rule (what a number is, what a bad key says) lives here once.
"""

from __future__ import annotations

import ast
import datetime
import math
import operator
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sim_runtime.errors import InputError
from sim_runtime.inputfile import read_input_text, shown
from sim_runtime.limits import MAX_MAGNITUDE

#: Most nodes the aliases of one YAML text may add to its tree (each ``*name`` counting as a copy
#: of everything under its ``&name``). A file sharing a few defaults adds hundreds; a ~2 KB alias
#: bomb ("billion laughs") adds billions, and formatting or walking that tree takes the machine.
MAX_ALIAS_NODES = 100_000


def load_yaml(path: str | os.PathLike[str], what: str) -> Any:
    """Parse the YAML file ``path`` (a ``what``, e.g. "world file", for messages).

    A missing or unreadable file, a FIFO, device or directory, one that is not UTF-8 text, a YAML
    syntax error, aliases expanding beyond :data:`MAX_ALIAS_NODES` nodes and an alias inside its
    own anchor all become an :class:`InputError` naming the file (and the line, where known).
    """
    path = Path(path)
    return parse_yaml(read_input_text(path, what), path)


def parse_yaml(text: str, source: str | os.PathLike[str]) -> Any:
    """Parse YAML ``text`` (from ``source``, for messages) as :func:`load_yaml` does: safe tags
    only, alias expansion bounded before any value is built, every problem an InputError."""
    loader = None
    try:
        loader = yaml.SafeLoader(text)  # it reads the text at once: a NUL is refused here
        node = loader.get_single_node()
        if node is None:
            return None
        _check_aliases(node, source)
        return loader.construct_document(node)
    except InputError:
        raise
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        raise InputError.at(shown(source), line, f"invalid YAML: {short_text(str(exc), 150)}") from None
    except RecursionError:
        raise InputError.at(shown(source), None, "invalid YAML: nested too deeply") from None
    except (ValueError, TypeError, OverflowError) as exc:  # e.g. a date such as 2024-13-45
        raise InputError.at(shown(source), None, f"invalid YAML value: {short_text(str(exc), 120)}") from None
    finally:
        if loader is not None:
            loader.dispose()


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        items: list[yaml.Node] = node.value  # yaml ships no types
        return items
    if isinstance(node, yaml.MappingNode):
        return [part for pair in node.value for part in pair]
    return []


def _check_aliases(root: yaml.Node, source: str | os.PathLike[str]) -> None:
    """Refuse a node graph whose aliases expand to more than MAX_ALIAS_NODES extra nodes, or that
    contains itself. The count runs over the composed graph, each node once (its expanded size
    from its children's), so a bomb costs the size of its text, not of its expansion."""
    size: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, closing = stack.pop()
        key = id(node)
        if closing:
            open_nodes.discard(key)
            total = 1 + sum(size[id(child)] for child in _children(node))
            size[key] = total
            if total - len(size) > MAX_ALIAS_NODES:  # nodes seen so far bound this one's own
                raise InputError.at(
                    shown(source),
                    node.start_mark.line + 1,
                    f"YAML aliases expand to more than {MAX_ALIAS_NODES} nodes (an alias bomb?)",
                )
            continue
        if key in size:
            continue
        if key in open_nodes:
            raise InputError.at(shown(source), node.start_mark.line + 1, "a YAML alias refers to its own anchor")
        open_nodes.add(key)
        stack.append((node, True))
        stack.extend((child, False) for child in _children(node) if id(child) not in size)


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
    limit: float | None = MAX_MAGNITUDE,
) -> float:
    """A YAML number as a float (ints beyond float range refused); with ``expressions``, also a
    string such as ``-pi/2`` or ``165*deg``. A finite number beyond ``±limit`` (by default
    :data:`MAX_MAGNITUDE`, the maps' coordinate bound; None: any) is refused."""
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
    if limit is not None and math.isfinite(x) and abs(x) > limit:
        raise InputError(f"{where}: beyond ±{limit:g}, got {_short(value)}")
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


def check_keys(entry: dict[str, Any], allowed: set[str], where: str) -> None:
    """Every key of the mapping is a string among ``allowed``."""
    odd = [k for k in entry if not isinstance(k, str)]
    if odd:
        raise InputError(f"{where}: field names must be text, got {_short(odd[0])}")
    unknown = [k for k in entry if k not in allowed]
    if unknown:
        raise InputError(f"{where}: unknown field(s) {shown_names(unknown)}; allowed: {', '.join(sorted(allowed))}")


def field_name(key: Any) -> str:
    """A key of the file as a field name in a message: text as written (cut), anything else as a repr."""
    return short_text(key, 40) if isinstance(key, str) else short(key, 40)


def shown_names(names: list[Any], most: int = 3) -> str:
    """The first ``most`` of ``names`` for a message, each cut short ("'a', 'b', … (12 in all)")."""
    text = ", ".join(short(n, 30) for n in names[:most])
    return text if len(names) <= most else f"{text}, … ({len(names)} in all)"


def read_mapping(value: Any, where: str, allowed: set[str] | None = None) -> dict[str, Any]:
    """A YAML mapping whose keys are strings (among ``allowed`` when given)."""
    if not isinstance(value, dict):
        raise InputError(f"{where}: expected a mapping (key: value), got {_short(value)}")
    check_keys(value, allowed if allowed is not None else {k for k in value if isinstance(k, str)}, where)
    return value


_SHORT_CHARS = 60  # of a value in a message: a file can hold megabytes in one field
_SHORT_DEPTH = 8


def short(value: Any, limit: int = _SHORT_CHARS) -> str:
    """A repr of ``value`` for a message, at most ``limit`` characters, made with work of about
    that size whatever the value (a list of a billion shared items, a 60 MB string, a 10,000-digit
    integer, a list containing itself)."""
    parts: list[str] = []
    _emit(value, parts, [limit + 1], 0)
    text = "".join(parts)
    return text if len(text) <= limit else text[: max(limit - 3, 0)] + "..."


def short_text(text: str, limit: int = _SHORT_CHARS) -> str:
    """``text`` (not repr'd) cut to ``limit`` characters."""
    return text if len(text) <= limit else text[: max(limit - 3, 0)] + "..."


_short = short


def _put(text: str, parts: list[str], budget: list[int]) -> None:
    parts.append(text[: max(budget[0], 0)])
    budget[0] -= len(text)


def _emit(value: Any, parts: list[str], budget: list[int], depth: int) -> None:
    if budget[0] <= 0:
        return
    if isinstance(value, (str, bytes)):
        cut = value[: budget[0] + 1]
        _put(repr(cut) if len(cut) == len(value) else repr(cut)[:-1], parts, budget)
    elif isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64 * 3:
        _put(f"<integer of {value.bit_length()} bits>", parts, budget)
    elif value is None or isinstance(value, (bool, int, float, datetime.date)):
        _put(repr(value), parts, budget)
    elif isinstance(value, (list, tuple, set, frozenset, dict)):
        _emit_container(value, parts, budget, depth)
    else:
        _put(f"<{type(value).__name__}>", parts, budget)


def _emit_container(value: Any, parts: list[str], budget: list[int], depth: int) -> None:
    opening, closing = "[]" if isinstance(value, list) else "()" if isinstance(value, tuple) else "{}"
    if depth >= _SHORT_DEPTH:
        _put(f"{opening}...{closing}", parts, budget)
        return
    _put(opening, parts, budget)
    items = iter(value.items() if isinstance(value, dict) else value)
    for i, item in enumerate(items):  # stops at the budget: never walks a huge container
        if budget[0] <= 0:
            return
        if i:
            _put(", ", parts, budget)
        if isinstance(value, dict):
            _emit(item[0], parts, budget, depth + 1)
            _put(": ", parts, budget)
            item = item[1]
        _emit(item, parts, budget, depth + 1)
    _put(closing, parts, budget)


class FieldReader:
    """Typed reads of the fields of one YAML file: each problem is ``InputError('<file>: <field>: …')``.

    ``expressions`` lets numbers be written as formulas of ``pi`` and ``deg`` (the arm formats).
    Field paths are written as the user sees them: ``dh.alpha[2]``, ``links[0].elements[1].color``.
    """

    def __init__(self, path: str | os.PathLike[str], *, expressions: bool = False) -> None:
        self.path = Path(path)
        self.expressions = expressions

    def where(self, field: str) -> str:
        return f"{shown(self.path)}: {field}" if field else shown(self.path)

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
        return read_mapping(value, self.where(field), allowed)

    def require(self, mapping: dict[str, Any], key: str, prefix: str = "") -> Any:
        if key not in mapping:
            raise self.error(f"{prefix}{key}", "missing")
        return mapping[key]
