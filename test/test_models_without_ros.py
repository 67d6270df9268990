"""The pure models and their tests need no ROS: a notebook or a CI without rclpy can use them."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PURE_TESTS = [
    "test/test_create_files.py",
    "test/test_create_model.py",
    "test/test_simrobot_world_file.py",
    "test/test_simrobot_model.py",
    "test/test_simrobot_raycast.py",
    "test/test_arm_model.py",
]
# rclpy made unimportable, as on a machine without ROS
NO_ROS = "import sys; sys.modules['rclpy'] = None; import pytest; sys.exit(pytest.main(sys.argv[1:]))"


def test_the_model_tests_collect_and_the_file_tests_pass_without_rclpy():
    collected = subprocess.run(
        [sys.executable, "-c", NO_ROS, "-q", "--co", "-p", "no:cacheprovider", *PURE_TESTS],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert collected.returncode == 0, collected.stdout[-3000:] + collected.stderr[-3000:]
    ran = subprocess.run(
        [sys.executable, "-c", NO_ROS, "-q", "-p", "no:cacheprovider", "test/test_create_files.py"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert ran.returncode == 0 and " passed" in ran.stdout, ran.stdout[-3000:] + ran.stderr[-3000:]
