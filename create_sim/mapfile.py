"""Create map files, in the original's text format (unchanged).

One element per row; ``%`` starts a comment (whole row or trailing); blank rows, any spaces or
tabs between fields and around the row are fine; keywords are case-insensitive::

    wall x1 y1 x2 y2            % a wall segment the robot cannot cross
    line x1 y1 x2 y2            % a painted line the cliff sensors see
    beacon x y [r g b] id       % a coloured beacon for the camera; id keeps its case
    virtwall x y theta setting  % virtual-wall emitter facing theta (rad), setting 1, 2 or 3

A row with an unknown keyword is skipped with a warning naming file and line (as the original),
but a file none of whose rows is known (``/etc/passwd``, a PNG) is refused; a known row with a
bad value raises :class:`InputError` naming file, line and value. Warnings go to ``warn`` (a
node's logger), or by default to Python's :mod:`warnings`. Coordinates
are bounded to ±1,000 km (:data:`MAX_COORDINATE_M`): far beyond any room, and small enough that
every distance between two points of a map is an ordinary float.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim_runtime.errors import InputError
from sim_runtime.inputfile import read_input_text
from sim_runtime.limits import MAX_COORDINATE_M

#: Unrecognised rows reported one by one; beyond these, one warning counts the rest.
MAX_REPORTED_ROWS = 10

Warn = Callable[[str], None]
"""Where a parser's warnings go, e.g. a node's ``get_logger().warning``."""

_BEACON_RE = re.compile(r"^(\S+)\s+(\S+)\s+\[([^\]]*)\]\s*(.*)$")


@dataclass
class CreateMap:
    """The map's elements as arrays (world frame, metres and radians)."""

    walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    beacon_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    beacon_rgb: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    beacon_ids: list[str] = field(default_factory=list)
    virtwalls: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))

    def to_text(self) -> str:
        """The map in the file format, numbers written exactly (``parse_map`` gives it back)."""
        rows = ["% robot_sims Create map: wall/line x1 y1 x2 y2, beacon x y [r g b] id, virtwall x y theta setting"]
        rows += ["wall " + " ".join(repr(float(v)) for v in w) for w in self.walls]
        rows += ["line " + " ".join(repr(float(v)) for v in w) for w in self.lines]
        for xy, rgb, beacon_id in zip(self.beacon_xy, self.beacon_rgb, self.beacon_ids, strict=True):
            rows.append(
                f"beacon {float(xy[0])!r} {float(xy[1])!r} [{' '.join(repr(float(c)) for c in rgb)}] {beacon_id}"
            )
        for x, y, theta, setting in self.virtwalls:
            rows.append(f"virtwall {float(x)!r} {float(y)!r} {float(theta)!r} {int(setting)}")
        return "\n".join(rows) + "\n"


def split_row(raw: str) -> list[str]:
    """Tokens of one row: the comment (from the first ``%``) removed, split on any whitespace."""
    return raw.split("%", 1)[0].split()


def _cut(text: str, limit: int = 60) -> str:
    """repr of a row's text for a message, cut (a row can be megabytes long)."""
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "..."


def parse_number(token: str, what: str, source: str, line: int) -> float:
    """A finite float, or InputError naming the file, line, field and the offending token."""
    try:
        value = float(token)
    except ValueError:
        raise InputError.at(source, line, f"{what}: {_cut(token)} is not a number") from None
    if not math.isfinite(value):
        raise InputError.at(source, line, f"{what}: {_cut(token)} is not a finite number")
    return value


def parse_coordinate(token: str, what: str, source: str, line: int) -> float:
    """A number within ±MAX_COORDINATE_M, or InputError naming the file, line, field and token."""
    value = parse_number(token, what, source, line)
    if abs(value) > MAX_COORDINATE_M:
        raise InputError.at(source, line, f"{what}: {_cut(token)} is beyond ±{MAX_COORDINATE_M:g} m")
    return value


def _numbers(tokens: list[str], names: tuple[str, ...], keyword: str, source: str, line: int) -> list[float]:
    if len(tokens) == len(names) and names[-1] not in ("theta", "setting"):
        # The common row, fast: the same float() as parse_number; anything odd is reported below.
        try:
            values = [float(t) for t in tokens]
        except ValueError:
            values = []
        if values and all(-MAX_COORDINATE_M <= v <= MAX_COORDINATE_M for v in values):
            return values
    if len(tokens) != len(names):
        raise InputError.at(
            source,
            line,
            f"'{keyword}' needs {len(names)} numbers ({' '.join(names)}), got {len(tokens)}: {_cut(' '.join(tokens))}",
        )
    return [
        parse_number(t, f"{keyword} {n}", source, line)
        if n in ("theta", "setting")
        else parse_coordinate(t, f"{keyword} {n}", source, line)
        for t, n in zip(tokens, names, strict=True)
    ]


def _beacon(tokens: list[str], source: str, line: int) -> tuple[list[float], list[float], str]:
    body = " ".join(tokens)
    match = _BEACON_RE.match(body)
    if match is None:
        raise InputError.at(source, line, f"'beacon' needs x y [r g b] id, got {body!r}")
    x_tok, y_tok, colour, beacon_id = match.groups()
    xy = [parse_coordinate(x_tok, "beacon x", source, line), parse_coordinate(y_tok, "beacon y", source, line)]
    colour_tokens = colour.replace(",", " ").split()
    if len(colour_tokens) != 3:
        raise InputError.at(source, line, f"beacon colour needs 3 values [r g b], got [{colour}]")
    rgb = [parse_number(t, f"beacon {n}", source, line) for t, n in zip(colour_tokens, "rgb", strict=True)]
    for value, name in zip(rgb, "rgb", strict=True):
        if not 0.0 <= value <= 1.0:
            raise InputError.at(source, line, f"beacon {name} = {value!r} is outside 0..1")
    id_tokens = beacon_id.split()
    if len(id_tokens) != 1:
        raise InputError.at(source, line, f"beacon id must be one word, got {beacon_id!r}")
    return xy, rgb, id_tokens[0]


def python_warning(message: str) -> None:
    """The default :data:`Warn`: a ``UserWarning`` (shown on stderr, or caught by a caller)."""
    warnings.warn(message, stacklevel=4)


def report_skipped(
    skipped: list[tuple[int, str]], recognised: int, source: str, expected: str, warn: Warn | None
) -> None:
    """Warn about each unrecognised row (line number, text; at most :data:`MAX_REPORTED_ROWS`, then
    a count); refuse a file that had rows but none of them recognised: it is not a file of this kind."""
    if skipped and not recognised:
        number, row = skipped[0]
        raise InputError.at(
            source,
            None,
            f"none of its {len(skipped)} rows is a {expected} row: is it the right file? (line {number}: {row[:80]!r})",
        )
    say = warn or python_warning
    for number, row in skipped[:MAX_REPORTED_ROWS]:
        say(f"{source}:{number}: unrecognized row {row[:80]!r} skipped (expected {expected})")
    if len(skipped) > MAX_REPORTED_ROWS:
        say(f"{source}: {len(skipped) - MAX_REPORTED_ROWS} more unrecognized rows skipped")


def parse_map(text: str, source: str = "<string>", warn: Warn | None = None) -> CreateMap:
    """Parse map-file text; ``source`` names the file in warnings and errors, ``warn`` receives the
    warnings (default: Python's :mod:`warnings`)."""
    walls: list[list[float]] = []
    lines: list[list[float]] = []
    beacon_xy: list[list[float]] = []
    beacon_rgb: list[list[float]] = []
    beacon_ids: list[str] = []
    virtwalls: list[list[float]] = []
    skipped: list[tuple[int, str]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        tokens = split_row(raw)
        if not tokens:
            continue
        keyword = tokens[0].lower()
        args = tokens[1:]
        if keyword == "wall":
            walls.append(_numbers(args, ("x1", "y1", "x2", "y2"), keyword, source, number))
        elif keyword == "line":
            lines.append(_numbers(args, ("x1", "y1", "x2", "y2"), keyword, source, number))
        elif keyword == "beacon":
            xy, rgb, beacon_id = _beacon(args, source, number)
            beacon_xy.append(xy)
            beacon_rgb.append(rgb)
            beacon_ids.append(beacon_id)
        elif keyword == "virtwall":
            x, y, theta, setting = _numbers(args, ("x", "y", "theta", "setting"), keyword, source, number)
            if setting not in (1.0, 2.0, 3.0):
                raise InputError.at(source, number, f"virtwall setting {args[3]!r} must be 1, 2 or 3")
            virtwalls.append([x, y, theta, setting])
        else:
            skipped.append((number, raw.strip()))
    recognised = len(walls) + len(lines) + len(beacon_ids) + len(virtwalls)
    report_skipped(skipped, recognised, source, "wall, line, beacon or virtwall", warn)
    return CreateMap(
        walls=np.array(walls, dtype=np.float64).reshape(-1, 4),
        lines=np.array(lines, dtype=np.float64).reshape(-1, 4),
        beacon_xy=np.array(beacon_xy, dtype=np.float64).reshape(-1, 2),
        beacon_rgb=np.array(beacon_rgb, dtype=np.float64).reshape(-1, 3),
        beacon_ids=beacon_ids,
        virtwalls=np.array(virtwalls, dtype=np.float64).reshape(-1, 4),
    )


def read_text_file(path: str | Path, kind: str) -> str:
    """A text file's contents, or InputError naming it when it is missing, unreadable, or not a
    regular file (a FIFO, a device, a directory)."""
    return read_input_text(path, f"{kind} file", errors="replace")


def load_map(path: str | Path, warn: Warn | None = None) -> CreateMap:
    """Read and parse a map file (``warn``: as :func:`parse_map`)."""
    return parse_map(read_text_file(path, "map"), str(path), warn)
