"""Reading the YAML files users write (world files, robot configs, scenes); no ROS imports."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

from sim_runtime.errors import InputError


def load_yaml(path: str | os.PathLike[str], what: str) -> Any:
    """Parse the YAML file ``path`` (a ``what``, e.g. "world file", for messages).

    A missing or unreadable file, one that is not UTF-8 text, and a YAML syntax error all become
    an :class:`InputError` naming the file (and the line, where YAML knows it).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError.at(path, None, f"{what} not found") from None
    except UnicodeDecodeError as exc:
        raise InputError.at(path, None, f"{what} is not UTF-8 text (byte {exc.start}): is it the right file?") from None
    except OSError as exc:
        raise InputError.at(path, None, f"cannot read {what}: {exc.strerror or exc}") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise InputError.at(path, None if mark is None else mark.line + 1, f"invalid YAML: {exc}") from None
