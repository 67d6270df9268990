"""The gradebook (``grading/<assignment>/gradebook.csv``, 0600): a row per student.

Its first columns are those of nbgrader's ``export`` CSV (``assignment, duedate, timestamp,
student_id, raw_score, late_submission_penalty, score, max_score``), which the import scripts of
learning platforms read; then the episodes' counts, the visible and hidden worlds' scores, the
assignment's ``columns`` (each metric's mean over the student's ok episodes) and every error.
"""

from __future__ import annotations

import csv
import datetime
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sim_tools.classroom.assignment import Assignment

#: The gradebook's first columns: those of nbgrader's ``export`` CSV, which LMS import scripts read.
NBGRADER_COLUMNS = (
    "assignment",
    "duedate",
    "timestamp",
    "student_id",
    "raw_score",
    "late_submission_penalty",
    "score",
    "max_score",
)


@dataclass(frozen=True)
class Student:
    """A student as the grading needs them: their user and home."""

    name: str
    uid: int
    gid: int
    home: Path


@dataclass
class Grade:
    """One student's grading: their episodes' rows (world names as the feedback shows them)."""

    student: Student
    submitted: datetime.datetime | None
    late: bool
    rows: list[dict[str, Any]] = field(default_factory=list)
    error: str = ""
    run: Path | None = None
    #: Why the student's feedback could not be written ("": it was).
    feedback_error: str = ""

    def episode_scores(self, a: Assignment) -> list[float]:
        scores = []
        for row in self.rows:
            value = a.episode_score(row) if row.get("status") == "ok" else 0.0
            scores.append(0.0 if math.isnan(value) else value)
        return scores

    def raw_score(self, a: Assignment) -> float:
        if self.error:
            return 0.0
        scores = self.episode_scores(a)
        return sum(scores) / len(scores) if scores else 0.0

    def penalty(self, a: Assignment) -> float:
        return self.raw_score(a) * a.late_penalty if self.late else 0.0


def metric_means(a: Assignment, g: Grade) -> dict[str, float]:
    """Each gradebook column's mean over the student's ok episodes."""
    means = {}
    for column in a.columns:
        values = [
            float(r[column]) for r in g.rows if r.get("status") == "ok" and isinstance(r.get(column), int | float)
        ]
        values = [v for v in values if not math.isnan(v)]
        means[column] = round(sum(values) / len(values), 6) if values else float("nan")
    return means


def gradebook_row(a: Assignment, g: Grade) -> dict[str, Any]:
    raw = g.raw_score(a)
    penalty = g.penalty(a)
    failed = [r for r in g.rows if r.get("status") != "ok"]
    visible = [
        sc for sc, r in zip(g.episode_scores(a), g.rows, strict=True) if not str(r["world"]).startswith("hidden ")
    ]
    hidden = [sc for sc, r in zip(g.episode_scores(a), g.rows, strict=True) if str(r["world"]).startswith("hidden ")]
    errors = [g.error] if g.error else []
    errors += sorted({f"{r['world']}: {r.get('error', '')}" for r in failed})
    row: dict[str, Any] = {
        "assignment": a.name,
        "duedate": a.deadline.isoformat(),
        "timestamp": g.submitted.isoformat(timespec="seconds") if g.submitted else "",
        "student_id": g.student.name,
        "raw_score": round(raw, 6),
        "late_submission_penalty": round(penalty, 6),
        "score": round(raw - penalty, 6),
        "max_score": "" if a.max_score is None else a.max_score,
        "late": g.late,
        "episodes": len(g.rows),
        "failed": len(failed),
        "score_visible": round(sum(visible) / len(visible), 6) if visible else "",
        "score_hidden": round(sum(hidden) / len(hidden), 6) if hidden else "",
    }
    row.update(metric_means(a, g))
    row["errors"] = " ; ".join(errors)[:2000]
    return row


def write_gradebook(a: Assignment, grades: Sequence[Grade]) -> Path:
    """``grading/<assignment>/gradebook.csv`` (0600): a row per student."""
    rows = [gradebook_row(a, g) for g in grades]
    path = a.grading / "gradebook.csv"
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW, 0o600)
    with os.fdopen(fd, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else list(NBGRADER_COLUMNS))
        writer.writeheader()
        writer.writerows(rows)
    path.chmod(0o600)
    return path
