"""tf2_msgs built from interfaces/ behaves as Jazzy's: same type hash on the graph (so robot_state_publisher,
RViz and amcl accept our /tf), messages cross a real publisher/subscriber pair; and a machine without a
compiler gets one clear line from the setup step instead of a failed install."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

from sim_runtime.testing import Collector, spin_until, wait_for_match

ROOT = Path(__file__).resolve().parent.parent
BUILD_SCRIPT = ROOT / "interfaces" / "build_interfaces.py"
# What `ros2 topic info -v /tf` reports on a stock Jazzy system (robot_state_publisher, amcl).
JAZZY_TFMESSAGE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def load_build_script():
    spec = importlib.util.spec_from_file_location("build_interfaces", BUILD_SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_tfmessage_on_the_graph_has_jazzys_type_hash(tf2_msgs, make_node):
    from tf2_msgs.msg import TFMessage

    node = make_node("tf_hash")
    node.create_publisher(TFMessage, "tf_hash_probe", 10)
    (info,) = node.get_publishers_info_by_topic("tf_hash_probe")
    assert info.topic_type == "tf2_msgs/msg/TFMessage"
    assert str(info.topic_type_hash) == JAZZY_TFMESSAGE_HASH


def test_a_published_tfmessage_arrives_with_every_field(tf2_msgs, executor, make_node):
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage

    publisher = make_node("tf_pub").create_publisher(TFMessage, "tf_roundtrip", 10)
    received = Collector(make_node("tf_sub"), TFMessage, "tf_roundtrip", 10)
    assert wait_for_match(executor, publisher)
    transform = TransformStamped()
    transform.header.frame_id = "odom"
    transform.header.stamp.sec = 12
    transform.child_frame_id = "base_link"
    transform.transform.translation.x = 1.5
    transform.transform.rotation.z = 0.6
    transform.transform.rotation.w = 0.8
    publisher.publish(TFMessage(transforms=[transform, transform]))
    assert spin_until(executor, lambda: received.msgs, timeout=10)
    (got,) = received.msgs
    assert len(got.transforms) == 2
    first = got.transforms[0]
    assert (first.header.frame_id, first.child_frame_id, first.header.stamp.sec) == ("odom", "base_link", 12)
    assert (first.transform.translation.x, first.transform.rotation.z, first.transform.rotation.w) == (1.5, 0.6, 0.8)


def test_the_rest_of_jazzys_tf2_msgs_is_there(tf2_msgs):
    from tf2_msgs.action import LookupTransform
    from tf2_msgs.msg import TF2Error
    from tf2_msgs.srv import FrameGraph

    assert (TF2Error.NO_ERROR, TF2Error.LOOKUP_ERROR, TF2Error.TRANSFORM_ERROR) == (0, 1, 6)
    assert FrameGraph.Response().frame_yaml == ""
    goal = LookupTransform.Goal(target_frame="map", source_frame="base_link", advanced=True, fixed_frame="odom")
    assert (goal.target_frame, goal.advanced) == ("map", True)
    assert LookupTransform.Result().error.error == TF2Error.NO_ERROR


def test_without_a_compiler_the_setup_step_says_tf_and_the_set_pose_service_are_off_and_goes_on():
    env = dict(os.environ, CC="/nonexistent/cc", CXX="/nonexistent/c++")
    done = subprocess.run(
        [sys.executable, str(BUILD_SCRIPT), "--force"], env=env, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 2, done.stdout
    assert lines[0].startswith("TF is off: tf2_msgs is not built") and "/nonexistent/cc" in lines[0], lines[0]
    assert lines[1].startswith("The set_pose service is off: robot_sims_interfaces is not built"), lines[1]
    assert all(line.endswith("install gcc g++ python3-dev to enable") for line in lines), lines
    assert done.stderr == ""


def test_the_makefile_builds_tf2_msgs_after_the_project_has_put_the_ros_wheels_in_the_venv():
    done = subprocess.run(
        ["make", "-n", "-B", "-C", str(ROOT), ".venv/.robot_sims-installed"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    recipe = done.stdout
    assert "interfaces/build_interfaces.py" in recipe
    # its CMake build finds fastrtps_cmake_module & co. in the venv, where the project's install puts them
    assert recipe.index("pip install --quiet -e") < recipe.index("interfaces/build_interfaces.py")
