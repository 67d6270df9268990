"""Compile every numba kernel once, into numba's on-disk cache, so a user's first world starts in seconds.

``python -m sim_tools.warmup`` (run by ``make venv``) drives each simulator's pure model the way its
node does, on small inputs: the Create's step and every sensor, a SIMROBOT world with both sensor
types, an arm's forward/inverse kinematics and dynamics, the STL readers (binary and ASCII) and the
rotation kernel, the bag index. Without it the first start of a world spends ~30 s compiling. Each kernel is
cached per argument types, so the calls below pass what the nodes pass.

The worlds themselves compile every kernel they can use before they are ready
(:mod:`sim_runtime.kernels`).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def warm_create() -> None:
    from create_sim.configfile import load_config
    from create_sim.mapfile import load_map
    from create_sim.model import CreateModel
    from sim_runtime.paths import config_path

    world = load_map(config_path("create/example.map"))
    CreateModel(world, load_config(config_path("create/example_config.txt"))).compile_kernels()


def warm_simrobot() -> None:
    from sim_runtime.paths import config_path
    from simrobot_sim.model import SimrobotWorld
    from simrobot_sim.world_file import load_world

    sensor = "{{name: {0}, type: {1}, position: [0.05, 0], axis: 0, beamwidth: 60, range: 0.5, rays: 30}}"
    robot = "  - name: r{0}\n    position: [{1}, 1.55]\n    sensors:\n      - {2}\n      - {3}\n"
    robots = "".join(
        robot.format(i, x, sensor.format("us", "ultrasonic"), sensor.format("lz", "laser"))
        for i, x in ((1, 1.3), (2, 1.8))
    )
    for model in ("exact", "original"):
        world_text = (
            f"map: {config_path('simrobot/demo_map.png')}\nresolution: 0.01\ndt: 1.0\n"
            f"sensor_model: {model}\nrobots:\n{robots}"
        )
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "warmup.yaml"
            path.write_text(world_text)
            SimrobotWorld(load_world(path)).compile_kernels()


def warm_arm() -> None:
    from arm_sim.arm import Arm
    from arm_sim.stl import parse_stl
    from sim_runtime.paths import config_path
    from sim_runtime.rotations import quaternions_xyzw

    arm = Arm.from_file(config_path("arm/irb120.yaml"))  # reads its binary STL meshes
    q = arm.mid_range()
    frames = arm.fkine_all(q)
    quaternions_xyzw(np.ascontiguousarray(frames))
    arm.fkine(q), arm.jacob0(q), arm.rne(q, q, q), arm.gravload(q), arm.inertia(q)
    arm.ikine(arm.fkine(q + 0.1), q0=q)
    arm.ikine_batch(np.stack([arm.fkine(q)] * 2), np.tile(q, (2, 1)))
    Q = np.tile(q, (2, 1))
    arm.fkine_batch(Q), arm.jacob0_batch(Q), arm.rne_batch(Q, Q, Q)
    triangle = b"facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
    parse_stl(b"solid t\n" + triangle + b"endsolid t\n")  # the ASCII reader


def warm_replay() -> None:
    """The bag index and the fast pose reader the studio's Replay page opens a bag with."""
    from create_sim.synthetic_run import write_create_run
    from sim_runtime.bag.cdr import track_positions
    from sim_runtime.bag.index import BagIndex, _message_records

    with tempfile.TemporaryDirectory() as tmp:
        index = BagIndex.open(write_create_run(Path(tmp) / "run", 1.0))
        for topic, info in index.by_topic.items():
            track_positions(info.type, [m.data for m in index.messages(topic)])
        index.close()
    _message_records(np.frombuffer(bytes(9), dtype=np.uint8))  # chunks without message indexes


WARMERS = {"create": warm_create, "simrobot": warm_simrobot, "arm": warm_arm, "replay": warm_replay}


def main() -> int:
    """Warm every simulator's kernels; one line with the time taken."""
    start = time.monotonic()
    for name, warm in WARMERS.items():
        try:
            warm()
        except Exception as error:  # a warm-up failure must not fail the install; the world would compile later
            print(f"numba warm-up of {name} failed ({type(error).__name__}: {error}); it compiles on first use")
    print(f"numba kernels compiled and cached in {time.monotonic() - start:.0f} s (worlds now start in seconds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
