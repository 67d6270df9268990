"""Compile every numba kernel once, into numba's on-disk cache, so a user's first world starts in seconds.

``python -m sim_tools.warmup`` (run by ``make venv``) has each registered simulator's adapter drive
its pure model the way its node does, on small inputs (``warm_up`` in
:mod:`sim_tools.adapters.contract`: the Create's step and every sensor, a SIMROBOT world with both
sensor types, an arm's forward/inverse kinematics and dynamics, the STL readers and the rotation
kernel), then the bag index on a simulator's sample run. Without it the first start of a world
spends ~30 s compiling. Each kernel is cached per argument types, so the calls pass what the nodes
pass.

The worlds themselves compile every kernel they can use before they are ready
(:mod:`sim_runtime.kernels`).
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sim_tools.adapters.contract import world_parts


def warm_replay() -> None:
    """The bag index and the fast pose reader the studio's Replay page opens a bag with, on the
    first simulator's sample run that has one."""
    from sim_runtime.bag.cdr import track_positions
    from sim_runtime.bag.index import BagIndex, _message_records

    for sample_run in [part.sample_run for part in world_parts().values() if part.sample_run is not None][:1]:
        with tempfile.TemporaryDirectory() as tmp:
            index = BagIndex.open(sample_run(Path(tmp)))
            for topic, info in index.by_topic.items():
                track_positions(info.type, [m.data for m in index.messages(topic)])
            index.close()
    _message_records(np.frombuffer(bytes(9), dtype=np.uint8))  # chunks without message indexes


def warm_learning() -> None:
    """The learning environments' own kernels (the arm's step, the Create observation's clip in
    both precisions: the env's float32 LIDAR, ``policy_controller``'s float64; the SIMROBOT env's
    wheels and rewards), where Gymnasium (and PettingZoo) is installed."""
    import importlib.util

    if importlib.util.find_spec("gymnasium") is None:
        return
    from sim_tools.rl.arm_reach import ArmReachEnv
    from sim_tools.rl.create_nav import CreateNavEnv
    from sim_tools.rl.create_sensors import SENSORS

    for env in (ArmReachEnv(), CreateNavEnv(sensors=SENSORS)):
        env.reset(seed=0)
        env.step(env.action_space.sample())
    if importlib.util.find_spec("pettingzoo") is not None:
        from sim_tools.rl.simrobot_parallel import SimrobotParallelEnv

        agents = SimrobotParallelEnv()
        agents.reset(seed=0)
        agents.step({agent: agents.action_space(agent).sample() for agent in agents.agents})


def warmers() -> dict[str, Callable[[], None]]:
    """Every registered simulator's warm-up by its name, then the bag readers' (``replay``) and the
    learning environments' (``learning``)."""
    parts = {name: part.warm_up for name, part in world_parts().items()}
    return {**parts, "replay": warm_replay, "learning": warm_learning}


def main() -> int:
    """Warm every simulator's kernels; one line with the time taken."""
    start = time.monotonic()
    for name, warm in warmers().items():
        try:
            warm()
        except Exception as error:  # a warm-up failure must not fail the install; the world would compile later
            print(f"numba warm-up of {name} failed ({type(error).__name__}: {error}); it compiles on first use")
    print(f"numba kernels compiled and cached in {time.monotonic() - start:.0f} s (worlds now start in seconds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
