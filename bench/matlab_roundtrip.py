"""Toolbox call round trip from Octave through ``matlab_bridge`` to a running create_world.

    .venv/bin/python bench/matlab_roundtrip.py [--calls 2000] [--program-seconds 60]

Starts create_world (empty floor, real time) and ``robot_sims matlab_bridge`` in their own
processes, then times ``--calls`` calls of each function in one Octave session, wall clock from
``tic`` before the call to ``toc`` after its outputs are decoded. Goal: median <= 1 ms, p99 <= 5 ms.

Then a control program in the original's style runs for ``--program-seconds`` (0: skip): drive at
0.1 m/s, read the bumpers and ``pause(0.05)`` in a ``tic; while toc < T`` loop, and every 5 s
compare ``toc`` with the robot's own clock, read as odometry distance / speed: the lag between
them must not grow (the robot keeps up with the program's wall clock at real time).
Prints the machine's load (os.getloadavg) before and after.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2000, help="calls timed per function (default 2000)")
    parser.add_argument("--program-seconds", type=float, default=60.0, help="control program length (0: skip)")
    args = parser.parse_args()
    octave = shutil.which("octave-cli")
    if octave is None:
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
        subprocess.run([octave, "--no-gui", "--quiet", "--eval", script], check=True, timeout=600)
        print(f"load after: {os.getloadavg()[0]:.2f}")
    finally:
        for process in (bridge, world):
            process.send_signal(signal.SIGINT)
            process.wait(timeout=30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
