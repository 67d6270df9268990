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


def _base_domain() -> int:
    """The caller's ROS domain (its ROS_DOMAIN_ID), else one from the run's process id (1-100).
    Kept in ROBOT_SIMS_TEST_DOMAIN, which pytest-xdist's workers inherit from the controller, so
    every worker derives its own domain from the same base."""
    base = os.environ.get("ROBOT_SIMS_TEST_DOMAIN") or os.environ.get("ROS_DOMAIN_ID")
    if not base:
        # a worker whose controller set nothing (not loaded there): the controller is its parent
        pid = os.getppid() if os.environ.get("PYTEST_XDIST_WORKER") else os.getpid()
        base = str(1 + pid % 100)
    os.environ["ROBOT_SIMS_TEST_DOMAIN"] = base
    return int(base)


def _suite_domain() -> int:
    """This process's ROS domain: the base one, or under pytest-xdist the base plus the worker's
    number (gw0, gw1, ...), wrapped into 1-100, so workers never share one even where the caller's
    environment sets ROS_DOMAIN_ID. The studio modules' domains
    (`studio_browser_support.studio_domain`, 101-201) lie above these and follow the base."""
    base = _base_domain()
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if not worker.startswith("gw"):
        return base
    return 1 + (base - 1 + int(worker[2:])) % 100


os.environ["ROS_DOMAIN_ID"] = str(_suite_domain())
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))
os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)

_names = itertools.count()


@pytest.fixture(autouse=True)
def _one_ray_cluster_at_a_time(request):
    """A test that starts Ray (its name has the word ``ray``) waits for any other worker's: two
    clusters starting at once on 2 busy cores time out in Ray's own start-up ("the GCS has
    become overloaded") before any of our code runs."""
    if "ray" not in request.node.originalname.split("_"):
        yield
        return
    import fcntl

    lock_dir = ROOT / "out"
    lock_dir.mkdir(exist_ok=True)
    with open(lock_dir / ".ray-tests.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        yield


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


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist's file-grouped scheduling (``--dist loadfile``, `make test`), a worker
    replaced after a crash (a hang's timeout ends its process) must not be given work before its
    collection has arrived: xdist 3.8 then stops the whole run with an INTERNALERROR (KeyError in
    ``LoadScopeScheduling._assign_work_unit``). It is given its share once its collection is in."""
    if not config.pluginmanager.hasplugin("xdist") or hasattr(config, "workerinput"):
        return
    from xdist.scheduler.loadscope import LoadScopeScheduling

    reschedule = LoadScopeScheduling._reschedule
    if getattr(reschedule, "waits_for_collection", False):
        return

    def reschedule_collected(self: LoadScopeScheduling, node) -> None:
        if node in self.registered_collections:
            reschedule(self, node)

    reschedule_collected.waits_for_collection = True  # type: ignore[attr-defined]
    LoadScopeScheduling._reschedule = reschedule_collected  # type: ignore[method-assign]
