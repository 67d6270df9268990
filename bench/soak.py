"""Soak: each world for a long sim time at real_time_factor 0, recorder on, a controller driving;
then a 10 kHz cmd_vel flood with NaN/inf/huge values against the Create world.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/soak.py [--sim-seconds 3600]

Per world it reports the world process's RSS after warm-up (10 % of the run) and at the end
(goal: growth ≤ 5 MB), the sim-time rate (sim s per wall s) over the first and the last 10 %
after warm-up (goal: no drift: end/start ≥ 0.8), and the bag's completeness (periodic topics with
no gap in their header stamps). The flood reports whether the world held real time at
real_time_factor 1 (sim/wall ≥ 0.95) and its RSS growth. Load average printed with each figure.
``--busy N`` runs N CPU-bound loops beside the worlds (killed afterwards): the recorder must still
miss nothing, as the world waits for it (sim_runtime.flow_control).
"""

from __future__ import annotations

import argparse
import math
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))

from record_worlds import drops, exe, stop  # noqa: E402

MB = 1024 * 1024
CREATE_CONFIG = ROOT / "config/create/example_config.txt"


def rss(pid: int) -> int:
    """Resident set size of a process (bytes; 0 once it has gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


class Watcher:
    """A node of the bench: follows /clock and can publish commands."""

    def __init__(self) -> None:
        import rclpy
        from rosgraph_msgs.msg import Clock

        from sim_runtime.run import make_executor

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("soak_watcher", context=self.context)
        self.sim = 0.0
        self.node.create_subscription(Clock, "/clock", self._on_clock, 10)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._running = True
        self._thread.start()

    def _on_clock(self, msg) -> None:
        self.sim = msg.clock.sec + msg.clock.nanosec * 1e-9

    def _spin(self) -> None:
        while self._running and self.context.ok():
            self.executor.spin_once(timeout_sec=0.1)

    def close(self) -> None:
        self._running = False
        self._thread.join(timeout=2)
        self.node.destroy_node()
        self.context.try_shutdown()


def run_world(name: str, args: list[str], sim_seconds: float, wall_limit: float, watcher: Watcher, drive=None) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        bag = Path(folder) / "bag"
        recorder = exe("record", "-o", str(bag), "--exclude", "/rosout|/parameter_events")
        time.sleep(1.5)
        watcher.sim = 0.0
        world = exe(name, "--ros-args", "-p", "real_time_factor:=0.0", *args)
        samples: list[tuple[float, float, int]] = []  # (wall, sim, rss)
        begin = time.monotonic()
        last_drive = -1.0
        while time.monotonic() - begin < wall_limit and world.poll() is None:
            samples.append((time.monotonic() - begin, watcher.sim, rss(world.pid)))
            if drive is not None and watcher.sim - last_drive >= 2.0:
                drive(watcher.sim)
                last_drive = watcher.sim
            if watcher.sim >= sim_seconds:
                break
            time.sleep(0.05)  # a SIMROBOT hour at 1 Hz takes seconds
        log = stop(world)
        time.sleep(1.0)
        stop(recorder)
        if world.returncode not in (0, -2, 130):
            print(f"{name}: exit {world.returncode}\n{log[-2000:]}")
        total, checked, missing = drops(bag)
    samples = [s for s in samples if s[1] > 0]
    if len(samples) < 5:
        return {"world": name, "error": "too few /clock samples", "log": log[-1500:]}
    end_sim = samples[-1][1]
    warm = next(s for s in samples if s[1] >= 0.1 * end_sim)
    after = [s for s in samples if s[0] >= warm[0]]
    k = max(2, len(after) // 10)

    def rate(part: list[tuple[float, float, int]]) -> float:
        return (part[-1][1] - part[0][1]) / max(part[-1][0] - part[0][0], 1e-9)

    return {
        "world": name,
        "sim_s": end_sim,
        "wall_s": samples[-1][0],
        "rss_warm_mb": warm[2] / MB,
        "rss_end_mb": samples[-1][2] / MB,
        # RSS at 25 %, 50 %, 75 % of the run after warm-up: a plateau or a steady climb?
        "rss_quarters_mb": [after[min(len(after) - 1, len(after) * q // 4)][2] / MB for q in (1, 2, 3)],
        "rate_start": rate(after[:k]),
        "rate_end": rate(after[-k:]),
        "messages": total,
        "topics_checked": checked,
        "dropped": sum(missing.values()),
        "missing": missing,
    }


def flood(seconds: float, watcher: Watcher) -> dict:
    """Create world at real_time_factor 1; cmd_vel at up to 10 kHz, a tenth of them NaN/inf/huge."""
    from geometry_msgs.msg import Twist

    watcher.sim = 0.0
    world = exe("create_world", "--ros-args", "-p", "real_time_factor:=1.0")
    publisher = watcher.node.create_publisher(Twist, "/cmd_vel", 10)
    deadline = time.monotonic() + 60
    while watcher.sim <= 0.5 and time.monotonic() < deadline:
        time.sleep(0.1)
    rss_before = rss(world.pid)
    sim0, wall0 = watcher.sim, time.monotonic()
    sent = 0
    bad = (math.nan, math.inf, -math.inf, 1e300, -1e300)
    rng = random.Random(0)
    period = 1e-4
    next_time = time.monotonic()
    while time.monotonic() - wall0 < seconds:
        msg = Twist()
        if sent % 10 == 0:
            msg.linear.x, msg.angular.z = rng.choice(bad), rng.choice(bad)
        else:
            msg.linear.x, msg.angular.z = rng.uniform(-0.5, 0.5), rng.uniform(-2, 2)
        publisher.publish(msg)
        sent += 1
        next_time += period
        delay = next_time - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    wall = time.monotonic() - wall0
    sim = watcher.sim - sim0
    rss_after = rss(world.pid)
    alive = world.poll() is None
    stop(world)
    watcher.node.destroy_publisher(publisher)
    return {
        "sent_per_s": sent / wall,
        "sim_per_wall": sim / wall,
        "rss_before_mb": rss_before / MB,
        "rss_after_mb": rss_after / MB,
        "alive": alive,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-seconds", type=float, default=3600.0, help="sim time per world (default 3600)")
    parser.add_argument("--wall-limit", type=float, default=3600.0, help="wall seconds at most per world")
    parser.add_argument("--flood-seconds", type=float, default=30.0, help="length of the cmd_vel flood")
    parser.add_argument("--worlds", default="create_world,simrobot_world,arm", help="comma-separated worlds")
    parser.add_argument("--busy", type=int, default=0, help="CPU-bound loops loading the machine meanwhile")
    opts = parser.parse_args()
    print(f"{os.cpu_count()} CPUs, {load()}; sim time per world {opts.sim_seconds:g} s; {opts.busy} busy loops")
    watcher = Watcher()
    demo = ROOT / "config/simrobot/demo.yaml"
    endless = tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False)  # noqa: SIM115 - a world reads it
    endless.write(
        demo.read_text()
        .replace("map: demo_map.png", f"map: {demo.parent / 'demo_map.png'}")
        .replace("steps_limit: 300", "steps_limit: .inf")
        .replace("lockstep: true", "lockstep: false")
    )
    endless.close()
    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(opts.busy)]
    try:
        from sensor_msgs.msg import JointState

        joints = watcher.node.create_publisher(JointState, "/joint_command", 10)
        rng = random.Random(1)

        def drive_arm(_sim: float) -> None:
            joints.publish(JointState(position=[rng.uniform(-1.0, 1.0) for _ in range(6)]))

        worlds = {
            "create_world": (
                ["-p", f"config_file:={ROOT / 'config/create/example_config.txt'}"],
                None,
                "create_bump_turn",
            ),
            "simrobot_world": (["-p", f"world_file:={endless.name}"], None, None),  # alg2 runs in the world
            "arm": ([], drive_arm, None),
        }
        print(
            f"{'world':15s} {'sim s':>7s} {'wall s':>7s} {'RSS warm':>9s} {'RSS end':>8s} {'growth':>7s} "
            f"{'rate start':>10s} {'rate end':>9s} {'end/start':>9s} {'messages':>9s} {'dropped':>8s}"
        )
        for name in opts.worlds.split(","):
            args, drive, controller = worlds[name]
            ctl = exe(controller) if controller else None
            try:
                r = run_world(name, args, opts.sim_seconds, opts.wall_limit, watcher, drive)
            finally:
                if ctl is not None:
                    stop(ctl)
            if "error" in r:
                print(f"{name:15s} {r['error']}\n{r['log']}")
                continue
            growth = r["rss_end_mb"] - r["rss_warm_mb"]
            print(
                f"{name:15s} {r['sim_s']:7.0f} {r['wall_s']:7.0f} {r['rss_warm_mb']:8.1f}M {r['rss_end_mb']:7.1f}M "
                f"{growth:+6.1f}M {r['rate_start']:9.1f}x {r['rate_end']:8.1f}x {r['rate_end'] / r['rate_start']:9.2f} "
                f"{r['messages']:9d} {r['dropped']:8d}   {load()}   "
                f"goals: growth ≤ 5 MB {'met' if growth <= 5 else 'MISSED'}, "
                f"no drift {'met' if r['rate_end'] >= 0.8 * r['rate_start'] else 'MISSED'}, "
                f"complete {'met' if r['dropped'] == 0 else r['missing']}"
            )
            quarters = ", ".join(f"{m:.1f}" for m in r["rss_quarters_mb"])
            print(f"{'':15s} RSS (MB) after warm-up at 25/50/75 %: {quarters}")
        f = flood(opts.flood_seconds, watcher)
        print(
            f"cmd_vel flood {opts.flood_seconds:g} s: {f['sent_per_s']:.0f} msg/s sent (a tenth NaN/inf/±1e300), "
            f"world sim/wall {f['sim_per_wall']:.3f} "
            f"(goal ≥ 0.95: {'met' if f['sim_per_wall'] >= 0.95 else 'MISSED'}), "
            f"RSS {f['rss_before_mb']:.1f} → {f['rss_after_mb']:.1f} MB, alive {f['alive']}   {load()}"
        )
    finally:
        for process in busy:
            process.kill()
            process.wait()
        os.unlink(endless.name)
        watcher.close()


if __name__ == "__main__":
    main()
