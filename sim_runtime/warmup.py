"""Compile every numba kernel once, into numba's on-disk cache, so a user's first world starts in seconds.

``python -m sim_runtime.warmup`` (run by ``make venv``) drives each simulator's pure model the way its
node does, on small inputs: the Create's step and every sensor, a SIMROBOT world with both sensor
types, an arm's forward/inverse kinematics and dynamics, the STL readers (binary and ASCII) and the
rotation kernel, the bag index. Without it the first start of a world spends ~30 s compiling. Each kernel is
cached per argument types, so the calls below pass what the nodes pass.

The worlds themselves compile every kernel they can use before they are ready (their models'
``compile_kernels``), with :func:`announce_compiling` saying so only when numba really compiles and
:func:`compiled_aside` sharing the work with a second process on a cold cache.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

#: What a world logs before numba compiles its first kernel (only then: loads from the cache are silent).
COMPILING_NOTICE = "compiling kernels (first run only, ~30 s) ..."


@contextmanager
def announce_compiling(say: Callable[[str], None]) -> Iterator[None]:
    """Within the block, ``say`` :data:`COMPILING_NOTICE` once when numba starts compiling a kernel
    (a cache miss: nothing when every kernel comes from numba's cache, wherever that is), and when
    the block ends how long it took."""
    from numba.core import event

    class Notice(event.Listener):
        def __init__(self) -> None:
            self.depth = 0  # a kernel's callees are compiled inside its own compile event
            self.compiled = 0
            self.started = 0.0

        def on_start(self, _event: event.Event) -> None:
            if self.depth == 0 and self.compiled == 0:
                say(COMPILING_NOTICE)
                self.started = time.monotonic()
            self.depth += 1

        def on_end(self, _event: event.Event) -> None:
            self.depth -= 1
            self.compiled += self.depth == 0

    notice = Notice()
    with event.install_listener("numba:compile", notice):
        yield
    if notice.compiled:
        seconds = time.monotonic() - notice.started
        say(f"kernels compiled in {seconds:.1f} s (numba caches them for the next start)")


@contextmanager
def compiled_aside(obj: Any, method: str, enabled: bool = True) -> Iterator[None]:
    """Within the block, the first time numba starts compiling (a cold cache), start a process that
    calls ``method`` of a copy of ``obj`` (pickled now, before the block changes it): numba compiles
    one kernel at a time per process, so that method's kernels are compiled, into numba's cache,
    beside whatever the block compiles; call it after the block and it loads them. At the end of
    the block, wait for the helper. Nothing starts when everything is cached or on a single core."""
    from numba.core import event

    pickled = pickle.dumps(obj) if enabled and (os.cpu_count() or 1) > 1 else b""
    helpers: list[subprocess.Popen] = []

    class StartHelper(event.Listener):
        def on_start(self, _event: event.Event) -> None:
            if pickled and not helpers:
                helpers.append(_start_helper(pickled, method))

        def on_end(self, _event: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", StartHelper()):
        yield
    for helper in helpers:
        helper.wait()  # its outcome does not matter: anything it did not cache is compiled afterwards


def _start_helper(pickled: bytes, method: str) -> subprocess.Popen:
    """A process that unpickles an object from its stdin and calls its ``method``."""
    # the same modules from the same files (numba's cache is per file), nothing on the terminal
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    helper = subprocess.Popen(
        # -P: not the current directory first
        [sys.executable, "-P", "-c", f"import pickle, sys; pickle.load(sys.stdin.buffer).{method}()"],
        stdin=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    stdin = helper.stdin
    assert stdin is not None

    def feed() -> None:  # in a thread: the pipe fills until the helper has imported numba
        with stdin:
            stdin.write(pickled)

    threading.Thread(target=feed, daemon=True).start()
    return helper


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
    from sim_runtime.bag.index import _message_records
    from studio.replay import Replay

    with tempfile.TemporaryDirectory() as tmp:
        replay = Replay.open(write_create_run(Path(tmp) / "run", 1.0))
        replay.frame(replay.start_ns)
        replay.index.close()
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
