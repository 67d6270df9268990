"""``bag_to_mat``: a recorded run as a .mat file that MATLAB/Octave scripts load."""

from __future__ import annotations

import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rerun_test_helpers import Raw, stamp, write_bag
from sensor_msgs.msg import JointState, LaserScan
from std_msgs.msg import Bool, String

from sim_runtime.errors import InputError
from sim_runtime.msgs import quaternion_from_yaw
from sim_tools.matlab.bag_to_mat import bag_to_mat, mat_name

STEPS = 5


def odom(k: int) -> Odometry:
    msg = Odometry()
    msg.header.stamp = stamp(0.1 * k)
    msg.header.frame_id = "odom"
    msg.pose.pose.position.x = 0.5 * k
    msg.pose.pose.position.y = -0.25 * k
    msg.pose.pose.orientation = quaternion_from_yaw(0.3 * k)
    msg.twist.twist.linear.x = 0.2
    msg.twist.twist.angular.z = 0.1 * k
    return msg


def overhead(k: int) -> PoseStamped:
    msg = PoseStamped()
    msg.header.stamp = stamp(0.1 * k)
    msg.pose.position.x, msg.pose.position.y = 1.0 + k, 2.0
    msg.pose.orientation = quaternion_from_yaw(-0.5)
    return msg


def scan(k: int) -> LaserScan:
    msg = LaserScan()
    msg.header.stamp = stamp(0.1 * k)
    msg.angle_increment = 0.5
    msg.ranges = [1.0 + k, 2.0, math.inf]
    return msg


def joints(k: int) -> JointState:
    msg = JointState()
    msg.header.stamp = stamp(0.1 * k)
    msg.name = ["j1", "j2"]
    msg.position = [0.1 * k, -0.1 * k]
    return msg


@pytest.fixture
def bag(tmp_path):
    messages: list[tuple[str, object, float]] = []
    for k in range(STEPS):
        t = 100.0 + 0.1 * k  # recorded on the wall clock; stamped with sim time 0.1 k
        messages += [("/odom", odom(k), t), ("/overhead_pose", overhead(k), t), ("/r1/scan", scan(k), t)]
        messages += [("/arm/joint_states", joints(k), t), ("/r1/crashed", Bool(data=k == 3), t)]
    # The MATLAB bridge's calls, recorded between the poses: none while pose 1 and 3 were the
    # newest, one after pose 0, two after pose 2, one after pose 4.
    for text, t in CALLS:
        messages.append(("/matlab_calls", String(data=text), t))
    messages.sort(key=lambda m: m[2])
    messages.append(("/exotic", Raw("no_such_pkg/msg/Thing", b"\x00\x01\x00\x00"), 101.0))
    return write_bag(tmp_path / "run.mcap", messages)


CALLS = [
    ("travelDist(0.200,0.500)", 100.05),
    ("[0 0 0 0 0 0]= BumpsWheelDropsSensorsRoomba", 100.21),
    ("[]= ReadSonar", 100.22),
    ("[1.000 2.000 -0.500]]= OverheadLocalizationCreate", 100.45),
]


def test_a_bag_becomes_one_struct_per_topic_with_a_row_per_message(bag, capsys):
    from scipy.io import loadmat

    out = bag_to_mat(bag)
    assert out == bag.with_name("run.mat")
    assert "left out /exotic" in capsys.readouterr().err
    d = loadmat(out, simplify_cells=True)
    assert np.allclose(d["odom"]["t"], 0.1 * np.arange(STEPS))
    assert np.allclose(d["odom"]["t_recorded"], 100.0 + 0.1 * np.arange(STEPS))
    k = np.arange(STEPS)
    assert np.allclose(d["odom"]["x"], 0.5 * k) and np.allclose(d["odom"]["y"], -0.25 * k)
    assert np.allclose(d["odom"]["theta"], 0.3 * k) and np.allclose(d["odom"]["omega"], 0.1 * k)
    assert d["odom"]["type"] == "nav_msgs/msg/Odometry" and d["odom"]["header_frame_id"] == "odom"
    assert d["odom"]["pose_covariance"].shape == (STEPS, 36)
    assert d["r1_scan"]["ranges"].shape == (STEPS, 3) and d["r1_scan"]["ranges"][4, 0] == 5.0
    assert np.isinf(d["r1_scan"]["ranges"][0, 2])
    assert list(d["arm_joint_states"]["name"]) == ["j1", "j2"]
    assert np.allclose(d["arm_joint_states"]["position"][:, 1], -0.1 * np.arange(STEPS))
    assert d["r1_crashed"]["data"].tolist() == [0, 0, 0, 1, 0]
    assert "exotic" not in d
    assert [row[1] for row in d["topics"]] == [
        "/odom",
        "/overhead_pose",
        "/r1/scan",
        "/arm/joint_states",
        "/r1/crashed",
        "/matlab_calls",
    ]
    assert list(d["matlab_calls"]["data"]) == [text for text, _t in CALLS]  # a string per message
    # the original Create simulator's saved data: {time since start, x, y, angle, calls} per pose
    history = d["datahistory"]
    assert len(history) == STEPS and history[2][0] == pytest.approx(0.2) and history[2][1] == 3.0
    assert history[2][2] == 2.0 and history[2][3] == pytest.approx(-0.5)
    # as the original's: the calls made while that pose was the newest; [] none, a text, a cell of texts
    assert history[0][4] == "travelDist(0.200,0.500)"
    assert np.size(history[1][4]) == 0 and np.size(history[3][4]) == 0
    assert list(history[2][4]) == ["[0 0 0 0 0 0]= BumpsWheelDropsSensorsRoomba", "[]= ReadSonar"]
    assert history[4][4] == "[1.000 2.000 -0.500]]= OverheadLocalizationCreate"


def test_topic_names_become_unique_matlab_names():
    taken: set[str] = set()
    assert [mat_name(t, taken) for t in ("/odom", "/r1/odom", "r1_odom", "/2d/x-y", "/" + "a" * 70)] == [
        "odom",
        "r1_odom",
        "r1_odom_2",
        "t_2d_x_y",
        "a" * 63,
    ]


def test_unknown_topics_and_unwritable_outputs_are_clear_errors(bag, tmp_path):
    with pytest.raises(InputError, match="no topic /nope in the bag; it has /odom"):
        bag_to_mat(bag, topics=["/nope"])
    with pytest.raises(InputError, match=r"cannot write the \.mat file"):
        bag_to_mat(bag, tmp_path / "missing_folder" / "x.mat")


@pytest.mark.skipif(shutil.which("octave-cli") is None, reason="GNU Octave is not installed here; CI runs this")
def test_the_mat_file_loads_in_octave_with_the_same_numbers(bag, tmp_path):
    out = tmp_path / "x.mat"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "sim_tools.matlab.bag_to_mat",
            str(bag),
            "-o",
            str(out),
            "--topics",
            "/odom",
            "/overhead_pose",
            "/matlab_calls",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0 and f"wrote {out}" in done.stdout, done.stderr
    script = (
        f"d = load('{out}'); disp(size(d.odom.x)); printf('%.3f ', d.odom.x); printf('\\n');"
        "printf('%s\\n', class(d.datahistory)); printf('%.3f\\n', d.datahistory{3, 2}); disp(d.topics{2, 2});"
        "c = d.datahistory{3, 5}; printf('%s|%s|%d|%s\\n', class(c), c{2}, isempty(d.datahistory{2, 5}), "
        "d.datahistory{1, 5});"
    )
    octave = subprocess.run(["octave-cli", "--no-gui", "--eval", script], capture_output=True, text=True, timeout=60)
    assert octave.returncode == 0, octave.stderr
    lines = octave.stdout.split("\n")
    assert lines[0].split() == ["5", "1"]
    assert lines[1].split() == ["0.000", "0.500", "1.000", "1.500", "2.000"]
    assert lines[2:5] == ["cell", "3.000", "/overhead_pose"]
    # what the original's ReplayGUI shows: the call texts, several in a cell
    assert lines[5] == "cell|[]= ReadSonar|1|travelDist(0.200,0.500)"
