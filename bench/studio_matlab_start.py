"""Start and Stop of an m-file program in the studio's Autonomous section, as the page does them
(:func:`studio.create.matlab_program.start_program`, ``MatlabRun.stop``) against a Create world on
an open floor, without the browser.

Prints, for each of N starts: seconds from Start to the bridge listening, to the program's first
toolbox reply (its first printed line), and from Stop to Octave and the bridge both ended (the
robot stopped by the bridge).

    .venv/bin/python bench/studio_matlab_start.py --runs 3
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
import time
from pathlib import Path

from _studio_support import ROOT, use_local_ros

sys.path[0] = str(ROOT)  # the studio package, not bench/studio.py

PROGRAM = """\
function bench_drive(serPort)
tic;
while toc < 600
    SetFwdVelAngVelCreate(serPort, 0.2, 0);
    fprintf('moved %.3f\\n', DistanceSensorRoomba(serPort));
    pause(0.2);
end
end
"""


async def wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise SystemExit(f"not within {timeout:g} s: {what}")
        await asyncio.sleep(0.01)


async def one_run(studio, ns: str) -> tuple[float, float, float]:
    from studio.create.matlab_program import start_program

    start = time.monotonic()
    run = await start_program(studio, ns, "bench_drive.m")
    assert run is not None
    listening = time.monotonic() - start
    await wait_for(lambda: any(line.startswith("moved") for line in run.output), 60.0, "the first reply")
    first = time.monotonic() - start
    stop = time.monotonic()
    run.stop()
    assert not run.running and not run.bridge.running
    return listening, first, time.monotonic() - stop


async def main(runs: int) -> None:
    from studio.shell.app import Studio
    from studio.shell.processes import Child, executable_command, world_ros_args
    from studio.shell.workspace import Workspace

    ws = Path(tempfile.mkdtemp(prefix="bench_matlab_"))
    (ws / "bench_drive.m").write_text(PROGRAM)
    studio = Studio(workspace=Workspace(ws), controllers={})
    ns = "/bench_matlab"
    world = Child("world", executable_command("create_world", world_ros_args(ns, "", "", (0.0, 0.0, 0.0), True)))
    try:
        await wait_for(lambda: any("ready" in line for line in world.output), 120.0, "the world ready")
        results = [await one_run(studio, ns) for _ in range(runs)]
    finally:
        world.stop()
    names = ("bridge listening", "first toolbox reply", "Stop to both ended")
    for name, values in zip(names, zip(*results, strict=True), strict=True):
        print(f"{name}: " + ", ".join(f"{v:.2f}" for v in values) + f" s (median {statistics.median(values):.2f})")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    use_local_ros()
    asyncio.run(main(parser.parse_args().runs))
