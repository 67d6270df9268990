"""Toolbox call round trip from Octave through ``matlab_bridge`` to a running create_world.

    .venv/bin/python bench/matlab_roundtrip.py [--calls 2000] [--program-seconds 60] [--interrupts 5]

Starts create_world (empty floor, real time) and ``robot_sims matlab_bridge`` in their own
processes, then times ``--calls`` calls of each function in one Octave session, wall clock from
``tic`` before the call to ``toc`` after its outputs are decoded. Goal: median <= 1 ms, p99 <= 5 ms.

Then a control program in the original's style runs for ``--program-seconds`` (0: skip): drive at
0.1 m/s, read the bumpers and ``pause(0.05)`` in a ``tic; while toc < T`` loop, and every 5 s
compare ``toc`` with the robot's own clock, read as odometry distance / speed: the lag between
them must not grow (the robot keeps up with the program's wall clock at real time).

Then programs that end badly (``--interrupts`` runs each, 0: skip): Ctrl-C typed at an
interactive Octave prompt inside ``travelDist``, and SIGINT / SIGTERM to ``octave --eval``
inside ``travelDist``: the wall time from the interrupt to the first odometry reporting the robot
standing (goal <= 0.2 s), and whether the next call at the prompt answers with the pose; then a
world killed (SIGKILL) under a program calling ``OverheadLocalizationCreate`` in a loop: the wall
time from the kill to the call's ``CreateRobot:bridge`` error (goal <= 1 s).
Prints the machine's load (os.getloadavg) before and after.
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(1, str(ROOT / "test"))  # octave_support: the Octave driver the MATLAB tests use

FUNCTIONS = (
    "BumpsWheelDropsSensorsRoomba(s)",
    "SetFwdVelAngVelCreate(s, 0, 0)",
    "OverheadLocalizationCreate(s)",
    "ReadSonarMultiple(s)",
    "LidarSensorCreate(s)",
)

OCTAVE_LOOP = """
crash_dumps_octave_core(false); sigterm_dumps_octave_core(false);
addpath('{toolbox}');
s = CreateRobot({port});
for attempt = 1:24  % the world may still be starting (compiling its kernels on a cold cache)
  try
    OverheadLocalizationCreate(s);
    break
  catch
  end
end
calls = {{{calls}}};
for k = 1:numel(calls)
  f = str2func(['@(s) ' calls{{k}}]);
  for i = 1:50, f(s); end
  t = zeros({n}, 1);
  for i = 1:{n}
    t0 = tic; f(s); t(i) = toc(t0);
  end
  t = sort(t) * 1e3;
  printf('  %-36s median %6.3f ms   p99 %6.3f ms   max %7.3f ms\\n', ...
         calls{{k}}, median(t), t(ceil(0.99 * {n})), t(end));
end
"""


OCTAVE_PROGRAM = """
SetFwdVelAngVelCreate(s, 0.1, 0);
DistanceSensorRoomba(s);
driven = 0; loops = 0; next_mark = 5;
tic
while toc < {seconds}
  BumpsWheelDropsSensorsRoomba(s);
  loops = loops + 1;
  if toc >= next_mark
    driven = driven + DistanceSensorRoomba(s);
    printf('  at toc %5.1f s: the robot has driven %6.3f m = %5.2f s at 0.1 m/s, lag %+6.3f s\\n', ...
           toc, driven, driven / 0.1, toc - driven / 0.1);
    next_mark = next_mark + 5;
  end
  pause(0.05);
end
SetFwdVelAngVelCreate(s, 0, 0);
printf('  %d loops in %.1f s (%.1f per s; pause(0.05) alone would give 20)\\n', loops, toc, loops / toc);
"""


class Odometry:
    """The robot's odometry as it arrives: when (monotonic) it last reported the robot standing."""

    def __init__(self, namespace: str) -> None:
        import rclpy
        from nav_msgs.msg import Odometry as OdometryMsg
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS

        if not rclpy.ok():
            rclpy.init()
        self.node = Node("matlab_bench_probe")
        self.speed = 0.0
        self.stood_at = 0.0
        self.node.create_subscription(OdometryMsg, f"{namespace}/odom", self._on_odom, SENSOR_SUBSCRIBER_QOS)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        threading.Thread(target=self.executor.spin, daemon=True).start()

    def _on_odom(self, msg) -> None:
        self.speed = abs(msg.twist.twist.linear.x)
        if self.speed == 0.0 and msg.twist.twist.angular.z == 0.0:
            self.stood_at = time.monotonic()

    def wait(self, done, timeout: float = 60.0) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if done():
                return True
            time.sleep(0.001)
        return False


def stop_latency(odom: Odometry, interrupt) -> float:
    """Wall s from ``interrupt()`` (the robot driving) to odometry reporting it standing."""
    if not odom.wait(lambda: odom.speed > 0.1):
        raise RuntimeError("the robot never drove")
    time.sleep(0.5)
    sent = time.monotonic()
    interrupt()
    if not odom.wait(lambda: odom.stood_at > sent, timeout=30):
        raise RuntimeError("the robot never stopped")
    return odom.stood_at - sent


def prompt_runs(port: int, odom: Odometry, runs: int, env: dict[str, str]) -> list[float]:
    """Ctrl-C at an interactive prompt (a pseudo-terminal) inside travelDist, ``runs`` times."""
    from octave_support import OctavePrompt

    from sim_tools.matlab.paths import matlab_dir

    prompt = OctavePrompt(f"addpath('{matlab_dir('create')}'); s = CreateRobot({port}); disp('READY')", env)
    latencies = []
    try:
        for k in range(runs):
            prompt.type("travelDist(s, 0.2, 50)")
            latencies.append(stop_latency(odom, prompt.ctrl_c))
            prompt.type(f"[x, y, a] = OverheadLocalizationCreate(s); printf('POSE%d %.3f\\n', {k}, x)")
            prompt.expect(f"^POSE{k} ", timeout=60)
    finally:
        prompt.close()
    print(f"  the next call after each Ctrl-C answered with the pose ({runs}/{runs})")
    return latencies


def signal_runs(port: int, odom: Odometry, runs: int, signum: int, env: dict[str, str]) -> list[float]:
    """SIGINT/SIGTERM to ``octave --eval`` inside travelDist, ``runs`` times."""
    from octave_support import octave_eval

    from sim_tools.matlab.paths import matlab_dir

    latencies = []
    script = f"addpath('{matlab_dir('create')}'); s = CreateRobot({port}); travelDist(s, 0.2, 50)"
    for _ in range(runs):
        process = octave_eval(script, env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        latencies.append(stop_latency(odom, lambda p=process: p.send_signal(signum)))
        process.wait(timeout=30)
        time.sleep(1.2)  # the bridge confirms the stop before it takes the next program
    return latencies


DEAD_LOOP = """
addpath('{toolbox}'); s = CreateRobot({port});
for attempt = 1:24, try, OverheadLocalizationCreate(s); break, catch, end, end
disp('LOOPING'); fflush(stdout);
while true
  try
    OverheadLocalizationCreate(s); pause(0.01);
  catch e
    printf('ERROR %.6f %s %s\\n', time(), e.identifier, e.message); fflush(stdout); break
  end
end
"""


def dead_world_run(env: dict[str, str]) -> float:
    """Wall s from SIGKILL of the world to the program's CreateRobot:bridge error."""
    from octave_support import octave_eval

    from sim_tools.cli import executable_command
    from sim_tools.matlab.bridge import spawn_bridge
    from sim_tools.matlab.paths import matlab_dir

    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", "map_file:=''", "-r", "__ns:=/bench_dead"]),
        env=env,
        stderr=subprocess.DEVNULL,
    )
    bridge, port = spawn_bridge("/bench_dead", env=env)
    try:
        script = DEAD_LOOP.format(toolbox=matlab_dir("create"), port=port)
        program = octave_eval(script, env, stdout=subprocess.PIPE, text=True)
        assert program.stdout is not None
        while "LOOPING" not in program.stdout.readline():
            pass
        time.sleep(1.0)
        killed = time.time()
        world.kill()
        line = program.stdout.readline().split()
        program.wait(timeout=30)
        if line[:1] != ["ERROR"] or line[2] != "CreateRobot:bridge":
            raise RuntimeError(f"the program did not fail as expected: {line}")
        return float(line[1]) - killed
    finally:
        world.wait()
        bridge.send_signal(signal.SIGINT)
        bridge.wait(timeout=30)


def summary(name: str, seconds: list[float]) -> None:
    ms = sorted(1e3 * s for s in seconds)
    print(f"  {name:48s} median {statistics.median(ms):6.1f} ms   max {ms[-1]:6.1f} ms   ({len(ms)} runs)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2000, help="calls timed per function (default 2000)")
    parser.add_argument("--program-seconds", type=float, default=60.0, help="control program length (0: skip)")
    parser.add_argument("--interrupts", type=int, default=5, help="runs of each interruption (0: skip)")
    args = parser.parse_args()
    from octave_support import OCTAVE, octave_eval

    if OCTAVE is None:
        print("octave-cli not found: install octave and octave-instrument-control", file=sys.stderr)
        return 2
    from sim_tools.cli import executable_command
    from sim_tools.matlab.bridge import spawn_bridge
    from sim_tools.matlab.paths import matlab_dir

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", "map_file:=''", "-r", "__ns:=/bench"]),
        env=env,
        stderr=subprocess.DEVNULL,
    )
    bridge, port = spawn_bridge("/bench", env=env)
    try:
        print(f"load before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
        calls = ", ".join(f"'{c}'" for c in FUNCTIONS)
        script = OCTAVE_LOOP.format(toolbox=matlab_dir("create"), port=port, calls=calls, n=args.calls)
        if args.program_seconds > 0:
            script += OCTAVE_PROGRAM.format(seconds=args.program_seconds)
        if octave_eval(script, env).wait(timeout=600) != 0:
            raise RuntimeError("the timing program failed in Octave")
        if args.interrupts > 0:
            print(f"programs that end badly (load {os.getloadavg()[0]:.2f}): interrupt -> robot standing")
            odom = Odometry("/bench")
            summary("Ctrl-C at the prompt inside travelDist", prompt_runs(port, odom, args.interrupts, env))
            for signum in (signal.SIGINT, signal.SIGTERM):
                latencies = signal_runs(port, odom, args.interrupts, signum, env)
                summary(f"{signal.Signals(signum).name} to octave --eval inside travelDist", latencies)
            summary("world killed -> CreateRobot:bridge", [dead_world_run(env) for _ in range(args.interrupts)])
        print(f"load after: {os.getloadavg()[0]:.2f}")
    finally:
        for process in (bridge, world):
            process.send_signal(signal.SIGINT)
            process.wait(timeout=30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
