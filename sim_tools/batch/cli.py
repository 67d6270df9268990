"""``robot_sims batch SWEEP.yaml [--workers N | --ray [ADDRESS]] [--out DIR]``.

Runs every episode of the sweep that the output folder does not already hold, then writes
``episodes.parquet``, ``episodes.csv``, ``timings.csv``, ``summary.txt`` (every failure, the spread
of each metric) and ``plots/*.png`` there and prints a summary; each episode's output is in
``logs/<episode key>.log`` there. Exit status: 0 when the sweep ran (failed episodes, crashed or
stopped at a limit included, are rows of the table), 2 for a bad sweep file or arguments (every
controller that cannot be imported or built is named; ``--broken-as-rows`` makes their episodes
error rows instead), 1 when no worker process can start, 130 after Ctrl-C (what finished is kept).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from sim_tools.batch.row import OK, Columns, Result, is_ok


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="robot_sims batch",
        description="Run a sweep of isolated, deterministic simulation episodes; write a table and plots.",
    )
    parser.add_argument("sweep", help="sweep file (YAML)")
    parser.add_argument("--out", help="output folder (default: the sweep's 'out', else out/batch/<sweep name>)")
    parser.add_argument(
        "--workers", type=int, default=None, help="worker processes (default: all cores; Ray: CPUs of a local Ray)"
    )
    parser.add_argument(
        "--ray",
        nargs="?",
        const="",
        default=None,
        metavar="ADDRESS",
        help="run on Ray: a local Ray without ADDRESS, else the cluster at ADDRESS (host:port)",
    )
    parser.add_argument("--retry-failed", action="store_true", help="run failed episodes again")
    parser.add_argument(
        "--broken-as-rows",
        action="store_true",
        help="grade controllers that cannot be imported or built as error rows (with the reason), not refuse the sweep",
    )
    parser.add_argument("--limit", type=int, default=None, help="run only the first N episodes of the sweep")
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(list(argv))
    if args.workers is not None and args.workers < 1:
        parser.error(f"--workers {args.workers}: must be >= 1")
    if args.limit is not None and args.limit < 1:
        parser.error(f"--limit {args.limit}: must be >= 1")
    return args


def run_sweep(argv: Sequence[str]) -> dict[str, Any]:
    """Run the sweep the arguments describe; returns paths and counts (the tests' entry point)."""
    from sim_tools.batch import engines, output
    from sim_tools.batch.isolated_load import load_sweep_isolated
    from sim_tools.batch.supervisor import Limits

    args = parse_args(argv)
    sweep = load_sweep_isolated(args.sweep, out=args.out, broken_as_rows=args.broken_as_rows)
    for line in sweep.warnings:
        print(line, file=sys.stderr)
    refused = {ep.key: ep for ep in sweep.broken_episodes}
    every = sorted([*sweep.episodes, *sweep.broken_episodes], key=lambda ep: ep.index)
    episodes = every[: args.limit] if args.limit else every
    folder = sweep.out
    log = output.ResultLog(folder)
    if args.retry_failed:
        log.forget_failed()
    bags = folder / "bags"
    todo = []
    for ep in episodes:
        if ep.key in log.rows or ep.key in refused:
            continue
        if ep.record_bag:
            ep = dataclasses.replace(ep, bag_dir=str(bags / f"episode_{ep.index:05d}"))
        todo.append(ep)
    broken_rows = _broken_rows(sweep, [ep for ep in episodes if ep.key in refused])
    skipped = len(episodes) - len(todo) - len(broken_rows)
    engine = "ray" if args.ray is not None else "local"
    workers = args.workers or (os.cpu_count() or 1)
    where = f"ray {args.ray or '(local)'}" if engine == "ray" else f"{workers} local workers"
    print(f"{sweep.source}: {len(episodes)} episodes ({skipped} already done) -> {folder} [{where}]", file=sys.stderr)
    for broken in sweep.broken:
        print(f"refused, graded as error rows: {broken.line()}", file=sys.stderr)
    progress = None if args.quiet else output.Progress(len(episodes) - len(broken_rows), skipped)
    limits = Limits(sweep.time_limit_s, sweep.memory_limit_mb)

    def on_result(result: Result) -> None:
        log.add(result)
        if progress is not None:
            progress.update(result["row"].status == OK)

    try:
        if engine == "ray":
            engines.run_ray(todo, args.ray or None, args.workers, on_result, limits, folder)
        else:
            engines.run_local(todo, workers, on_result, limits, folder)
        if sweep.keep_bags == "failures":
            failed = [ep for ep in todo if not is_ok(log.rows.get(ep.key, {}))]
            _record_failures(failed, bags, limits, folder)
    finally:
        log.close()
    keys = [ep.key for ep in episodes]
    rows = output.table_rows(log, keys, broken_rows)
    parquet, csv = output.write_table(rows, folder)
    output.write_timings(log, keys, folder)
    text = output.write_summary(rows, sweep.grid_keys, folder, sweep.grid_applies)
    output.summary(rows, sweep.grid_keys, applies=sweep.grid_applies, full=text)
    pngs = [] if args.no_plots else output.plots(rows, sweep.grid_keys, folder / "plots")
    print(f"table: {parquet} and {csv}; summary: {text}" + (f"; plots: {folder / 'plots'}/" if pngs else ""))
    return {
        "folder": folder,
        "parquet": parquet,
        "csv": csv,
        "summary": text,
        "plots": pngs,
        "ran": len(todo),
        "skipped": skipped,
        "failed": sum(not is_ok(r) for r in rows),
    }


def _broken_rows(sweep: Any, episodes: list[Any]) -> dict[str, Columns]:
    """The error rows of the refused controllers' episodes (never logged: the next run checks
    those controllers again, and runs them once they work)."""
    from sim_tools.batch.supervisor import error_result

    why = {broken.label: broken for broken in sweep.broken}
    rows = {}
    for ep in episodes:
        broken = why[ep.controller["label"]]
        reason = f"refused before the sweep: field '{broken.field}': {broken.reason}"
        rows[ep.key] = error_result(ep, reason, -1, 0.0)["row"].columns()
    return rows


def _record_failures(failed: list[Any], bags: Path, limits: Any, folder: Path) -> None:
    """Run each failed episode again with a recorder (episodes are deterministic: it fails the
    same way), in a worker process like the first time, and keep its bag (logs/<key>.bag.log)."""
    from sim_tools.batch.engines import run_local

    recorded = [
        dataclasses.replace(ep, record_bag=True, bag_dir=str(bags / f"episode_{ep.index:05d}")) for ep in failed
    ]
    run_local(recorded, 1, lambda result: None, limits, folder, log_suffix=".bag")
    for ep in recorded:
        print(f"bag of failed episode {ep.index}: {ep.bag_dir}", file=sys.stderr)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``batch``."""
    from sim_tools.batch.supervisor import WorkerStartError

    argv = sys.argv[1:] if args is None else list(args)
    try:
        run_sweep(argv)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except WorkerStartError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("\ninterrupted: finished episodes are kept; run the same command to resume", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
