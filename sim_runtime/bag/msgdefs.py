"""Message definitions for MCAP schemas, as rosbag2's message-definition cache builds them.

`full_definition('sensor_msgs/msg/LaserScan')` returns the type's `.msg` text followed by every
dependency's text, each after a line of 80 ``=`` and ``MSG: pkg/Type`` (dependencies in sorted
order, depth first, each once) — byte for byte what `ros2 bag record -s mcap` puts in a `ros2msg`
schema, so Foxglove, `mcap-ros2-support` and `rosbags` decode our bags.

The `.msg` files come from the installed interface packages' share folders: every prefix in
`AMENT_PREFIX_PATH`, then this Python environment's prefix (pip-installed ROS wheels put
`share/<pkg>/msg/` there).
"""

from __future__ import annotations

import functools
import importlib
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Definition", "full_definition", "share_prefixes"]

_DELIMITER = "=" * 80 + "\n"

_PRIMITIVE_TYPES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
        "wstring",
        "time",
        "duration",
    }
)

# rosbag2's MSG_FIELD_TYPE_REGEX: the type word starting a field or constant line
# ("foo_msgs/Bar" in "foo_msgs/Bar[] bar").
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_TYPE_NAME = re.compile(r"^([a-zA-Z0-9_]+)/(?:msg/)?([a-zA-Z0-9_]+)$")


@dataclass(frozen=True)
class Definition:
    """A schema's text and the types whose `.msg` could not be found (empty when complete)."""

    text: str
    missing: tuple[str, ...]


def share_prefixes() -> list[Path]:
    """Install prefixes searched for `share/<pkg>/msg/*.msg`, in search order."""
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    prefixes.append(Path(sys.prefix))
    return list(dict.fromkeys(prefixes))


@functools.cache
def _msg_text(package: str, name: str) -> str | None:
    for prefix in share_prefixes():
        path = prefix / "share" / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path.read_text()
    return None


_IDL_TO_MSG = {"boolean": "bool", "octet": "byte", "float": "float32", "double": "float64"}
_SEQUENCE = re.compile(r"^sequence<([^,>]+)(?:,\s*(\d+))?>$")
_BOUNDED_STRING = re.compile(r"^(w?string)<(\d+)>$")


def _msg_type_of(idl_type: str) -> str:
    """A field type as rosidl's Python classes spell it ('sequence<float, 5>') in .msg syntax."""
    match = _SEQUENCE.match(idl_type)
    if match:
        bound = f"<={match.group(2)}" if match.group(2) else ""
        return f"{_msg_type_of(match.group(1).strip())}[{bound}]"
    if idl_type.endswith("]"):
        base, _, size = idl_type[:-1].rpartition("[")
        return f"{_msg_type_of(base)}[{size}]"
    match = _BOUNDED_STRING.match(idl_type)
    if match:
        return f"{match.group(1)}<={match.group(2)}"
    return _IDL_TO_MSG.get(idl_type, idl_type)


def _text_from_python_class(package: str, name: str) -> str | None:
    """Field list rebuilt from the installed Python message class (constants and comments
    are lost), for a type whose .msg file is not installed."""
    try:
        cls = getattr(importlib.import_module(f"{package}.msg"), name)
        fields = cls.get_fields_and_field_types()
    except (ImportError, AttributeError):
        return None
    return "".join(f"{_msg_type_of(t)} {field}\n" for field, t in fields.items())


def _dependencies(text: str, package: str) -> list[str]:
    deps = set()
    for match in _FIELD_TYPE.finditer(text):
        field_type = match.group(1)
        if field_type in _PRIMITIVE_TYPES:
            continue
        deps.add(field_type if "/" in field_type else f"{package}/{field_type}")
    return sorted(deps)


@functools.cache
def full_definition(type_name: str) -> Definition:
    """Schema text for `type_name` (``pkg/msg/Type`` or ``pkg/Type``) with all dependencies.

    Types whose `.msg` is not installed are listed in `Definition.missing` (the caller warns);
    their text is rebuilt from the installed Python class when there is one (fields only),
    else left out (the root's text is then empty if the root itself is unknown).
    """
    seen: set[str] = set()
    missing: list[str] = []

    def text_of(dep_name: str) -> str:
        match = _TYPE_NAME.match(dep_name)
        text = _msg_text(match.group(1), match.group(2)) if match else None
        if text is None:
            missing.append(dep_name)
            text = _text_from_python_class(match.group(1), match.group(2)) if match else None
            if text is None:
                return ""
        assert match is not None  # text is only found for a well-formed type name
        result = text
        for dep in _dependencies(text, match.group(1)):
            if dep not in seen:
                seen.add(dep)
                body = text_of(dep)
                if body:
                    result += f"\n{_DELIMITER}MSG: {dep}\n{body}"
        return result

    return Definition(text_of(type_name), tuple(missing))
