"""Installing the package puts executables and ament resources where ROS 2 tools look, and ships
numba's cache: the installed package's first start compiles nothing."""

import os
import shutil
import signal
import subprocess
import sys
import sysconfig
import threading
from pathlib import Path

import pytest

from sim_tools.executables import EXECUTABLES as DECLARED

ROOT = Path(__file__).resolve().parent.parent
EXECUTABLES = list(DECLARED)  # declared once, in sim_tools/executables.py
PACKAGES = ("sim_runtime", "create_sim", "simrobot_sim", "arm_sim", "sim_tools", "studio")
# The install's build runs the numba warm-up: seconds when this checkout's cache is warm (make
# venv), minutes of compiling for sources changed since, on a loaded machine.
pytestmark = [pytest.mark.timeout(3600), pytest.mark.long]  # minutes: `make test-long`


def copy_tree(dest: Path) -> Path:
    """This checkout's tracked files, as they are now, and the numba cache ``make venv`` warmed
    beside them (a developer's ``pip install .``): the build then loads the kernels instead of
    compiling them all again. Installing a copy keeps the build's files out of the checkout."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout.decode()
    cached = [p.relative_to(ROOT) for top in PACKAGES for p in (ROOT / top).rglob("__pycache__/*.nb[ic]")]
    for name in [*files.split("\0"), *map(str, cached)]:
        if name and (ROOT / name).is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, dest / name)
    return dest


@pytest.fixture(scope="module")
def prefix(tmp_path_factory):
    tree = copy_tree(tmp_path_factory.mktemp("tree"))
    prefix = tmp_path_factory.mktemp("prefix")
    env = {k: v for k, v in os.environ.items() if k not in ("ROBOT_SIMS_BUILD_WARMUP", "NUMBA_CACHE_DIR")}
    subprocess.run(
        # --ignore-installed: never uninstall the developer's editable install on the way.
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--ignore-installed",
            "--prefix",
            str(prefix),
            str(tree),
        ],
        check=True,
        timeout=3600,  # a cold build compiles every kernel: minutes on a loaded machine
        env=env,
    )
    return prefix


def site_packages(prefix: Path) -> Path:
    return Path(sysconfig.get_path("purelib", vars={"base": str(prefix), "platbase": str(prefix)}))


def test_ros2_run_finds_every_executable(prefix):
    for name in EXECUTABLES:
        wrapper = prefix / "lib" / "robot_sims" / name
        assert wrapper.is_file(), name
        assert os.access(wrapper, os.X_OK), name
        assert f'run("{name}"' in wrapper.read_text()


def test_ament_index_and_share_files_are_installed(prefix):
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "robot_sims").is_file()
    assert "<name>robot_sims</name>" in (prefix / "share" / "robot_sims" / "package.xml").read_text()
    assert (prefix / "share" / "robot_sims" / "config" / "fastdds_localhost.xml").is_file()


def test_the_matlab_toolbox_is_installed_beside_config(prefix):
    # `robot_sims matlab_path` finds it there: share/robot_sims/config/../matlab/create
    installed = prefix / "share" / "robot_sims" / "matlab" / "create" / "CreateRobot.m"
    assert installed.read_text() == (ROOT / "matlab" / "create" / "CreateRobot.m").read_text()


def test_umbrella_command_lists_the_executables():
    out = subprocess.run(
        [sys.executable, "-c", "import sys; from sim_tools import cli; sys.argv=['rs', '--help']; cli.main()"],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout
    for name in EXECUTABLES:
        assert name in out
    bad = subprocess.run(
        [sys.executable, "-c", "import sys; from sim_tools.cli import run; sys.exit(run('no_such_exe', []))"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert bad.returncode == 2 and "unknown executable 'no_such_exe'" in bad.stderr


@pytest.mark.parametrize(
    ("name", "args"),
    [
        ("create_world", ["-r", "__ns:=/installed_create"]),
        ("simrobot_world", ["-p", "world_file:=simrobot/demo.yaml", "-r", "__ns:=/installed_simrobot"]),
        ("arm", ["-r", "__ns:=/installed_arm"]),
    ],
)
def test_a_worlds_first_start_from_a_fresh_prefix_loads_every_kernel_from_the_shipped_cache(prefix, name, args):
    site = site_packages(prefix)
    assert list(site.glob("arm_sim/__pycache__/*.nbi")), "the install shipped no numba cache"
    world = subprocess.Popen(
        [sys.executable, str(prefix / "bin" / "robot_sims"), name, "--ros-args", *args],
        cwd=prefix,
        # the prefix ahead of the venv's editable install; numba says what it loads and saves
        env=dict(
            os.environ,
            PYTHONPATH=str(site),
            AMENT_PREFIX_PATH=os.pathsep.join([str(prefix), os.environ.get("AMENT_PREFIX_PATH", "")]),
            NUMBA_DEBUG_CACHE="1",
            PYTHONUNBUFFERED="1",  # numba's lines in order with the log's
        ),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    log: list[str] = []
    ready = threading.Event()

    def read() -> None:
        assert world.stdout is not None
        for line in world.stdout:
            log.append(line)
            if "ready:" in line:
                ready.set()
        ready.set()  # the world ended

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        ready.wait(timeout=600)  # a generous ceiling: seconds when the cache is there
    finally:
        world.send_signal(signal.SIGINT)
        try:
            world.wait(timeout=60)  # the reader drains its output
        except subprocess.TimeoutExpired:
            world.kill()
            world.wait()
        reader.join(timeout=30)
    out = "".join(log)
    assert "ready:" in out, out[-3000:]
    loaded = [line for line in log if "data loaded from" in line]
    assert loaded and all(str(site) in line for line in loaded), out[-3000:]  # the prefix's own cache
    compiled = [line for line in log if "data saved to" in line]
    assert compiled == [], f"{name}'s first start compiled kernels the install did not ship: {compiled}"
