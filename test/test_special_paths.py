"""Every input file kind, given a path no one can read as a file — a name too long, a path too long,
a NUL in the name, a FIFO, a directory, /dev/zero, a link to it, a link loop — refuses it with an
InputError naming the file (and the field it came from) at once: no OSError, no hang on the FIFO,
no endless read."""

from __future__ import annotations

import os
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

from arm_sim.arm import Arm
from arm_sim.robot_config import load_robot_config
from arm_sim.scene import load_scene
from arm_sim.stl import load_stl
from arm_sim.trajectory_file import load_trajectory
from create_sim.configfile import load_config
from create_sim.mapfile import load_map
from sim_runtime.bag.reader import open_bag
from sim_runtime.bag.writer import BagWriter
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path, resolve_input_file
from sim_tools.batch.sweep import load_sweep
from sim_tools.cli import executable_command
from sim_tools.fuzz.targets import SPECIAL_PATHS, special_path
from simrobot_sim.world_file import load_bitmap, load_world

ROOT = Path(__file__).resolve().parent.parent
QUICKLY_S = 10.0  # each takes milliseconds; the margin is for a loaded machine

LOADERS: dict[str, Callable[[Path], object]] = {
    "map": load_map,
    "config": load_config,
    "world": load_world,
    "bitmap": load_bitmap,
    "robot_config": load_robot_config,
    "scene": load_scene,
    "stl": load_stl,
    "trajectory": load_trajectory,
    "bag": open_bag,
    "sweep": load_sweep,
    "parameter": lambda path: resolve_input_file(str(path), "map_file"),
}


def quickly(call: Callable[[], object]) -> object:
    """What ``call()`` returns (or raises) within QUICKLY_S; it runs in a thread, so a reader stuck on
    a FIFO or reading /dev/zero fails the test instead of hanging it."""
    outcome: list[tuple[object, BaseException | None]] = []

    def run() -> None:
        try:
            outcome.append((call(), None))
        except BaseException as error:  # raised again in the test's thread
            outcome.append((None, error))

    start = time.monotonic()
    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(QUICKLY_S)
    assert outcome, f"still running after {time.monotonic() - start:.1f} s"
    value, error = outcome[0]
    if error is not None:
        raise error
    return value


def refusal(call: Callable[[], object]) -> InputError:
    """The InputError ``call()`` raises within QUICKLY_S."""
    with pytest.raises(InputError) as info:
        quickly(call)
    return info.value


@pytest.mark.parametrize("kind", SPECIAL_PATHS)
@pytest.mark.parametrize("loader", list(LOADERS))
def test_each_file_kind_refuses_each_special_path_with_an_input_error_at_once(tmp_path, loader, kind):
    path = special_path(kind, tmp_path, ".x")
    error = refusal(lambda: LOADERS[loader](path))
    assert len(str(error)) < 600  # a 6,000-character path is shortened in the message
    assert str(error).count("\n") == 0


def test_a_special_path_error_says_what_the_path_is(tmp_path):
    assert "FIFO" in str(refusal(lambda: load_map(special_path("fifo", tmp_path))))
    assert "character device" in str(refusal(lambda: load_config(Path("/dev/zero"))))
    assert "directory" in str(refusal(lambda: load_world(tmp_path)))
    assert "File name too long" in str(refusal(lambda: load_stl(special_path("long_name", tmp_path))))
    assert "NUL" in str(refusal(lambda: load_bitmap(special_path("nul_name", tmp_path))))


def write_yaml(path: Path, tree: object) -> Path:
    path.write_text(yaml.safe_dump(tree), encoding="utf-8")
    return path


@pytest.mark.parametrize("kind", SPECIAL_PATHS)
def test_a_world_files_map_field_naming_a_special_path_is_refused_naming_the_field(tmp_path, kind):
    special = special_path(kind, tmp_path, ".png")
    world = write_yaml(tmp_path / "w.yaml", {"map": str(special), "robots": [{"name": "r", "position": [0, 0]}]})
    assert f"{world}: map: " in str(refusal(lambda: load_world(world)))


@pytest.mark.parametrize("kind", SPECIAL_PATHS)
def test_a_scenes_mesh_and_arm_config_naming_a_special_path_are_refused_naming_the_field(tmp_path, kind):
    special = special_path(kind, tmp_path, ".stl")
    scene = write_yaml(tmp_path / "s.yaml", {"objects": [{"name": "box", "mesh": str(special)}]})
    assert "objects[0].mesh: " in str(refusal(lambda: load_scene(scene)))
    write_yaml(scene, {"arms": [{"name": "a", "config": str(special)}]})
    assert "arms[0].config: " in str(refusal(lambda: load_scene(scene)))


@pytest.mark.parametrize("kind", SPECIAL_PATHS)
def test_a_robot_configs_mesh_naming_a_special_path_is_refused_naming_the_field(tmp_path, kind):
    special = special_path(kind, tmp_path, ".stl")
    config = yaml.safe_load(config_path("arm/irb120.yaml").read_text())
    config["links"] = [{"link": 0, "elements": [{"mesh": str(special)}]}]
    path = write_yaml(tmp_path / "robot.yaml", config)
    assert "links[0].elements[0].mesh: " in str(refusal(lambda: Arm.from_file(path)))
    assert Arm.from_file(path, skip_missing_meshes=True).elements[0].placeholder


@pytest.mark.parametrize("kind", SPECIAL_PATHS)
def test_a_sweeps_map_naming_a_special_path_is_refused_naming_the_field(tmp_path, kind):
    special = special_path(kind, tmp_path, ".map")
    sweep = write_yaml(tmp_path / "sweep.yaml", {"worlds": [{"map": str(special)}], "duration_s": 1})
    assert "worlds[0].map" in str(refusal(lambda: load_sweep(sweep, out=str(tmp_path / "out"))))


@pytest.mark.parametrize("kind", ["fifo", "directory", "zero_link", "link_loop"])
def test_a_bag_holding_a_special_file_named_like_a_split_opens_without_it(tmp_path, kind):
    with BagWriter(tmp_path / "bag") as writer:
        writer.write(writer.add_topic("/t", "std_msgs/msg/String", ""), 1, b"\x00\x01\x00\x00\x01\x00\x00\x00\x00")
    special_path(kind, tmp_path / "bag", ".mcap")
    assert quickly(lambda: sum(1 for _ in open_bag(tmp_path / "bag").messages())) == 1


@pytest.mark.parametrize("executable", ["record", "bag_to_rerun"])
def test_an_output_name_the_system_refuses_is_one_error_line_and_exit_2(tmp_path, executable):
    with BagWriter(tmp_path / "bag") as writer:
        writer.write(writer.add_topic("/t", "std_msgs/msg/String", ""), 1, b"\x00\x01\x00\x00\x01\x00\x00\x00\x00")
    too_long = tmp_path / ("o" * 300)
    args = {"record": ["-o", str(too_long)], "bag_to_rerun": [str(tmp_path / "bag"), "-o", f"{too_long}.rrd"]}
    done = subprocess.run(
        executable_command(executable, args[executable]),
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith(f"{executable}: error: File name too long: ")
    assert "Traceback" not in done.stderr


def test_a_file_beyond_its_kinds_size_limit_is_refused_before_it_is_read(tmp_path):
    from sim_runtime.inputfile import read_input_bytes

    path = tmp_path / "big.stl"
    path.write_bytes(b"x" * 11)
    assert read_input_bytes(path, "STL file", limit=11) == b"x" * 11
    with pytest.raises(InputError, match=r"big\.stl: STL file is 11 bytes, more than the limit 10"):
        read_input_bytes(path, "STL file", limit=10)
