"""A sweep's output folder: the resumable log, the table (Parquet + CSV), timings, summary, plots.

``episodes.jsonl`` gets one line per finished episode as it finishes (a killed sweep loses
nothing; a rerun skips the keys found there). The table is rebuilt from it, one row per episode
of the sweep in episode order, so it is the same whatever order the workers finished in.
``timings.csv`` (wall seconds per part of each episode, which worker) is kept apart: the table
holds only what the sweep determines.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any, TextIO

ID_COLUMNS = ("episode", "key", "world", "controller")
STATUS_COLUMNS = ("status", "error", "sim_time_s")


class ResultLog:
    """``episodes.jsonl`` in ``folder``: what is finished, and appending new results."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.path = folder / "episodes.jsonl"
        self.rows: dict[str, dict[str, Any]] = {}
        self.timings: dict[str, dict[str, Any]] = {}
        if self.path.exists():
            for line in self.path.read_text(encoding="utf-8").splitlines():
                try:
                    entry = json.loads(line)
                except json.JSONDecodeError:
                    continue  # a line cut short when a run was killed: that episode runs again
                self.rows[entry["row"]["key"]] = entry["row"]
                self.timings[entry["row"]["key"]] = entry.get("timing", {})
        self._file: TextIO = self.path.open("a", encoding="utf-8")

    def add(self, result: dict[str, Any]) -> None:
        self.rows[result["row"]["key"]] = result["row"]
        self.timings[result["row"]["key"]] = result["timing"]
        self._file.write(json.dumps(result, default=_json_default) + "\n")
        self._file.flush()

    def forget_failed(self) -> None:
        """Drop failed episodes so that they run again."""
        for key in [k for k, row in self.rows.items() if row.get("status") != "ok"]:
            del self.rows[key]

    def close(self) -> None:
        self._file.close()


def _json_default(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    return str(value)


def _column_order(rows: list[dict[str, Any]]) -> list[str]:
    seen: dict[str, None] = {}
    for row in rows:
        for key in row:
            seen.setdefault(key, None)
    first = [c for c in ID_COLUMNS if c in seen]
    params = [c for c in seen if c.startswith("param.") or c.startswith("pose_") or c == "seed"]
    status = [c for c in STATUS_COLUMNS if c in seen]
    rest = [c for c in seen if c not in first and c not in params and c not in status]
    return first + params + status + rest


def table_rows(log: ResultLog, keys: Iterable[str]) -> list[dict[str, Any]]:
    """The logged rows of ``keys`` (the sweep's episodes, in order); missing ones are left out."""
    return [log.rows[k] for k in keys if k in log.rows]


def write_table(rows: list[dict[str, Any]], folder: Path) -> tuple[Path, Path]:
    """``episodes.parquet`` and ``episodes.csv``: one row per episode, every column typed."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    columns = _column_order(rows)
    arrays = {}
    for name in columns:
        values = [row.get(name) for row in rows]
        present = [v for v in values if v is not None]
        if present and all(isinstance(v, bool) for v in present):
            arrays[name] = pa.array(values, type=pa.bool_())
        elif present and all(isinstance(v, int | float) and not isinstance(v, bool) for v in present):
            kind = pa.int64() if all(isinstance(v, int) for v in present) else pa.float64()
            arrays[name] = pa.array(
                [None if v is None else (float(v) if kind == pa.float64() else v) for v in values], kind
            )
        else:
            arrays[name] = pa.array([None if v is None else str(v) for v in values], pa.string())
    table = pa.table(arrays)
    parquet, csv = folder / "episodes.parquet", folder / "episodes.csv"
    pq.write_table(table, parquet)
    pacsv.write_csv(table, csv)
    return parquet, csv


def write_timings(log: ResultLog, keys: list[str], folder: Path) -> Path:
    """``timings.csv``: episode, worker pid, transport and wall seconds of set-up, run, collect."""
    path = folder / "timings.csv"
    fields = ["episode", "pid", "transport", "setup_s", "run_s", "teardown_s", "collect_s", "total_s"]
    lines = [",".join(fields)]
    for key in keys:
        timing = log.timings.get(key)
        if timing:
            lines.append(",".join(_fmt(timing.get(f, "")) for f in fields))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _fmt(value: Any) -> str:
    return f"{value:.6f}" if isinstance(value, float) else str(value)


def metric_columns(rows: list[dict[str, Any]], grid_keys: list[str]) -> list[str]:
    """Numeric columns that are results (not ids, parameters, poses or seeds)."""
    skip = set(ID_COLUMNS) | set(STATUS_COLUMNS) | {"seed"}
    out = []
    for name in _column_order(rows):
        if name in skip or name.startswith("param.") or name.startswith("pose_") or "." in name:
            continue
        values = [row.get(name) for row in rows if row.get("status") == "ok"]
        if values and all(isinstance(v, int | float) and not isinstance(v, bool) for v in values if v is not None):
            out.append(name)
    return out


def summary(rows: list[dict[str, Any]], grid_keys: list[str], out: TextIO = sys.stdout) -> None:
    """Episodes ok/failed, then the mean of each metric per controller (× world, × grid point)."""
    ok = [r for r in rows if r.get("status") == "ok"]
    failed = [r for r in rows if r.get("status") != "ok"]
    print(f"{len(rows)} episodes: {len(ok)} ok, {len(failed)} failed", file=out)
    for row in failed[:5]:
        print(f"  episode {row['episode']} ({row['controller']} on {row['world']}): {row.get('error')}", file=out)
    metrics = metric_columns(rows, grid_keys)
    if not ok or not metrics:
        return
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for row in ok:
        label = (row["controller"], row["world"], *(row.get(f"param.{k}") for k in grid_keys))
        groups.setdefault(label, []).append(row)
    head = ["controller", "world", *grid_keys, "n", *metrics]
    lines = [head]
    for label, members in groups.items():
        means = []
        for m in metrics:
            values = [r[m] for r in members if r.get(m) is not None and not _nan(r[m])]
            means.append(f"{sum(values) / len(values):.4g}" if values else "nan")
        lines.append([*map(str, label), str(len(members)), *means])
    widths = [max(len(line[i]) for line in lines) for i in range(len(head))]
    print("mean per group:", file=out)
    for line in lines:
        print("  " + "  ".join(cell.rjust(w) for cell, w in zip(line, widths, strict=True)), file=out)


def _nan(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


def plots(rows: list[dict[str, Any]], grid_keys: list[str], folder: Path) -> list[Path]:
    """One PNG per metric: against the first grid parameter (a line per controller × world) when
    the sweep has a grid, else a box per controller × world over the seeds and poses."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    series: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in ok:
        series.setdefault((row["controller"], row["world"]), []).append(row)
    for metric in metric_columns(rows, grid_keys):
        fig, ax = plt.subplots(figsize=(7, 4.2))
        if grid_keys and all(isinstance(r.get(f"param.{grid_keys[0]}"), int | float) for r in ok):
            key = f"param.{grid_keys[0]}"
            for (controller, world), members in series.items():
                xs = sorted({r[key] for r in members})
                means = []
                for x in xs:
                    values = [r[metric] for r in members if r[key] == x and not _nan(r[metric])]
                    means.append(sum(values) / len(values) if values else math.nan)
                ax.plot(xs, means, marker="o", label=f"{controller} / {world}")
            ax.set_xlabel(grid_keys[0])
            ax.legend(fontsize="small")
        else:
            labels = [f"{c}\n{w}" for c, w in series]
            data = [[r[metric] for r in members if not _nan(r[metric])] for members in series.values()]
            ax.boxplot(data, tick_labels=labels)
            ax.tick_params(axis="x", labelsize="small")
        ax.set_ylabel(metric)
        ax.set_title(f"{metric} ({len(ok)} episodes)")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = folder / f"{metric}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        written.append(path)
    return written


class Progress:
    """``[#####.....] 120/1000  12%  34.5 ep/s  ETA 0:25  failed 0`` on stderr: redrawn in place on
    a terminal, a line every few seconds otherwise (logs, CI)."""

    def __init__(self, total: int, done: int = 0, stream: TextIO = sys.stderr, width: int = 30) -> None:
        self.total = total
        self.skipped = done
        self.done = done
        self.failed = 0
        self.stream = stream
        self.width = width
        self.start = time.monotonic()
        self.last_draw = -math.inf
        self.tty = stream.isatty()

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += not ok
        now = time.monotonic()
        if self.done == self.total or now - self.last_draw >= (0.2 if self.tty else 5.0):
            self.last_draw = now
            self.draw()

    def line(self) -> str:
        run = self.done - self.skipped
        elapsed = time.monotonic() - self.start
        rate = run / elapsed if elapsed > 0 else 0.0
        left = self.total - self.done
        eta = _clock(left / rate) if rate > 0 else "?"
        fill = int(self.width * self.done / max(self.total, 1))
        bar = "#" * fill + "." * (self.width - fill)
        pct = 100.0 * self.done / max(self.total, 1)
        return (
            f"[{bar}] {self.done}/{self.total} {pct:3.0f}%  {rate * 3600:,.0f} ep/h  "
            f"elapsed {_clock(elapsed)}  ETA {eta}  failed {self.failed}"
        )

    def draw(self) -> None:
        if self.tty:
            self.stream.write("\r" + self.line())
            if self.done == self.total:
                self.stream.write("\n")
        else:
            self.stream.write(self.line() + "\n")
        self.stream.flush()


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"
