"""Launch-free test harness: rclpy once per session, one fresh executor per test.

DDS traffic must stay on this machine, and parallel runs must not see each other, so the
environment is fixed here before rclpy loads. rclpy is imported only by the fixtures that need it:
the pure-model tests run where ROS is not installed.
"""

from __future__ import annotations

import itertools
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def _suite_domain() -> int:
    """The run's ROS domain (1-100): from the process id, or under pytest-xdist from the
    controller's and the worker's number, so parallel workers never share one. The studio
    modules' domains (`studio_browser_support.studio_domain`, 101-201) lie above these."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")  # gw0, gw1, ...
    if not worker.startswith("gw"):
        return 1 + os.getpid() % 100
    # 37 apart: each worker's studio domains (an offset of 50-60 from its own) stay disjoint
    return 1 + (os.getppid() + 37 * int(worker[2:])) % 100


os.environ.setdefault("ROS_DOMAIN_ID", str(_suite_domain()))
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))
os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)

_names = itertools.count()


@pytest.fixture(scope="session")
def ros():
    """rclpy initialised once for the whole session."""
    import rclpy

    rclpy.init()
    yield
    rclpy.shutdown()


@pytest.fixture
def executor(ros):
    """A fresh executor; every node added to it is destroyed after the test."""
    from sim_runtime.run import make_executor

    ex = make_executor()
    yield ex
    for node in list(ex.get_nodes()):
        ex.remove_node(node)
        node.destroy_node()
    ex.shutdown()


@pytest.fixture
def make_node(executor):
    """Factory of plain nodes (unique names) already added to ``executor``."""

    from rclpy.node import Node

    def factory(name: str = "test_node", **kwargs) -> Node:
        node = Node(f"{name}_{next(_names)}", **kwargs)
        executor.add_node(node)
        return node

    return factory


@pytest.fixture(scope="session")
def tf2_msgs():
    """The installed tf2_msgs. A test using it is skipped only where the setup step turned TF off
    for want of a compiler or the Python headers (the one case where the package works without TF);
    anywhere else a missing tf2_msgs fails the test."""
    import importlib.util

    if importlib.util.find_spec("tf2_msgs") is None:
        spec = importlib.util.spec_from_file_location("build_interfaces", ROOT / "interfaces" / "build_interfaces.py")
        build = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(build)
        missing = build.missing_build_tools()
        if missing:
            pytest.skip(f"TF is off on this machine: {missing}")
    import tf2_msgs

    return tf2_msgs


@pytest.fixture(scope="module")
def studio_url(request, workspace):
    """``robot_sims studio`` on the module's ``workspace`` fixture, in the module's ``STUDIO_DOMAIN``
    (each studio browser-test module has a domain of its own); yields its URL."""
    from studio_browser_support import running_studio

    with running_studio(workspace, request.module.STUDIO_DOMAIN) as url:
        yield url


@pytest.fixture(scope="module")
def browser(request, studio_url):
    """Debian's Chromium (headless, the module's ``WINDOW_SIZE`` if it has one) for ``studio_url``."""
    from studio_browser_support import new_browser

    with new_browser(getattr(request.module, "WINDOW_SIZE", "1400,1600")) as driver:
        yield driver
