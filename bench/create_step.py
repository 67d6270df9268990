"""Full-sensor Create model step rate per CPU-second, for before/after comparisons of a change.

    for t in OLD_TREE NEW_TREE; do PYTHONPATH=$t .venv/bin/python bench/create_step.py; done

Physics + every sensor on bench/create_world.py's random map (example noise), best of 5 × 2,000
steps; CPU time of this process only, so other load on the machine moves it less than wall time.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from create_world import free_poses, random_map

from create_sim.configfile import load_config
from create_sim.model import CreateModel
from sim_runtime.paths import config_path


def main() -> None:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    world = random_map()
    robot = CreateModel(world, load_config(config_path("create/example_config.txt")), pose=free_poses(world, 1)[0])

    def run(steps: int) -> None:
        for _ in range(steps):
            robot.set_velocity(0.3, 0.5)
            robot.step(0.01)
            robot.bumps(), robot.cliff_signals(), robot.wall_sensor(), robot.virtual_wall()
            robot.sonar(), robot.lidar(), robot.camera()

    run(200)  # compile / load the kernels
    best = 0.0
    for _ in range(5):
        start = time.process_time()
        run(2000)
        best = max(best, 2000 / (time.process_time() - start))
    import create_sim

    print(f"{Path(create_sim.__file__).parent.parent}: {best:.0f} steps per CPU-second, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
