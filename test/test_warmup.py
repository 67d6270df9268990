"""After the setup step's numba warm-up, a world's first start compiles nothing: a user's first
``robot_sims create_world`` (or simrobot_world, arm) starts in seconds, not after a minute of
compiling; and the warm-up caches every kernel of the packages (but those it names as not needed)."""

from __future__ import annotations

import importlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState, LaserScan

from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until
from sim_tools.cli import executable_command
from sim_tools.warmup import NOT_WARMED

ROOT = Path(__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
PACKAGES = ("sim_runtime", "create_sim", "simrobot_sim", "arm_sim", "sim_tools", "studio")


@pytest.fixture(scope="module")
def warmed_up():
    """``python -m sim_tools.warmup`` as ``make venv`` runs it (fast when the cache is warm already)."""
    done = subprocess.run(
        [sys.executable, "-m", "sim_tools.warmup"], cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=900
    )
    assert done.returncode == 0, done.stderr
    assert "failed" not in done.stdout, done.stdout  # every simulator warmed without error
    assert done.stdout.startswith("numba kernels compiled and cached"), done.stdout
    return done.stdout


@pytest.mark.parametrize(
    ("name", "args", "topic", "msg_type"),
    [
        ("create_world", ["-r", "__ns:=/warm_create"], "/warm_create/scan", LaserScan),
        (
            "simrobot_world",
            ["-p", f"world_file:={ROOT / 'config/simrobot/demo.yaml'}"],  # real time: one step a second
            "/r1/odom",
            Odometry,
        ),
        ("arm", ["-r", "__ns:=/warm_arm"], "/warm_arm/joint_states", JointState),
    ],
)
def test_after_the_warm_up_a_worlds_first_start_compiles_no_kernel(
    name, args, topic, msg_type, warmed_up, executor, make_node
):
    received = Collector(make_node("warm_probe"), msg_type, topic, SENSOR_SUBSCRIBER_QOS)
    world = subprocess.Popen(
        executable_command(name, ["--ros-args", *args]),
        cwd=ROOT,
        env=dict(ENV, NUMBA_DEBUG_CACHE="1"),  # numba reports each kernel it loads or compiles+saves
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert spin_until(executor, lambda: received.msgs or world.poll() is not None, timeout=120)
        assert received.msgs, world.communicate()[1]
    finally:
        world.send_signal(signal.SIGINT)
        out, _err = world.communicate(timeout=60)
    assert "data loaded from" in out  # the kernels came from the cache...
    compiled = [line for line in out.splitlines() if "data saved to" in line]
    assert compiled == [], f"{name} compiled kernels the warm-up missed: {compiled}"  # ...none compiled


def kernels_of_packages() -> dict[str, object]:
    """Every numba kernel of our packages, by its full name."""
    from numba.core.registry import CPUDispatcher

    kernels = {}
    for top in PACKAGES:
        for path in sorted((ROOT / top).rglob("*.py")):
            if b"njit" not in path.read_bytes():
                continue
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            for attribute, value in vars(importlib.import_module(name)).items():
                if isinstance(value, CPUDispatcher) and value.__module__ == name:
                    kernels[f"{name}.{attribute}"] = value
    return kernels


def covered(kernels: dict[str, object]) -> set[str]:
    """The kernels whose machine code the cache holds: those with an entry of this numba version
    and these sources (numba's own check when it loads one), and every kernel such a kernel calls
    (compiled into its entry, so never compiled on its own), and theirs."""
    from numba.core.caching import FunctionCache

    done = {
        name
        for name, k in kernels.items()
        if isinstance(k._cache, FunctionCache) and k._cache._cache_file._load_index()
    }
    by_short_name: dict[str, list[str]] = {}
    for name in kernels:
        by_short_name.setdefault(name.rpartition(".")[2], []).append(name)
    todo = list(done)
    while todo:
        for called in kernels[todo.pop()].py_func.__code__.co_names:  # globals and attributes it names
            for name in by_short_name.get(called, []):
                if name not in done:
                    done.add(name)
                    todo.append(name)
    return done


def test_the_warm_up_caches_every_kernel_of_the_packages(warmed_up):
    from numba.core.caching import FunctionCache

    kernels = kernels_of_packages()
    # cached on disk, not inlined into their callers
    cached = {
        name
        for name, k in kernels.items()
        if isinstance(k._cache, FunctionCache) and k.targetoptions.get("inline") != "always"
    }
    assert len(cached) >= 60  # the scan found the packages' kernels
    assert set(NOT_WARMED) <= cached  # each exception names a kernel that exists
    missing = sorted(cached - covered(kernels) - set(NOT_WARMED))
    assert missing == [], f"no warm-up compiles {missing}: a first start would"
