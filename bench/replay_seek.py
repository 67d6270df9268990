"""Seek latency in a 10-minute Create bag: the bag index against rescanning the bag to the instant.

    .venv/bin/python bench/replay_seek.py [--minutes 10] [--seeks 300] [--baseline-seeks 20]

The bag is a Create run at the world's default rates (``create_sim.synthetic_run``: ~700 messages/s,
zstd chunks closed every half second as the recorder does), written once into
``out/bench/replay_seek_<minutes>min`` and reused. Measured, at random instants:

- ``index``: :meth:`BagIndex.state_at` (the latest message of every topic, as bytes);
- ``page frame``: :meth:`studio.replay.frames.Replay.frame`, everything the replay page shows (every topic
  decoded, the map, the track up to the instant, the commands sent);
- ``rescan``: the baseline, reading the bag from its start up to the instant and keeping each topic's
  latest message (what a player without an index does).

Goal: a seek anywhere within 200 ms. The load average is printed with the figures (shared machine).
"""

from __future__ import annotations

import argparse
import os
import random
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

GOAL_MS = 200.0


def load() -> str:
    return "load average " + " ".join(f"{v:.2f}" for v in os.getloadavg())


def percentiles(ms: list[float]) -> tuple[float, float, float]:
    ordered = sorted(ms)
    return (
        ordered[len(ordered) // 2],
        ordered[min(len(ordered) - 1, round(0.99 * (len(ordered) - 1)))],
        ordered[-1],
    )


def rescan_state(bag, t_ns: int) -> dict:
    """The baseline: every message from the bag's start to ``t_ns``, keeping each topic's latest."""
    state = {}
    for m in bag.messages(end=t_ns):
        state[m.topic] = m
    return state


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--seeks", type=int, default=300)
    parser.add_argument("--baseline-seeks", type=int, default=20)
    options = parser.parse_args()

    from create_sim.synthetic_run import write_create_run
    from sim_runtime.bag.index import BagIndex
    from sim_runtime.bag.reader import open_bag
    from studio.replay.frames import Replay

    folder = ROOT / "out" / "bench" / f"replay_seek_{options.minutes:g}min"
    if not (folder / "metadata.yaml").exists():
        if folder.exists():  # a run that was cut short
            import shutil

            shutil.rmtree(folder)
        folder.parent.mkdir(parents=True, exist_ok=True)
        started = time.perf_counter()
        write_create_run(folder, options.minutes * 60.0)
        print(f"wrote {folder} in {time.perf_counter() - started:.1f} s ({load()})")
    size_mb = sum(f.stat().st_size for f in folder.glob("*.mcap")) / 1e6

    started = time.perf_counter()
    bag = open_bag(folder)
    count = sum(1 for _ in bag.messages())
    full_scan_s = time.perf_counter() - started
    started = time.perf_counter()
    index = BagIndex.open(folder)
    build_s = time.perf_counter() - started
    started = time.perf_counter()
    replay = Replay(index)
    replay.frame(index.start_ns)  # the page shows the first instant on opening (message classes imported)
    replay_open_s = time.perf_counter() - started
    assert index.message_count == count, (index.message_count, count)
    print(
        f"bag: {options.minutes:g} min, {count} messages, {len(index.by_topic)} topics, {size_mb:.1f} MB, "
        f"{len(bag._infos[0].chunk_indexes)} chunks ({load()})"
    )
    print(
        f"open: index built in {build_s * 1e3:.0f} ms vs one full read of the bag {full_scan_s * 1e3:.0f} ms "
        f"(ratio {full_scan_s / build_s:.1f}x); page open (index, tracks, first frame) {replay_open_s * 1e3:.0f} ms"
    )

    rng = random.Random(1)
    instants = [rng.randrange(index.start_ns, index.end_ns + 1) for _ in range(options.seeks)]
    index_ms, frame_ms = [], []
    for t in instants:
        started = time.perf_counter()
        state = index.state_at(t)
        index_ms.append((time.perf_counter() - started) * 1e3)
        started = time.perf_counter()
        replay.frame(t)
        frame_ms.append((time.perf_counter() - started) * 1e3)
    baseline_ms = []
    for t in instants[: options.baseline_seeks]:
        started = time.perf_counter()
        expected = rescan_state(bag, t)
        baseline_ms.append((time.perf_counter() - started) * 1e3)
        state = index.state_at(t)
        assert {k: m.log_time_ns for k, m in state.items()} == {k: m.log_time_ns for k, m in expected.items()}

    print(f"random seeks ({load()}):")
    print(f"  {'':<22}{'seeks':>6}{'p50 ms':>10}{'p99 ms':>10}{'max ms':>10}")
    rows = [("index (state_at)", index_ms), ("page frame (decoded)", frame_ms), ("rescan (baseline)", baseline_ms)]
    for name, ms in rows:
        p50, p99, worst = percentiles(ms)
        print(f"  {name:<22}{len(ms):>6}{p50:>10.1f}{p99:>10.1f}{worst:>10.1f}")
    base = percentiles(baseline_ms)[0]
    print(
        f"  p50 ratio rescan / index: {base / percentiles(index_ms)[0]:.0f}x, "
        f"rescan / page frame: {base / percentiles(frame_ms)[0]:.0f}x"
    )
    worst = max(max(index_ms), max(frame_ms))
    verdict = "PASS" if worst <= GOAL_MS else "FAIL"
    print(f"{verdict}: slowest seek {worst:.1f} ms (goal ≤ {GOAL_MS:.0f} ms anywhere in the bag)")
    return 0 if verdict == "PASS" else 1


if __name__ == "__main__":
    sys.exit(main())
