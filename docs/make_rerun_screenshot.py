"""Regenerate docs/rerun_create.png: the Create demo (bump_turn) drawn by bag_to_rerun in Rerun.

Run from the repository root (needs Xvfb and Mesa software rendering; the Rerun viewer runs with a
private config home where analytics are disabled)::

    PYTHONPATH=. ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python docs/make_rerun_screenshot.py

Xvfb and Mesa's Vulkan driver: ``apt-get install xvfb mesa-vulkan-drivers``. Rerun's OpenGL path
needs R32Float render targets that llvmpipe's GL lacks, so the viewer runs on lavapipe (Vulkan).
"""

from __future__ import annotations

import copy
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import rclpy
from rclpy.node import Node

from create_sim.bump_turn import BumpTurnNode
from create_sim.world_node import CreateWorldNode
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.rerun_view.analytics import private_rerun_env, rerun_cli
from sim_runtime.rerun_view.convert import bag_to_rerun
from sim_runtime.rerun_view.logger import type_name
from sim_runtime.run import drain, make_executor

SIM_SECONDS = 40.0
DOCS = Path(__file__).resolve().parent


def record_demo(bag: Path) -> None:
    rclpy.init()
    executor = make_executor()
    world = CreateWorldNode(parameter_overrides=[])
    controller = BumpTurnNode()
    recorder = Node("screenshot_recorder")
    for node in (world, controller, recorder):
        executor.add_node(node)
    writer = BagWriter(bag)
    for pub in world.publishers:
        tid = writer.add_topic(pub.topic_name, type_name(pub.msg_type), qos_profiles_yaml([{}]))
        qos = copy.copy(pub.qos_profile)
        qos.depth = 200
        recorder.create_subscription(
            pub.msg_type,
            pub.topic_name,
            lambda data, tid=tid: writer.write(tid, round(world.sim_time * 1e9), data),
            qos,
            raw=True,
        )
    for _ in range(50):
        executor.spin_once(timeout_sec=0.05)
    while world.sim_time < SIM_SECONDS:
        world.step(5)
        drain(executor)
    writer.close()
    rclpy.shutdown()


def screenshot(rrd: Path, png: Path, home: Path) -> None:
    env = private_rerun_env(home)
    env.update({"WGPU_BACKEND": "vulkan", "XDG_RUNTIME_DIR": str(home)})
    # The X screen is larger than the window so the pointer (centre of the screen) hovers nothing.
    cmd = [
        "xvfb-run",
        "-a",
        "-s",
        "-screen 0 3600x2400x24",
        rerun_cli(),
        str(rrd),
        "--window-size",
        "1600x1000",
        "--screenshot-to",
        str(png),
    ]
    subprocess.run(cmd, env=env, check=True, timeout=300)


def main() -> None:
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / "create_demo"
        record_demo(bag)
        rrd = bag_to_rerun(bag, Path(tmp) / "create_demo.rrd", progress=False)
        screenshot(rrd, DOCS / "rerun_create.png", Path(tmp) / "rerun_home")
    print(f"wrote {DOCS / 'rerun_create.png'}", file=sys.stderr)


if __name__ == "__main__":
    main()
