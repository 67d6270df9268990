"""A sweep's output folder: the resumable log, the table (Parquet + CSV), timings, summary, plots.

``episodes.jsonl`` gets one line per finished episode as it finishes (a killed sweep loses
nothing; a rerun skips the keys found there). The table is rebuilt from it, one row per episode
of the sweep in episode order, so it is the same whatever order the workers finished in.
``timings.csv`` (wall seconds per part of each episode, which worker) is kept apart: the table
holds only what the sweep determines.
"""

from __future__ import annotations

import itertools
import json
import math
import re
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from sim_tools.batch.metrics import reached_column, split_unit, unit_of
from sim_tools.batch.row import (
    ID_COLUMNS,
    PARAM_PREFIX,
    STATUS_COLUMNS,
    Columns,
    Result,
    column_order,
    is_ok,
    is_setting,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


class ResultLog:
    """``episodes.jsonl`` in ``folder``: what is finished, and appending new results."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.path = folder / "episodes.jsonl"
        self.rows: dict[str, Columns] = {}
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

    def add(self, result: Result) -> None:
        row = result["row"].columns()
        self.rows[row["key"]] = row
        self.timings[row["key"]] = result["timing"]
        self._file.write(json.dumps({"row": row, "timing": result["timing"]}, default=_json_default) + "\n")
        self._file.flush()

    def forget_failed(self) -> None:
        """Drop failed episodes so that they run again."""
        for key in [k for k, row in self.rows.items() if not is_ok(row)]:
            del self.rows[key]

    def close(self) -> None:
        self._file.close()


def _json_default(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    return str(value)


def table_rows(log: ResultLog, keys: Iterable[str], extra: dict[str, Columns] | None = None) -> list[Columns]:
    """The logged rows of ``keys`` (the sweep's episodes, in order; missing ones are left out),
    each "time to" metric preceded by its ``<event>_reached`` column (:func:`with_reached`);
    ``extra`` rows (refused controllers' error rows) take the place of logged ones."""
    extra = extra or {}
    return [with_reached(extra.get(k) or log.rows[k]) for k in keys if k in extra or k in log.rows]


def with_reached(row: Columns) -> Columns:
    """``row`` with ``goal_reached`` (true/false) before ``goal_time_s``, and so for every
    ``<event>_time_s`` metric of an ok episode: its NaN means the event never happened, which a
    mean or a plot would otherwise drop without a word."""
    if not is_ok(row):
        return row
    out: Columns = {}
    for name, value in row.items():
        reached = None if name in STATUS_COLUMNS else reached_column(name)
        if reached and reached not in row and (value is None or _is_number(value)):
            out[reached] = _is_number(value) and not _nan(value)
        out[name] = value
    return out


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def write_table(rows: list[Columns], folder: Path) -> tuple[Path, Path]:
    """``episodes.parquet`` and ``episodes.csv``: one row per episode, every column typed."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    columns = column_order(rows)
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


def metric_columns(rows: list[Columns], grid_keys: list[str] | None = None) -> list[str]:
    """Numeric columns that are results (not ids, parameters, poses, seeds or per-robot columns)."""
    skip = set(ID_COLUMNS) | set(STATUS_COLUMNS)
    out = []
    for name in column_order(rows):
        if name in skip or is_setting(name) or "." in name:
            continue
        values = [row.get(name) for row in rows if is_ok(row)]
        if values and all(_is_number(v) for v in values if v is not None):
            out.append(name)
    return out


def _finite(rows: list[Columns], metric: str) -> list[float]:
    """The metric's values that are numbers (a NaN or a missing value is not one)."""
    return [r[metric] for r in rows if _is_number(r.get(metric)) and not _nan(r[metric])]


def _mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else math.nan


def _number(value: float, unit: str = "") -> str:
    return "nan" if _nan(value) else f"{value:.4g}" + (f" {unit}" if unit else "")


#: Failed episodes the terminal's summary lists (``summary.txt`` lists every one).
SHOWN_FAILURES = 5


def summary(
    rows: list[Columns],
    grid_keys: list[str],
    out: TextIO = sys.stdout,
    *,
    applies: dict[str, list[str]] | None = None,
    shown_failures: int | None = SHOWN_FAILURES,
    full: Path | None = None,
) -> None:
    """Episodes ok/failed and the failures (the first ``shown_failures``, None: all, then how many
    more and where they all are: ``full``), which grid parameters each controller was swept over
    (``applies``), the mean of each metric per controller × world × grid point, then how many
    episodes reached each "time to" metric's event and how many NaN any other metric has."""
    ok = [r for r in rows if is_ok(r)]
    failed = [r for r in rows if not is_ok(r)]
    print(f"{len(rows)} episodes: {len(ok)} ok, {len(failed)} failed", file=out)
    listed = failed if shown_failures is None else failed[:shown_failures]
    for row in listed:
        print(f"  episode {row['episode']} ({row['controller']} on {row['world']}): {row.get('error')}", file=out)
    if len(listed) < len(failed):
        where = f": every one in {full}" if full is not None else ""
        print(f"  ... and {len(failed) - len(listed)} more failed episodes{where}", file=out)
    for line in grid_note(grid_keys, applies or {}):
        print(line, file=out)
    metrics = metric_columns(rows)
    if not ok or not metrics:
        return
    lines = _group_table(rows, grid_keys, metrics, with_failed=bool(failed))
    time_to = any(reached_column(m) for m in metrics)
    print("mean per group" + (" (a time: over the episodes that reached it)" if time_to else "") + ":", file=out)
    _print_table(lines, out)
    for m in metrics:
        note = _nan_note(ok, m)
        if note:
            print(note, file=out)


def _print_table(lines: list[list[str]], out: TextIO) -> None:
    widths = [max(len(line[i]) for line in lines) for i in range(len(lines[0]))]
    for line in lines:
        print("  " + "  ".join(cell.rjust(w) for cell, w in zip(line, widths, strict=True)), file=out)


def grid_note(grid_keys: list[str], applies: dict[str, list[str]]) -> list[str]:
    """Per grid parameter, the controllers swept over it and those that do not declare it (they
    run once per world × pose × seed, not once per value of a parameter they never read)."""
    out = []
    for key in grid_keys:
        swept = [c for c, keys in applies.items() if key in keys]
        not_swept = [c for c, keys in applies.items() if key not in keys]
        if not_swept:
            out.append(
                f"grid {key}: swept for {', '.join(swept) or 'none'}; not for {', '.join(not_swept)} "
                "(it does not declare it: run once, not once per value)"
            )
    return out


def write_summary(
    rows: list[Columns], grid_keys: list[str], folder: Path, applies: dict[str, list[str]] | None = None
) -> Path:
    """``summary.txt``: the summary with every failure and its reason, then the spread of each
    metric per group (n, mean, sd, min, max over the ok episodes)."""
    import io

    text = io.StringIO()
    summary(rows, grid_keys, text, applies=applies, shown_failures=None)
    metrics = metric_columns(rows)
    ok = [r for r in rows if is_ok(r)]
    if ok and metrics:
        print("spread per group (over its ok episodes; sd: sample standard deviation):", file=text)
        _print_table(_spread_table(rows, grid_keys, metrics), text)
    path = folder / "summary.txt"
    path.write_text(text.getvalue(), encoding="utf-8")
    return path


def _spread_table(rows: list[Columns], grid_keys: list[str], metrics: list[str]) -> list[list[str]]:
    lines = [["controller", "world", *grid_keys, "metric", "n", "mean", "sd", "min", "max"]]
    for label, members in _groups(rows, grid_keys).items():
        good = [r for r in members if is_ok(r)]
        if not good:
            lines.append([*label, "(none ok)", "0", "-", "-", "-", "-"])
            continue
        for m in metrics:
            values = _finite(good, m)
            sd = (
                math.sqrt(sum((v - _mean(values)) ** 2 for v in values) / (len(values) - 1))
                if len(values) > 1
                else math.nan
            )
            spread = [_mean(values), sd, min(values, default=math.nan), max(values, default=math.nan)]
            lines.append([*label, m, str(len(values)), *(_number(v) if values else "-" for v in spread)])
    return lines


def _group_table(rows: list[Columns], grid_keys: list[str], metrics: list[str], with_failed: bool) -> list[list[str]]:
    """The summary's table: a head, then per group its ok episodes ``n`` (and ``failed``), and
    each metric's mean over the ok ones; a "time to" metric gets ``reached/n`` before its mean."""
    head = ["controller", "world", *grid_keys, "n", *(["failed"] if with_failed else [])]
    for m in metrics:
        head += [str(reached_column(m)), m] if reached_column(m) else [m]
    lines = [head]
    for label, members in _groups(rows, grid_keys).items():
        good = [r for r in members if is_ok(r)]
        cells = [*label, str(len(good)), *([str(len(members) - len(good))] if with_failed else [])]
        for m in metrics:
            values = _finite(good, m)
            if reached_column(m):
                cells.append(f"{len(values)}/{len(good)}")
            cells.append(_mean_cell(values, len(good), m))
        lines.append(cells)
    return lines


def _mean_cell(values: list[float], ok: int, metric: str) -> str:
    """The mean, ``-`` when there is none to take (no ok episode, nobody reached), ``nan`` when
    every value of a metric that is not a time is NaN."""
    if values:
        return _number(_mean(values))
    return "-" if reached_column(metric) or not ok else "nan"


def _groups(rows: list[Columns], grid_keys: list[str]) -> dict[tuple[str, ...], list[Columns]]:
    """Rows per controller × world × grid point, in the order they first appear."""
    groups: dict[tuple[str, ...], list[Columns]] = {}
    for row in rows:
        label = (row["controller"], row["world"], *(_param(row, k) for k in grid_keys))
        groups.setdefault(tuple("-" if v is None else str(v) for v in label), []).append(row)
    return groups


def _nan_note(ok: list[Columns], metric: str) -> str:
    """``goal_time_s: reached 331/1000 (33 %), mean of those 12.3 s``, or for any other metric
    with NaN ``x: NaN in 3 of 1000 episodes, left out of its mean``; "" when there is nothing
    to say."""
    values = _finite(ok, metric)
    n = len(ok)
    if reached_column(metric):
        share = f"{metric}: reached {len(values)}/{n} ({100 * len(values) / n:.0f} %)"
        return share + (f", mean of those {_number(_mean(values), unit_of(metric))}" if values else "")
    if len(values) < n:
        return f"{metric}: NaN in {n - len(values)} of {n} episodes, left out of its mean"
    return ""


def _param(row: Columns, key: str) -> Any:
    return row.get(f"{PARAM_PREFIX}{key}")


def _nan(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


# ------------------------------------------------------------------------------------- plots
#: Size of one panel of a plot (inches).
PANEL_SIZE = (4.4, 3.2)
#: Width of a box (a controller × world) in a plot without a grid (inches): 30 students stay legible.
BOX_WIDTH = 0.9
#: The smallest span of a value axis: a near-constant column (all 0.0 m, or 3 bumps) gets an
#: axis this wide around its value instead of one zoomed in on its rounding noise.
MIN_SPAN = 0.01
MIN_SPAN_RELATIVE = 0.05
#: A "time to" plot writes each grid value's reached count for up to this many controller × world.
MAX_COUNTED_SERIES = 4


def plot_columns(rows: list[Columns]) -> list[str]:
    """The columns :func:`plots` draws: every metric, each "time to" one after its reached share."""
    out = []
    for metric in metric_columns(rows):
        reached = reached_column(metric)
        if reached and any(reached in row for row in rows):
            out.append(reached)
        out.append(metric)
    return out


def plots(rows: list[Columns], grid_keys: list[str], folder: Path) -> list[Path]:
    """``<column>.png`` per column of :func:`plot_columns` (see :func:`figure`)."""
    plt = _pyplot()
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for column in plot_columns(rows):
        fig = figure(rows, grid_keys, column)
        path = folder / f"{column}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        written.append(path)
    return written


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure(rows: list[Columns], grid_keys: list[str], column: str) -> Figure:
    """One column of the ok episodes, nothing averaged away: against the first grid parameter (a
    line of means per controller × world over the episodes' dots), a column of panels per value of
    the second, a row per combination of the others; without a grid a box per controller × world.
    A controller that is not swept over the first grid parameter is a dashed line at its mean.

    A ``<event>_reached`` column is drawn as the share of episodes (%); a "time to" metric shows
    the episodes that reached, and every title says how many of how many those are. Failed
    episodes are crosses at the foot of their place, their reason in the legend: a student whose
    every episode failed is still in the figure."""
    plt = _pyplot()
    ok = [r for r in rows if is_ok(r)]
    col_values = _values(rows, grid_keys[1]) if len(grid_keys) > 1 else [None]
    row_values = list(itertools.product(*(_values(rows, k) for k in grid_keys[2:])))
    series = list(dict.fromkeys((r["controller"], r["world"]) for r in rows))
    width = 1.2 + PANEL_SIZE[0] * len(col_values) if grid_keys else 1.2 + BOX_WIDTH * len(series)
    fig, axes = plt.subplots(
        len(row_values),
        len(col_values),
        figsize=(max(7.0, width), 1.0 + PANEL_SIZE[1] * len(row_values)),
        sharex=True,
        sharey=True,
        squeeze=False,
    )
    for i, row_value in enumerate(row_values):
        for j, col_value in enumerate(col_values):
            facet = dict(zip(grid_keys[2:], row_value, strict=True))
            if len(grid_keys) > 1:
                facet = {grid_keys[1]: col_value, **facet}
            # a controller not swept over a parameter (it does not declare it) is in every panel of it
            members = [r for r in rows if all(_param(r, k) in (v, None) for k, v in facet.items())]
            ax = axes[i][j]
            _panel(ax, [r for r in members if is_ok(r)], ok, rows, grid_keys[:1], column, series)
            ax.set_title(_panel_title(facet, [r for r in members if is_ok(r)], column), fontsize="medium")
            if i == len(row_values) - 1 and grid_keys:
                ax.set_xlabel(_axis_label(grid_keys[0]))
        axes[i][0].set_ylabel(_axis_label(column, share=_is_share(column, ok)))
    _value_axis(axes[0][0], ok, column)
    if grid_keys and reached_column(column):  # room at the foot for the reached counts
        bottom, top = axes[0][0].get_ylim()
        axes[0][0].set_ylim(bottom - 0.2 * (top - bottom), top)
    for i, row_value in enumerate(row_values):  # after the value axis: crosses sit at its foot
        for j, col_value in enumerate(col_values):
            facet = dict(zip(grid_keys[2:], row_value, strict=True))
            if len(grid_keys) > 1:
                facet = {grid_keys[1]: col_value, **facet}
            failed = [r for r in rows if not is_ok(r) and all(_param(r, k) in (v, None) for k, v in facet.items())]
            _failures(axes[i][j], failed, rows, grid_keys[:1], series, legend=(i, j) == (0, len(col_values) - 1))
    handles, _ = axes[0][-1].get_legend_handles_labels()
    if handles and (len(series) > 1 or any(not is_ok(r) for r in rows)):
        axes[0][-1].legend(fontsize="small")
    fig.suptitle(_figure_title(rows, ok, column))
    fig.tight_layout()
    return fig


_REFUSED = re.compile(r"^refused before the sweep: field '[^']*': ")
#: A failure's reason in a plot's legend is cut to this many characters (the table has it whole).
LEGEND_REASON = 60


def _failures(
    ax: Axes,
    failed: list[Columns],
    rows: list[Columns],
    x_key: list[str],
    series: list[tuple[str, str]],
    legend: bool,
) -> None:
    """Failed episodes as crosses at the foot of the panel: under their controller × world's box,
    or at their grid value in its colour; each series' most common reason in the legend."""
    foot = ax.get_xaxis_transform()  # x in data, y in axes fractions
    xs = _values(rows, x_key[0]) if x_key else []
    numeric = bool(xs) and all(_is_number(x) for x in xs)
    for k, s in enumerate(series):
        mine = [r for r in failed if (r["controller"], r["world"]) == s]
        if not mine:
            continue
        if x_key:
            spots = [_param(r, x_key[0]) for r in mine]
            if any(v is None for v in spots):  # not swept over it: its crosses span the axis
                spots = [xs[i % len(xs)] for i in range(len(mine))] if xs else [0.0] * len(mine)
            positions = [v if numeric else xs.index(v) for v in spots]
            colour = f"C{k}"
        else:
            positions = [k + 1 + 0.25 * ((i * 0.618) % 1 - 0.5) for i in range(len(mine))]
            colour = "C3"
        label = f"{s[0]} / {s[1]}: {len(mine)} failed: {_reason(mine)}" if legend else None
        ax.scatter(positions, [0.04] * len(mine), transform=foot, marker="x", s=36, color=colour, label=label)


def _reason(failed: list[Columns]) -> str:
    """The most common error of ``failed``, without its log file, cut for a legend."""
    reasons = [_REFUSED.sub("refused: ", str(r.get("error", "")).split(" [log: ")[0]) for r in failed]
    reason = max(set(reasons), key=reasons.count)
    return reason if len(reason) <= LEGEND_REASON else reason[: LEGEND_REASON - 1] + "…"


def _is_share(column: str, ok: list[Columns]) -> bool:
    """A yes/no column (``goal_reached``): drawn as the share of episodes."""
    values = [r.get(column) for r in ok if r.get(column) is not None]
    return bool(values) and all(isinstance(v, bool) for v in values)


def _values(ok: list[Columns], key: str) -> list[Any]:
    """The grid parameter's values, sorted when they are numbers, else in the sweep's order."""
    values: list[Any] = []
    for row in ok:
        if _param(row, key) is not None and _param(row, key) not in values:
            values.append(_param(row, key))
    return sorted(values) if all(_is_number(v) for v in values) else values


def _panel(
    ax: Axes,
    members: list[Columns],
    ok: list[Columns],
    rows: list[Columns],
    x_key: list[str],
    column: str,
    series: list[tuple[str, str]],
) -> None:
    """One panel: a line per controller × world against ``x_key`` (dots: the episodes), or a box
    (a bar for a share) per controller × world without one."""
    share = _is_share(column, ok)
    if not x_key:
        groups = [[r for r in members if (r["controller"], r["world"]) == s] for s in series]
        data = [_shares(g, column) if share else _finite(g, column) for g in groups]
        positions = list(range(1, len(series) + 1))
        if share:
            bars = ax.bar(positions, [_mean(d) for d in data], color="C0", width=0.6)
            ax.bar_label(bars, [f"{int(sum(d) / 100)}/{len(d)}" for d in data])
        else:
            filled = [(p, d) for p, d in zip(positions, data, strict=True) if d]
            if filled:
                ax.boxplot([d for _, d in filled], positions=[p for p, _ in filled], showfliers=False)
            for p, d in filled:  # every episode, spread sideways so that equal values stay apart
                spread = [p + 0.25 * ((i * 0.618) % 1 - 0.5) for i in range(len(d))]
                ax.scatter(spread, d, s=9, alpha=0.35, color="C0", linewidths=0)
        ax.set_xticks(positions, [_series_tick(s, g, column) for s, g in zip(series, groups, strict=True)])
        ax.tick_params(axis="x", labelsize="small")
        return
    xs = _values(rows, x_key[0])
    numeric = all(_is_number(x) for x in xs)
    positions = xs if numeric else list(range(len(xs)))
    for k, (controller, world) in enumerate(series):
        mine = [r for r in members if (r["controller"], r["world"]) == (controller, world)]
        flat = [r for r in mine if _param(r, x_key[0]) is None]
        if flat:  # not swept over it: one level, a dashed line across
            values = _shares(flat, column) if share else _finite(flat, column)
            if values:
                label = f"{controller} / {world} (not swept over {x_key[0]})"
                ax.axhline(_mean(values), linestyle="--", color=f"C{k}", label=label)
            continue
        per_x = [[r for r in mine if _param(r, x_key[0]) == x] for x in xs]
        data = [_shares(g, column) if share else _finite(g, column) for g in per_x]
        if not share:
            dots = [(p, v) for p, d in zip(positions, data, strict=True) for v in d]
            ax.scatter([p for p, _ in dots], [v for _, v in dots], s=9, alpha=0.3, color=f"C{k}", linewidths=0)
        means = [_mean(d) for d in data]
        line = "-" if numeric else "none"  # no line between unordered values
        if not mine:
            continue
        ax.plot(positions, means, marker="o", linestyle=line, color=f"C{k}", label=f"{controller} / {world}")
        if reached_column(column) and len(series) <= MAX_COUNTED_SERIES:
            _reached_counts(ax, positions, per_x, data, k)
    if numeric:
        ax.ticklabel_format(axis="x", useOffset=False, style="plain")
        pad = 0.05 * (max(xs) - min(xs)) or 0.5
        ax.set_xlim(min(xs) - pad, max(xs) + pad)  # every grid value, even one nobody reached at
    else:
        ax.set_xticks(positions, [str(x) for x in xs])
        ax.set_xlim(-0.5, len(xs) - 0.5)
    ax.grid(alpha=0.3)


def _reached_counts(ax: Axes, positions: list[Any], per_x: list[Any], data: list[list[float]], k: int) -> None:
    """``2/6`` at the foot of each grid value: how many of its episodes reached (series k's colour,
    one line per series), so that a value none reached shows as 0/6, not as a gap."""
    foot = ax.get_xaxis_transform()  # x in data, y in axes fractions
    for p, rows, d in zip(positions, per_x, data, strict=True):
        if rows:
            text = f"{len(d)}/{len(rows)}"
            ax.text(p, 0.03 + 0.07 * k, text, transform=foot, ha="center", fontsize="x-small", color=f"C{k}")


def _shares(rows: list[Columns], column: str) -> list[float]:
    """A yes/no column as 100 (yes) and 0 (no), so that their mean is the share in %."""
    return [100.0 * bool(r[column]) for r in rows if isinstance(r.get(column), bool)]


def _series_tick(series: tuple[str, str], rows: list[Columns], column: str) -> str:
    tick = f"{series[0]}\n{series[1]}"
    if reached_column(column):
        tick += f"\n{len(_finite(rows, column))}/{len(rows)} reached"
    return tick


def _panel_title(facet: dict[str, Any], members: list[Columns], column: str) -> str:
    """``turn = 0.5, speed = 0.2``: the panel's grid values, and for a "time to" metric how many
    of its episodes reached the event (the others have no time to draw)."""
    parts = [f"{k} = {v}" for k, v in facet.items()]
    if reached_column(column) and facet:  # without facets the figure's title says it
        parts.append(f"{len(_finite(members, column))} of {len(members)} reached")
    return ", ".join(parts)


def _figure_title(rows: list[Columns], ok: list[Columns], column: str) -> str:
    failed = len(rows) - len(ok)
    title = f"{column}: {len(ok)} episodes"
    if reached_column(column):
        reached = len(_finite(ok, column))
        title = f"{column}: {reached} of {len(ok)} episodes reached ({len(ok) - reached} never: not drawn)"
    elif _is_share(column, ok):
        title = f"{column}: share of {len(ok)} episodes"
    else:
        missing = len(ok) - len(_finite(ok, column))
        title += f" ({missing} NaN not drawn)" if missing else ""
    return title + (f"; {failed} failed (x at the foot)" if failed else "")


def _axis_label(name: str, share: bool = False) -> str:
    """``goal_time_s`` → ``goal time (s)``; a share → ``goal reached (% of episodes)``."""
    stem, unit = split_unit(name.removeprefix(PARAM_PREFIX))
    if share:
        unit = "% of episodes"
    return f"{stem.replace('_', ' ')} ({unit})" if unit else stem.replace("_", " ")


def _value_axis(ax: Axes, ok: list[Columns], column: str) -> None:
    """Plain tick labels (no offset, no 1e-8 scale) on the value axis the panels share, at least
    :data:`MIN_SPAN` wide; a share spans 0–100 %, whole numbers get whole ticks."""
    from matplotlib.ticker import MaxNLocator

    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    if _is_share(column, ok):
        ax.set_ylim(-3, 103)
        return
    values = _finite(ok, column)
    if not values:
        ax.set_ylim(0, 1)
        return
    counts = all(isinstance(v, int) for v in values)
    if counts:
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    lo, hi = min(values), max(values)
    # whole numbers: at least two steps, or the locator falls back to 2.5, 2.6...
    span = max(MIN_SPAN, MIN_SPAN_RELATIVE * max(abs(lo), abs(hi)), 2.0 if counts else 0.0)
    if hi - lo < span:
        middle = (lo + hi) / 2
        bottom = max(middle - span / 2, 0.0) if lo >= 0 else middle - span / 2
        ax.set_ylim(bottom, bottom + span)


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
