"""The original's demo: four robots running alg2 for 300 steps on a drawn map, plus its tracks PNG.

``python -m simrobot_sim.demo [out_dir]`` or :func:`run_demo` (the lead's ``make demo``).
The original demo map is lost; :func:`draw_demo_map` draws the shipped one (5 m x 5 m at 1 cm:
four rooms joined by doorways, a few boxes and a round pillar).

A fifth robot, :data:`CRASH_ROBOT`, joins the world file's four in the south-east room, away
from them: its alg2 threshold is too small to ever turn (a classic controller bug), so it drives
into the east wall and crashes about two thirds into the run: the demo shows what a crash looks like.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image

from sim_runtime.paths import config_path
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec, load_world

if TYPE_CHECKING:
    from rclpy.node import Node

DEMO_WORLD = "simrobot/demo.yaml"
CRASH_ROBOT = RobotSpec(
    name="r5",
    position=(4.0, 0.8),
    heading=0.0,  # east: 0.96 m from the wall, 0.5 cm a step
    color=(1.0, 0.2, 0.6),
    sensors=(SensorSpec(name="sens1", kind="ultrasonic"),),
)
CRASH_THRESHOLD_M = 1e-6
"""The crash robot's alg2 threshold: no echo is ever this near, so it never turns."""


def draw_demo_map(path: str | Path, size: int = 500) -> Path:
    """Write the demo map as a 1-bit PNG (black = wall); image row 0 is the top (max y)."""
    occ = np.zeros((size, size), dtype=bool)  # [row, col], row 0 = top
    wall = 4
    occ[:wall, :] = occ[-wall:, :] = occ[:, :wall] = occ[:, -wall:] = True
    mid = size // 2
    # cross of inner walls with one doorway per arm
    occ[mid - 2 : mid + 2, :] = True
    occ[:, mid - 2 : mid + 2] = True
    for r0, r1, c0, c1 in (
        (mid - 2, mid + 2, 90, 170),  # west doorway
        (mid - 2, mid + 2, 330, 410),  # east doorway
        (90, 170, mid - 2, mid + 2),  # north doorway
        (330, 410, mid - 2, mid + 2),  # south doorway
    ):
        occ[r0:r1, c0:c1] = False
    # boxes and a pillar
    for r0, r1, c0, c1 in ((60, 100, 60, 120), (140, 160, 330, 440), (380, 440, 300, 330), (300, 330, 60, 90)):
        occ[r0:r1, c0:c1] = True
    rr, cc = np.mgrid[0:size, 0:size]
    occ |= (rr - 400) ** 2 + (cc - 130) ** 2 < 25**2
    path = Path(path)
    Image.fromarray(~occ).convert("1").save(path)
    return path


def demo_world() -> WorldSpec:
    """The world file's four robots plus :data:`CRASH_ROBOT`."""
    spec = load_world(config_path(DEMO_WORLD))
    return dataclasses.replace(spec, robots=(*spec.robots, CRASH_ROBOT))


def run_demo(
    out_dir: str | Path, steps: int = 300, extra_nodes: Callable[[Any], Sequence[Any]] | None = None
) -> dict[str, Any]:
    """Run the demo world in lockstep with its five in-process alg2 controllers and write
    ``simrobot_tracks.png`` into ``out_dir``. Returns a summary (steps, per-robot distance
    travelled in metres, crashed robots, PNG path). ``extra_nodes(context)`` adds nodes (a
    recorder, a viewer) to the demo's executor."""

    from rclpy.parameter import Parameter

    from sim_runtime.bag.record import wait_for_recorders
    from sim_runtime.run import private_ros, spin_steps
    from sim_runtime.track_plot import draw_tracks
    from simrobot_sim.avoid import AvoidNode
    from simrobot_sim.world_node import SimrobotWorldNode

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    spec = demo_world()
    nodes: list[Node] = []
    with private_ros() as (context, executor):
        world = SimrobotWorldNode(spec, context=context)
        nodes.append(world)
        for robot in spec.robots:
            sonar = next(s.name for s in robot.sensors if s.kind == "ultrasonic")
            overrides = [Parameter("threshold", value=CRASH_THRESHOLD_M)] if robot is CRASH_ROBOT else []
            nodes.append(AvoidNode(robot=robot.name, sensor=sonar, context=context, parameter_overrides=overrides))
        if extra_nodes is not None:
            nodes += extra_nodes(context)
        for node in nodes:
            executor.add_node(node)
        wait_for_recorders(executor, nodes, world)
        done = spin_steps(executor, world, steps)
        model = world.model
        tracks = model.tracks()
        colors = {name: tuple(model.colors[i]) for i, name in enumerate(model.names)}
        occupancy = np.asarray(spec.walls).T  # OccupancyGrid layout: rows along y
        png = draw_tracks(
            occupancy,
            model.resolution,
            model.origin,
            tracks,
            colors,
            out_dir / "simrobot_tracks.png",
            title=f"SIMROBOT demo: {len(tracks)} robots, alg2, {done} steps",
        )
        travelled = {n: float(np.hypot(*np.diff(xy, axis=0).T).sum()) for n, xy in tracks.items()}
        return {
            "steps": done,
            "travelled_m": travelled,
            "crashed": [n for i, n in enumerate(model.names) if model.crashed[i]],
            "tracks_png": str(png),
        }


if __name__ == "__main__":
    print(run_demo(sys.argv[1] if len(sys.argv) > 1 else "out"))
