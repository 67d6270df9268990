"""A fourth simulator is drawn by ``robot_sims bag_to_rerun`` from its registry entry alone.

The toy simulator (``test/toy_sim``: a point robot publishing ``odom`` on an empty plane) is added
for the converter's process with ``ROBOT_SIMS_SIMULATORS=toy=toy_sim.adapter``; its ``rerun`` part
(``test/toy_sim/adapter/rerun.py``) says how its robot looks. Nothing in sim_tools names it."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rerun_test_helpers import blueprint_views, column, load_entities, stamp
from toy_sim.adapter.rerun import LOOK, TRIANGLE_M

from sim_runtime.bag.writer import BagWriter
from sim_runtime.msgs import set_planar_pose
from sim_tools.rerun_view.convert import bag_to_rerun

ROOT = Path(__file__).resolve().parents[1]
TOY = {
    "ROBOT_SIMS_SIMULATORS": "toy=toy_sim.adapter",
    "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "test")]),
}
BODY = "/top/map/robots/robot/body"
SIMULATOR_PACKAGES = ("create_sim", "simrobot_sim", "arm_sim", "sim_tools.adapters.")


def write_toy_bag(folder: Path, steps: int = 30) -> Path:
    """A recording of the toy world: ``cmd_vel`` once, then ``odom`` at 10 Hz along a quarter circle."""
    with BagWriter(folder) as bag:
        odom_id = bag.add_topic("/odom", "nav_msgs/msg/Odometry", "")
        cmd_id = bag.add_topic("/cmd_vel", "geometry_msgs/msg/Twist", "")
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = 0.5, 0.5
        bag.write(cmd_id, 0, serialize_message(cmd))
        for k in range(steps):
            t_ns = 100_000_000 * (k + 1)
            theta = 0.05 * (k + 1)
            msg = Odometry(child_frame_id="base_link")
            msg.header.stamp, msg.header.frame_id = stamp(t_ns / 1e9), "odom"
            set_planar_pose(msg.pose.pose, np.sin(theta), 1.0 - np.cos(theta), theta)
            bag.write(odom_id, t_ns, serialize_message(msg))
    return folder


def robot_sims_bag_to_rerun(bag: Path, out: Path) -> subprocess.CompletedProcess:
    """``robot_sims bag_to_rerun BAG -o OUT`` in its own process, the toy registered."""
    cli = Path(sys.executable).with_name("robot_sims")
    return subprocess.run(
        [str(cli), "bag_to_rerun", str(bag), "-o", str(out), "--no-progress"],
        env={**os.environ, **TOY},
        text=True,
        capture_output=True,
        timeout=120,
    )


@pytest.fixture(scope="module")
def toy_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_toy_bag(tmp_path_factory.mktemp("toy") / "toy_bag")


def test_the_toy_robot_is_drawn_by_its_adapter_from_its_registry_entry(toy_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "toy.rrd"
    done = robot_sims_bag_to_rerun(toy_bag, out)
    assert done.returncode == 0, done.stderr
    ents = load_entities(out)
    # the toy's triangle, not the default dot, in the robot's colour
    assert column(ents[BODY], "LineStrips2D:strips") == [[TRIANGLE_M.tolist()]]
    assert column(ents[BODY], "Points2D:positions") == []
    heading = column(ents[f"{BODY}/heading"], "Arrows2D:vectors")
    assert heading == [[pytest.approx([LOOK.heading_m, 0.0])]]
    # its pose follows the odometry (its only pose) and its track is drawn
    moves = column(ents["/top/map/robots/robot"], "Transform3D:translation")
    assert len(moves) == 30 and moves[-1][0] == pytest.approx([np.sin(1.5), 1.0 - np.cos(1.5), 0.0], abs=1e-6)
    assert any(e.startswith("/top/map/tracks/robot/odom") for e in ents)
    # the view following it is as wide as its look says
    views = {v["ViewBlueprint:display_name"][0]: v for v in blueprint_views(out)}
    half = LOOK.follow_half_width_m
    (bounds,) = views["robot (follows)"]["VisualBounds2D:range"]
    assert bounds == {"x_range": [-half, half], "y_range": [-half, half]}


def test_without_its_registry_entry_the_toy_robot_gets_the_default_dot(toy_bag: Path, tmp_path: Path) -> None:
    assert "ROBOT_SIMS_SIMULATORS" not in os.environ
    ents = load_entities(bag_to_rerun(toy_bag, tmp_path / "plain.rrd", progress=False))
    assert column(ents[BODY], "LineStrips2D:strips") == []
    assert len(column(ents[BODY], "Points2D:positions")) == 1


def test_the_views_and_their_drawing_kit_import_no_simulator() -> None:
    """Only the registry (``sim_tools.adapters`` itself) may be named: each simulator comes from it."""
    named = {}
    for path in [*(ROOT / "sim_tools" / "rerun_view").glob("*.py"), *(ROOT / "sim_tools" / "rerun_kit").glob("*.py")]:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            modules = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            modules += [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            named.update({f"{path.name}: {m}": m for m in modules if m.startswith(SIMULATOR_PACKAGES)})
    assert not named
    assert any(path.name == "logger.py" for path in (ROOT / "sim_tools" / "rerun_view").glob("*.py"))
