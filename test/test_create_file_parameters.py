"""create_world's map_file and config_file set through the parameter service, as `ros2 param set`
does: a file of another kind (/etc/passwd) is refused with the reason, and the rows a good file
skips are logged on /rosout by the node, not printed as Python warnings."""

from __future__ import annotations

import warnings

import pytest
from rcl_interfaces.msg import Log
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSDurabilityPolicy, QoSProfile, QoSReliabilityPolicy

from create_sim.world_node import CreateWorldNode
from sim_runtime.testing import spin_until

NOT_A_CONFIG = "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n"
ROSOUT_QOS = QoSProfile(
    depth=100, reliability=QoSReliabilityPolicy.RELIABLE, durability=QoSDurabilityPolicy.TRANSIENT_LOCAL
)


@pytest.fixture
def world(executor, tmp_path):
    node = CreateWorldNode(
        node_name="files_world",
        parameter_overrides=[Parameter("map_file", value=""), Parameter("real_time_factor", value=0.0)],
    )
    executor.add_node(node)
    return node


def set_parameter(executor, make_node, world, name: str, value: str):
    client = AsyncParameterClient(make_node("ros2_param"), world.get_fully_qualified_name())
    assert client.wait_for_services(timeout_sec=5.0)
    future = client.set_parameters([Parameter(name, value=value)])
    assert spin_until(executor, future.done)
    return future.result().results[0]


@pytest.mark.parametrize("name", ["config_file", "map_file"])
def test_a_file_with_no_row_of_its_kind_is_refused_through_the_parameter_service(
    executor, make_node, world, tmp_path, name
):
    passwd = tmp_path / "passwd"
    passwd.write_text(NOT_A_CONFIG)
    before = world.get_parameter(name).value
    result = set_parameter(executor, make_node, world, name, str(passwd))
    assert not result.successful
    assert "none of its 2 rows" in result.reason and "is it the right file?" in result.reason
    assert str(passwd) in result.reason
    assert world.get_parameter(name).value == before  # the node keeps what it uses


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("config_file", "wall 0 0.01\ngps 0 1\n"),
        ("map_file", "wall 3 -1 3 1\ndoor 1 2 3 4\n"),
    ],
)
def test_skipped_rows_are_logged_on_rosout_by_the_node_not_printed_as_python_warnings(
    executor, make_node, world, tmp_path, name, text
):
    probe = make_node("rosout_probe")
    logged: list[Log] = []
    probe.create_subscription(Log, "/rosout", logged.append, ROSOUT_QOS)
    path = tmp_path / "partly_good.txt"
    path.write_text(text)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = set_parameter(executor, make_node, world, name, str(path))
    assert result.successful, result.reason
    assert not [w for w in caught if "unrecognized row" in str(w.message)]

    def skipped_row_logged() -> bool:
        return any("partly_good.txt:2: unrecognized row" in m.msg and m.name == "files_world" for m in logged)

    assert spin_until(executor, skipped_row_logged)
    (line,) = [m for m in logged if "unrecognized row" in m.msg]
    assert line.level == Log.WARN


@pytest.mark.parametrize("pose", [[1e308, 0.0, 0.0], [0.0, -2e6, 0.0], [0.0, 0.0, 1e300]])
def test_an_initial_pose_beyond_the_maps_bound_is_refused_with_the_bound(ros, pose):
    from sim_runtime.errors import InputError

    with pytest.raises(InputError, match=r"'initial_pose'.*±1e\+06"):
        CreateWorldNode(parameter_overrides=[Parameter("map_file", value=""), Parameter("initial_pose", value=pose)])
