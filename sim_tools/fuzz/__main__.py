"""``python -m sim_tools.fuzz``: run a fuzz campaign (``make fuzz``) or replay one input."""

from __future__ import annotations

import argparse
import sys

from sim_tools.fuzz.budget import Budget
from sim_tools.fuzz.campaign import Campaign, replay


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim_tools.fuzz", description=__doc__)
    parser.add_argument("--inputs", type=int, default=100_000, help="inputs to run (default 100000)")
    parser.add_argument("--seconds", type=float, default=900.0, help="time budget (default 900)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--seed", type=int, default=1, help="campaign seed (same seed, same inputs)")
    parser.add_argument(
        "--hang-seconds", type=float, default=30.0, help="an input running longer is a hang (default 30)"
    )
    parser.add_argument("--batch", type=int, default=50, help="inputs handed to a worker at a time (default 50)")
    parser.add_argument(
        "--recycle-after", type=int, default=1000, help="a worker is replaced after this many inputs (default 1000)"
    )
    parser.add_argument(
        "--budget-cpu-seconds",
        type=float,
        default=Budget.cpu_seconds,
        help=f"CPU seconds one input may take; more is a defect (default {Budget.cpu_seconds:g})",
    )
    parser.add_argument(
        "--budget-mb",
        type=float,
        default=Budget.memory_mb,
        help=f"memory (MB) one input may add to its worker; more is a defect (default {Budget.memory_mb:g})",
    )
    parser.add_argument("--out", default="out/fuzz", help="folder for seeds, defects and summary.json")
    parser.add_argument("--replay", type=int, metavar="INDEX", help="run input INDEX here and show its traceback")
    opts = parser.parse_args(argv)
    if opts.replay is not None:
        replay(opts.replay, opts.seed, opts.out)
        return 0
    report = Campaign(
        opts.inputs,
        seconds=opts.seconds,
        workers=opts.workers,
        seed=opts.seed,
        out=opts.out,
        hang_seconds=opts.hang_seconds,
        batch=opts.batch,
        recycle_after=opts.recycle_after,
        budget=Budget(cpu_seconds=opts.budget_cpu_seconds, memory_mb=opts.budget_mb),
    ).run()
    print(report.table())
    print(f"defect inputs saved under {opts.out}/defects; summary in {opts.out}/summary.json")
    return 1 if report.failures else 0


if __name__ == "__main__":
    sys.exit(main())
