"""Batch throughput: 60 s bump-and-turn Create episodes per hour, as ``robot_sims batch`` runs them.

Runs ``examples/01_bump_turn_sweep.yaml`` (random poses on the example map, metrics collected)
as a user would, each configuration in its own process and output folder:

- the headline: ``--episodes`` (default 1,000) on the local engine with 2 workers, then on a
  local Ray with 2 CPUs (goal: ≥ 7,000 episodes/hour, i.e. 1,000 in ≤ 9 minutes);
- side by side on ``--ratio-episodes`` (default 100): 1 worker vs 2 (goal: ≥ 1.7×), the DDS
  transport (the baseline: every message through the executor) vs the direct bus, and Ray with
  2 CPUs (skipped without Ray);
- the per-episode overhead (fresh context and nodes, tear-down, metrics; goal ≤ 0.1 s), median
  over the episodes, from ``timings.csv``.

Every table must be identical to the first run's (same episodes): the script checks it. The load
average is printed with every figure: the machine may be shared.

    python bench/batch.py [--episodes 1000] [--ratio-episodes 100] [--no-ray]
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SWEEP = ROOT / "examples" / "01_bump_turn_sweep.yaml"


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load avg {one:.2f} {five:.2f} {fifteen:.2f}"


def run(label: str, sweep: Path, episodes: int, out: Path, *extra: str) -> dict:
    """One ``robot_sims batch`` run; returns its figures."""
    folder = out / label.replace(" ", "_")
    shutil.rmtree(folder, ignore_errors=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT), RAY_AUTH_MODE="disabled")
    before = load()
    start = time.perf_counter()
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "sim_tools.batch.cli",
            str(sweep),
            "--limit",
            str(episodes),
            "--out",
            str(folder),
            "--quiet",
            "--no-plots",
            *extra,
        ],
        env=env,
        text=True,
        capture_output=True,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"{label} failed:\n{done.stderr}")
    with (folder / "timings.csv").open() as f:
        timings = list(csv.DictReader(f))
    overhead = [float(t["setup_s"]) + float(t["teardown_s"]) + float(t["collect_s"]) for t in timings]
    run_s = [float(t["run_s"]) for t in timings]
    busy: dict[str, float] = {}
    for t in timings:
        busy[t["pid"]] = busy.get(t["pid"], 0.0) + float(t["total_s"])
    figures = {
        "label": label,
        "episodes": episodes,
        "wall_s": wall,
        "per_hour": episodes / wall * 3600.0,
        # without start-up (processes, imports, numba's cache, Ray): the busiest worker's episode time
        "steady_per_hour": episodes / max(busy.values()) * 3600.0,
        "overhead_s": statistics.median(overhead),
        "run_s": statistics.median(run_s),
        "parts": {k: statistics.median(float(t[k]) for t in timings) for k in ("setup_s", "teardown_s", "collect_s")},
        "table": (folder / "episodes.csv").read_text(),
        "load": f"{before} -> {load()}",
    }
    print(
        f"{label:28s} {episodes:5d} episodes in {wall:7.1f} s = {figures['per_hour']:6,.0f} episodes/h "
        f"(steady {figures['steady_per_hour']:6,.0f}/h)   "
        f"median per episode: run {figures['run_s']:.3f} s, overhead {figures['overhead_s']:.3f} s   "
        f"[{figures['load']}]",
        flush=True,
    )
    return figures


def ray_available() -> bool:
    try:
        import ray  # noqa: F401
    except ImportError:
        return False
    return True


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000, help="episodes of the headline run (2 workers)")
    parser.add_argument("--ratio-episodes", type=int, default=100, help="episodes of the side-by-side runs")
    parser.add_argument("--no-ray", action="store_true", help="skip the Ray run")
    args = parser.parse_args()
    print(f"{SWEEP.relative_to(ROOT)}: 60 s bump-and-turn episodes; {os.cpu_count()} cores; {load()}")
    out = Path(tempfile.mkdtemp(prefix="bench_batch_"))
    ros_sweep = out / "ros_transport.yaml"
    ros_sweep.write_text(
        SWEEP.read_text().replace("  - create_bump_turn", "  - {use: create_bump_turn, transport: ros}"),
        encoding="utf-8",
    )
    try:
        n = args.ratio_episodes
        one = run("local, 1 worker", SWEEP, n, out, "--workers", "1")
        two = run("local, 2 workers", SWEEP, n, out, "--workers", "2")
        dds = run("local, 2 workers, DDS", ros_sweep, n, out, "--workers", "2")
        runs = [one, two, dds]
        if not args.no_ray and ray_available():
            runs.append(run("ray (local), 2 CPUs", SWEEP, n, out, "--ray", "--workers", "2"))
        same = all(r["table"] == one["table"] for r in runs)
        print(f"tables identical across engines, workers and transports: {same}")
        for what, a, b in [("2 workers vs 1", two, one), ("direct bus vs DDS transport", two, dds)] + (
            [("ray vs local, 2 workers", runs[3], two)] if len(runs) > 3 else []
        ):
            print(
                f"{what}: {a['per_hour'] / b['per_hour']:.2f}x wall clock, "
                f"{a['steady_per_hour'] / b['steady_per_hour']:.2f}x steady" + (" (goal >= 1.7x)" if b is one else "")
            )
        parts = ", ".join(f"{k[:-2]} {v:.3f} s" for k, v in one["parts"].items())
        print(f"per-episode overhead (median, local 1 worker): {one['overhead_s']:.3f} s = {parts} (goal <= 0.1 s)")
        if args.episodes:
            heads = [run("headline: local, 2 workers", SWEEP, args.episodes, out, "--workers", "2")]
            if not args.no_ray and ray_available():
                heads.append(run("headline: ray (local), 2 CPUs", SWEEP, args.episodes, out, "--ray", "--workers", "2"))
            for head in heads:
                print(
                    f"{head['label']}: {args.episodes} episodes in {head['wall_s'] / 60:.1f} min = "
                    f"{head['per_hour']:,.0f} episodes/h (goal >= 7,000/h; 1,000 in <= 9 min)"
                )
            same = same and all(h["table"] == heads[0]["table"] for h in heads)
        if not same:
            print("ERROR: the tables differ", file=sys.stderr)
            return 1
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
