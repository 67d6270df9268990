"""Each student's feedback, in their own space only: ``~/feedback/<assignment>/`` (0700, theirs).

| file | what |
|---|---|
| ``summary.txt`` | their score (raw, late penalty), the mean score per world, every error |
| ``episodes.csv`` | their episodes: world, seed, status, error, sim time, metrics, score |
| ``scores.png`` | the score of each episode per world (a failed one a cross at 0) |
| ``worst_episode.mcap`` | the bag of their lowest-scoring visible episode (the studio's replay opens it) |

Hidden worlds are named only ``hidden 1`` … ``hidden n`` (their scores shown), and no bag of one is
given (it would show the hidden map). When grading as root the files are written by a child
process running as the student, so a link they left in their home leads nowhere they could not
write themselves.
"""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path
from typing import Any

from sim_tools.classroom.assignment import Assignment
from sim_tools.classroom.gradebook import Grade, gradebook_row

#: Columns of a run's table the feedback leaves out (internal ids and paths).
HIDDEN_COLUMNS = {"key", "controller"}


def feedback_files(a: Assignment, g: Grade) -> dict[str, bytes]:
    """The feedback's file names and contents."""
    files = {"summary.txt": _summary(a, g).encode(), "episodes.csv": _episodes(a, g).encode()}
    if g.rows:
        files["scores.png"] = _plot(a, g)
    worst = _worst_bag(a, g)
    if worst is not None:
        files["worst_episode.mcap"] = worst
    return files


def write_feedback(a: Assignment, g: Grade) -> Path:
    """Write ``g``'s feedback into the student's home; returns its folder."""
    folder = g.student.home / "feedback" / a.name
    files = feedback_files(a, g)
    if os.geteuid() != 0 or g.student.uid == os.geteuid():
        _write_all(folder, files)
        return folder
    pid = os.fork()
    if pid == 0:  # pragma: no cover - checked by its effects
        code = 1
        try:
            os.setgroups([])
            os.setresgid(g.student.gid, g.student.gid, g.student.gid)
            os.setresuid(g.student.uid, g.student.uid, g.student.uid)
            _write_all(folder, files)
            code = 0
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise OSError(f"could not write {g.student.name}'s feedback into {folder}")
    return folder


def _write_all(folder: Path, files: dict[str, bytes]) -> None:
    for part in (folder.parent, folder):
        part.mkdir(mode=0o700, exist_ok=True)
        part.chmod(0o700)
    for old in folder.iterdir():
        if old.is_file() or old.is_symlink():
            old.unlink()
    for name, data in files.items():
        fd = os.open(folder / name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(data)


def _score_of(a: Assignment, row: dict[str, Any]) -> float:
    if row.get("status") != "ok":
        return 0.0
    value = a.episode_score(row)
    return 0.0 if math.isnan(value) else value


def _summary(a: Assignment, g: Grade) -> str:
    book = gradebook_row(a, g)
    lines = [f"{a.name}: {g.student.name}", f"score {book['score']}" + (f" of {a.max_score:g}" if a.max_score else "")]
    if g.late:
        lines.append(f"submitted late: {book['late_submission_penalty']} taken off (raw score {book['raw_score']})")
    if g.submitted:
        lines.append(f"graded submission of {g.submitted.isoformat(timespec='seconds')}")
    lines.append(f"score per episode: {a.score} (a failed episode scores 0)")
    worlds: dict[str, list[float]] = {}
    for row in g.rows:
        worlds.setdefault(str(row["world"]), []).append(_score_of(a, row))
    for world, scores in worlds.items():
        lines.append(f"  {world}: mean score {sum(scores) / len(scores):.4g} over {len(scores)} episodes")
    if book["errors"]:
        lines += ["errors:", *(f"  {e}" for e in str(book["errors"]).split(" ; "))]
    return "\n".join(lines) + "\n"


def _episodes(a: Assignment, g: Grade) -> str:
    out = io.StringIO()
    if not g.rows:
        return "world,status,error\n" + (f',error,"{g.error}"\n' if g.error else "")
    columns = [c for c in g.rows[0] if c not in HIDDEN_COLUMNS] + ["score"]
    writer = csv.DictWriter(out, fieldnames=columns, extrasaction="ignore")
    writer.writeheader()
    for row in g.rows:
        writer.writerow({**row, "score": _score_of(a, row)})
    return out.getvalue()


def _plot(a: Assignment, g: Grade) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    worlds = list(dict.fromkeys(str(r["world"]) for r in g.rows))
    fig, ax = plt.subplots(figsize=(1.6 + 1.2 * len(worlds), 3.2), dpi=80)
    for k, world in enumerate(worlds):
        rows = [r for r in g.rows if r["world"] == world]
        ok = [_score_of(a, r) for r in rows if r.get("status") == "ok"]
        ax.plot([k] * len(ok), ok, "o", color="tab:blue")
        failed = sum(r.get("status") != "ok" for r in rows)
        if failed:
            ax.plot([k] * failed, [0.0] * failed, "x", color="tab:red", markersize=9)
    ax.set_xticks(range(len(worlds)), worlds)
    ax.set_ylabel("score")
    ax.set_title(f"{a.name}: {g.student.name}")
    fig.tight_layout()
    data = io.BytesIO()
    fig.savefig(data, format="png")
    plt.close(fig)
    return data.getvalue()


def _worst_bag(a: Assignment, g: Grade) -> bytes | None:
    """The bag of the lowest-scoring episode on a visible world (None: none recorded)."""
    if g.run is None:
        return None
    visible = [r for r in g.rows if not str(r["world"]).startswith("hidden ") and isinstance(r.get("episode"), int)]
    for row in sorted(visible, key=lambda r: (_score_of(a, r), r["episode"])):
        bags = g.run / "out" / "bags" / f"episode_{row['episode']:05d}"
        if bags.is_symlink() or not bags.is_dir():
            continue
        for bag in sorted(bags.glob("*.mcap")):
            if bag.is_file() and not bag.is_symlink():
                return bag.read_bytes()
    return None
