"""The Create's ``set_pose`` service (robot_sims_interfaces/SetPose), called as a ROS user calls it:
an accepted pose moves the robot (the ground truth and odometry show it), a refused one answers
success=false with the reason and leaves the robot where it was, and the ``set_pose`` topic works
beside it; without the interface package the world says so once and keeps the topic."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest
from geometry_msgs.msg import PoseStamped
from test_create_node import Rig

from create_sim import spec
from sim_runtime.msgs import pose_msg, time_from_msg, yaw_from_quaternion
from sim_runtime.qos import COMMAND_PUBLISHER_QOS
from sim_runtime.testing import wait_for_match

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def set_pose_type():
    """SetPose, skipped only where the setup step could not build it for want of a compiler."""
    if importlib.util.find_spec("robot_sims_interfaces") is None:
        spec_ = importlib.util.spec_from_file_location("build_interfaces", ROOT / "interfaces" / "build_interfaces.py")
        build = importlib.util.module_from_spec(spec_)
        spec_.loader.exec_module(build)
        missing = build.missing_build_tools()
        if missing:
            pytest.skip(f"the set_pose service is off on this machine: {missing}")
    from robot_sims_interfaces.srv import SetPose

    return SetPose


def request(set_pose_type, x: float, y: float, yaw: float, frame: str = "map"):
    req = set_pose_type.Request(pose=PoseStamped(pose=pose_msg(x, y, yaw)))
    req.pose.header.frame_id = frame
    return req


def ground_truth(rig: Rig) -> tuple[float, float, float]:
    """The overhead pose published after the next physics steps (what a ROS user sees)."""
    rig["overhead_pose"].clear()
    rig.step(2)
    rig.wait(lambda: rig["overhead_pose"].last is not None)
    msg = rig["overhead_pose"].last
    assert time_from_msg(msg.header.stamp) > 0.0
    p = msg.pose.position
    return p.x, p.y, yaw_from_quaternion(msg.pose.orientation)


def test_an_accepted_pose_moves_the_robot_and_says_where_it_is(executor, make_node, tmp_path, set_pose_type):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[-1.0, 0.5, 0.3])
    rig.listen("overhead_pose", "odom")
    response = rig.call(set_pose_type, spec.SET_POSE_SERVICE, request(set_pose_type, 0.5, -0.5, -1.0))
    assert response.success, response.message
    assert response.message == "robot at (0.5, -0.5, -1) in the map"
    assert ground_truth(rig) == pytest.approx((0.5, -0.5, -1.0))
    # odometry keeps counting from where it was: the robot did not drive there
    rig.wait(lambda: rig["odom"].last is not None)
    assert rig["odom"].last.pose.pose.position.x == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(
    ("pose", "frame", "reason"),
    [
        ((2.0, 0.0, 0.0), "map", "inside a wall"),
        ((math.nan, 0.0, 0.0), "map", "not finite within ±1e+06"),
        ((0.0, 2e6, 0.0), "map", "not finite within ±1e+06"),
        ((0.5, 0.5, 0.0), "odom", "frame 'odom' is not 'map'"),
    ],
    ids=["in a wall", "NaN", "beyond the coordinate bound", "another frame"],
)
def test_a_refused_pose_answers_false_with_the_reason_and_leaves_the_robot(
    executor, make_node, tmp_path, set_pose_type, pose, frame, reason
):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[-1.0, 0.5, 0.3])
    rig.listen("overhead_pose")
    response = rig.call(set_pose_type, spec.SET_POSE_SERVICE, request(set_pose_type, *pose, frame=frame))
    assert not response.success
    assert response.message.startswith("set_pose refused: ") and reason in response.message, response.message
    assert ground_truth(rig) == pytest.approx((-1.0, 0.5, 0.3))


def test_the_set_pose_topic_still_moves_the_robot_beside_the_service(executor, make_node, tmp_path, set_pose_type):
    rig = Rig(executor, make_node, tmp_path)
    rig.listen("overhead_pose")
    pub = rig.probe.create_publisher(PoseStamped, spec.SET_POSE_TOPIC, COMMAND_PUBLISHER_QOS)
    assert wait_for_match(rig.executor, pub)
    target = PoseStamped(pose=pose_msg(-0.5, 0.5, 1.0))
    target.header.frame_id = "map"
    pub.publish(target)
    rig.wait(lambda: tuple(rig.world.model.pose[:2]) == pytest.approx((-0.5, 0.5)))
    assert ground_truth(rig) == pytest.approx((-0.5, 0.5, 1.0))
    # and the service answers on the same name, next to the topic
    response = rig.call(set_pose_type, spec.SET_POSE_SERVICE, request(set_pose_type, 0.25, 0.0, 0.0))
    assert response.success and ground_truth(rig) == pytest.approx((0.25, 0.0, 0.0))


def test_without_the_interface_package_the_world_says_the_service_is_off_and_the_topic_works(
    executor, make_node, tmp_path, monkeypatch, capfd
):
    import create_sim.world_node

    monkeypatch.setattr(create_sim.world_node, "SetPose", None)
    rig = Rig(executor, make_node, tmp_path)
    services = dict(rig.world.get_service_names_and_types_by_node(rig.world.get_name(), "/"))
    assert "/set_pose" not in services and "/reset" in services
    err = capfd.readouterr().err
    assert err.count("the set_pose service is off") == 1 and "robot_sims_interfaces is not installed" in err
    pub = rig.probe.create_publisher(PoseStamped, spec.SET_POSE_TOPIC, COMMAND_PUBLISHER_QOS)
    assert wait_for_match(rig.executor, pub)
    pub.publish(PoseStamped(pose=pose_msg(0.5, 0.5, 0.0)))
    rig.wait(lambda: tuple(rig.world.model.pose[:2]) == pytest.approx((0.5, 0.5)))
