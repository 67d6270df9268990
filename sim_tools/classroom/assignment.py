"""An assignment file (YAML): a sweep of ``robot_sims batch`` plus what a course needs around it.

The teacher's file holds everything, hidden worlds included, and stays the teacher's (mode 0600 is
advised): students never read it. :func:`public_part` is what they may see (name, deadline,
controller form, the visible worlds), written beside their drop folders by ``classroom submit
--open``. Every problem is an :class:`~sim_runtime.errors.InputError` naming the file, the line
and the field (``course.yaml:7: field 'deadline': ...``).

```yaml
name: bump_turn                     # a word: folders and the gradebook are named by it
deadline: 2026-12-20T23:59:00+01:00 # ISO 8601 with its zone
late: refuse                        # refuse (default) or mark (graded, flagged, late_penalty off)
late_penalty: 0.2                   # with late: mark, the share of the score taken off
controller: {form: python, entry: main}   # python (module, entry point name) or mfile
worlds:                             # the worlds students know (a batch sweep's worlds)
  - {map: create/example.map, config: "", name: two_rooms}
hidden_worlds:                      # graded, never shown: feedback calls them "hidden 1..n"
  - {map: teacher/maze.map, config: ""}
seeds: [0, 1]
duration_s: 20
metrics: [distance_m, bumps]
score: distance_m - 0.5 * bumps     # per episode, from its metrics; a failed episode scores 0
max_score: 10                       # optional: the gradebook's max_score column
columns: [distance_m, bumps]        # metrics shown per student (default: every metric)
students: [alice, bob]              # Unix users (or group: NAME, the members of a Unix group)
time_limit_s: 30                    # per episode (batch's)
```
"""

from __future__ import annotations

import ast
import datetime
import operator
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import yaml

from sim_runtime.errors import InputError
from sim_runtime.inputfile import read_input_text, shown
from sim_runtime.yamlfile import parse_yaml, read_number, short

Form = Literal["python", "mfile"]
LatePolicy = Literal["refuse", "mark"]
#: The suffix a submitted file of each form must have.
SUFFIXES: dict[str, str] = {"python": ".py", "mfile": ".m"}
#: The sweep fields an assignment passes to ``robot_sims batch`` as they are.
SWEEP_FIELDS = ("seeds", "duration_s", "metrics", "poses", "grid", "time_limit_s", "memory_limit_mb")
KEYS = {
    "name",
    "deadline",
    "late",
    "late_penalty",
    "controller",
    "worlds",
    "hidden_worlds",
    "score",
    "max_score",
    "columns",
    "students",
    "group",
    "course",
    *SWEEP_FIELDS,
}
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_BINARY: dict[type[ast.operator], Callable[[float, float], float]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
}


@dataclass(frozen=True)
class Assignment:
    """A checked assignment file."""

    source: Path
    name: str
    deadline: datetime.datetime
    late: LatePolicy
    late_penalty: float
    form: Form
    entry: str
    worlds: list[dict[str, Any]]
    hidden_worlds: list[dict[str, Any]]
    score: str
    max_score: float | None
    columns: list[str]
    students: list[str]
    group: str | None
    #: The course's folder: ``submissions/<name>/`` and ``grading/<name>/`` are in it.
    course: Path
    sweep: dict[str, Any] = field(default_factory=dict)

    @property
    def submissions(self) -> Path:
        return self.course / "submissions" / self.name

    @property
    def grading(self) -> Path:
        return self.course / "grading" / self.name

    def is_late(self, when: datetime.datetime) -> bool:
        return when > self.deadline

    def episode_score(self, metrics: dict[str, Any]) -> float:
        """The score formula on one episode's metrics (NaN when a metric it uses is NaN)."""
        return evaluate_score(self.score, metrics)


def public_part(a: Assignment) -> dict[str, Any]:
    """What students may read: no hidden world, no path of the teacher's."""
    return {
        "name": a.name,
        "deadline": a.deadline.isoformat(),
        "late": a.late,
        "form": a.form,
        "entry": a.entry,
        "suffix": SUFFIXES[a.form],
        "worlds": [w.get("name", "") for w in a.worlds],
        "hidden_worlds": len(a.hidden_worlds),
        "score": a.score,
    }


def load_assignment(path: str | Path) -> Assignment:
    """Read and check the assignment file ``path``."""
    path = Path(path)
    text = read_input_text(path, "assignment file")
    data = parse_yaml(text, path)
    lines = _top_lines(text)
    r = _Reader(path, lines)
    if not isinstance(data, dict):
        raise InputError.at(shown(path), None, "expected a mapping of fields (name, deadline, worlds, ...)")
    for key in data:
        if key not in KEYS:
            raise r.fail(str(key), f"unknown field; expected one of {', '.join(sorted(KEYS))}")
    name = r.text(data, "name")
    if not _NAME.match(name):
        raise r.fail("name", f"{short(name)}: letters, digits, '_', '.', '-' only (it names folders)")
    late = data.get("late", "refuse")
    if late not in ("refuse", "mark"):
        raise r.fail("late", f"{short(late)}: expected refuse or mark")
    penalty = read_number(data.get("late_penalty", 0.0), r.where("late_penalty"), nonneg=True)
    if penalty > 1.0:
        raise r.fail("late_penalty", f"{penalty:g}: the share of the score taken off is 0..1")
    form, entry = _controller(r, data.get("controller", {"form": "python"}))
    worlds = _worlds(r, data, "worlds", required=True)
    hidden = _worlds(r, data, "hidden_worlds", required=False)
    metrics = data.get("metrics", [])
    metric_names = [_metric_name(m) for m in metrics] if isinstance(metrics, list) else []
    score = r.text(data, "score")
    _check_score(r, score, metric_names)
    columns = data.get("columns", metric_names)
    if not isinstance(columns, list) or not all(isinstance(c, str) for c in columns):
        raise r.fail("columns", f"{short(columns)}: expected a list of metric names")
    students = data.get("students", [])
    if not isinstance(students, list) or not all(isinstance(s, str) and _NAME.match(s) for s in students):
        raise r.fail("students", f"{short(students)}: expected a list of Unix user names")
    group = data.get("group")
    if group is not None and not isinstance(group, str):
        raise r.fail("group", f"{short(group)}: expected a Unix group's name")
    max_score = data.get("max_score")
    return Assignment(
        source=path,
        name=name,
        deadline=_deadline(r, data),
        late=late,
        late_penalty=penalty,
        form=form,
        entry=entry,
        worlds=worlds,
        hidden_worlds=hidden,
        score=score,
        max_score=None if max_score is None else read_number(max_score, r.where("max_score"), nonneg=True),
        columns=columns,
        students=students,
        group=group,
        course=(path.parent / str(data.get("course", "."))).resolve(),
        sweep={k: data[k] for k in SWEEP_FIELDS if k in data},
    )


class _Reader:
    """Errors as ``file:line: field 'x': message`` (the line of the field's key)."""

    def __init__(self, path: Path, lines: dict[str, int]) -> None:
        self.path, self.lines = path, lines

    def where(self, key: str) -> str:
        line = self.lines.get(key.split(".")[0].split("[")[0])
        return f"{shown(self.path)}{f':{line}' if line else ''}: field '{key}'"

    def fail(self, key: str, message: str) -> InputError:
        return InputError(f"{self.where(key)}: {message}")

    def text(self, data: dict[str, Any], key: str) -> str:
        if key not in data:
            raise InputError.at(shown(self.path), None, f"field '{key}' is missing")
        value = data[key]
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, f"expected text, got {short(value)}")
        return value.strip()


def _top_lines(text: str) -> dict[str, int]:
    """The line of each top-level key (for messages)."""
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return {}
    if not isinstance(node, yaml.MappingNode):
        return {}
    return {str(k.value): k.start_mark.line + 1 for k, _ in node.value}


def _deadline(r: _Reader, data: dict[str, Any]) -> datetime.datetime:
    value = data.get("deadline")
    if value is None:
        raise InputError.at(shown(r.path), None, "field 'deadline' is missing (ISO 8601 with a zone)")
    if isinstance(value, datetime.datetime):
        when = value
    else:
        try:
            when = datetime.datetime.fromisoformat(str(value))
        except ValueError:
            raise r.fail("deadline", f"{short(value)}: expected ISO 8601, e.g. 2026-12-20T23:59:00+01:00") from None
    if when.tzinfo is None:
        raise r.fail("deadline", f"{short(str(value))}: give its zone (+01:00, Z): without one it is ambiguous")
    return when


def _controller(r: _Reader, value: Any) -> tuple[Form, str]:
    if not isinstance(value, dict):
        raise r.fail("controller", f"{short(value)}: expected {{form: python|mfile, entry: NAME}}")
    extra = set(value) - {"form", "entry"}
    if extra:
        raise r.fail(f"controller.{sorted(extra)[0]}", "unknown field; expected form, entry")
    form = value.get("form", "python")
    if form not in SUFFIXES:
        raise r.fail("controller.form", f"{short(form)}: expected python or mfile")
    entry = value.get("entry", "main")
    if not isinstance(entry, str) or not entry.isidentifier():
        raise r.fail("controller.entry", f"{short(entry)}: expected a Python name (a class or a function)")
    return form, entry


def _worlds(r: _Reader, data: dict[str, Any], key: str, required: bool) -> list[dict[str, Any]]:
    value = data.get(key, [])
    if not isinstance(value, list) or (required and not value):
        raise r.fail(key, f"{short(value)}: expected a list of worlds (as a batch sweep's)")
    for k, world in enumerate(value):
        if not isinstance(world, dict):
            raise r.fail(f"{key}[{k}]", f"{short(world)}: expected a world entry such as {{map: FILE, config: FILE}}")
    return [dict(w) for w in value]


def _metric_name(metric: Any) -> str:
    if isinstance(metric, dict) and len(metric) == 1:
        return str(next(iter(metric)))
    return str(metric)


def _names(node: ast.AST) -> list[str]:
    return [n.id for n in ast.walk(node) if isinstance(n, ast.Name)]


def _check_score(r: _Reader, score: str, metrics: list[str]) -> None:
    try:
        tree = ast.parse(score, mode="eval").body
        evaluate_score(score, dict.fromkeys(_names(tree), 1.0))
    except (SyntaxError, ValueError) as exc:
        raise r.fail("score", f"{short(score)}: {exc}; expected + - * / of numbers and metric names") from None
    unknown = [n for n in _names(tree) if metrics and n not in metrics and n != "goal_reached"]
    if unknown:
        raise r.fail("score", f"{unknown[0]!r} is not one of the metrics ({', '.join(metrics)})")


def evaluate_score(text: str, values: dict[str, Any]) -> float:
    """``text`` (numbers, names of ``values``, + - * /, brackets) on ``values``."""

    def walk(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id not in values:
                raise ValueError(f"unknown name {node.id!r}")
            return float(values[node.id])
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right = walk(node.left), walk(node.right)
            if isinstance(node.op, ast.Div) and right == 0.0:
                return float("nan")
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
            value = walk(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        raise ValueError("unsupported expression")

    if len(text) > 300:
        raise ValueError("formula too long")
    return walk(ast.parse(text, mode="eval").body)
