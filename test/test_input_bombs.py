"""Hostile YAML: a 10-level alias bomb at any key of any YAML input is refused at once, shortly.

Every YAML the package reads (a SIMROBOT world, an arm config, an arm scene, a joint trajectory, a
batch sweep, a bag's metadata.yaml) goes through one reader, which bounds alias expansion before
any value is built; and every message shows a value cut short after formatting about that much.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from arm_sim.robot_config import load_robot_config
from arm_sim.scene import load_scene
from arm_sim.trajectory_file import load_trajectory
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_runtime.yamlfile import MAX_ALIAS_NODES, parse_yaml, short
from sim_tools.batch.sweep import load_sweep
from sim_tools.fuzz_kit.mutate import alias_bomb, bombed_yaml, yaml_paths
from simrobot_sim.world_file import load_world

MESSAGE_CHARS = 300


def _world_tree() -> dict:
    tree = yaml.safe_load(config_path("simrobot/demo.yaml").read_text())
    tree["map"] = str(config_path("simrobot") / tree["map"])
    return tree


def _arm_tree() -> dict:
    tree = yaml.safe_load(config_path("arm/irb120.yaml").read_text())
    tree["mesh_folder"] = str((config_path("arm") / tree.get("mesh_folder", ".")).resolve())
    return tree


def _scene_tree() -> dict:
    tree = yaml.safe_load(config_path("arm/workcell.yaml").read_text())
    for obj in tree.get("objects", []):
        obj["mesh"] = str(config_path("arm") / obj["mesh"])
    for arm in tree.get("arms", []):
        arm["config"] = str(config_path("arm") / arm["config"])
    return tree


_TRAJECTORY = {"joint_names": ["joint_1", "joint_2"], "points": [{"time": 1.0, "positions": [0, "30*deg"]}]}
_SWEEP = {
    "worlds": [{"map": str(config_path("create/example.map")), "config": ""}],
    "controllers": ["create_bump_turn"],
    "seeds": [0, 1],
    "duration_s": 5,
}

#: Each YAML input kind: (a good tree of it, its loader).
FORMATS = {
    "simrobot world": (_world_tree, load_world),
    "arm config": (_arm_tree, load_robot_config),
    "arm scene": (_scene_tree, load_scene),
    "joint trajectory": (lambda: _TRAJECTORY, load_trajectory),
    "sweep": (lambda: _SWEEP, lambda p: load_sweep(p, out=str(p.parent / "out"))),
}


def _bomb_paths(tree: dict) -> list[tuple]:
    """Every key of the tree (each list's first item only: the others are alike) and an unknown one."""
    paths = [p for p in yaml_paths(tree) if not any(isinstance(k, int) and k > 0 for k in p)]
    return [*paths, ("not_a_field",)]


@pytest.mark.parametrize("kind", sorted(FORMATS))
def test_an_alias_bomb_at_every_key_of_every_yaml_format_is_refused_with_a_short_message(tmp_path, kind):
    make_tree, load = FORMATS[kind]
    tree = make_tree()
    load_path = tmp_path / "good.yaml"
    load_path.write_text(yaml.safe_dump(tree))
    load(load_path)  # the seed itself is good: every refusal below is the bomb's
    paths = _bomb_paths(tree)
    assert len(paths) > 5
    for path in paths:
        file = tmp_path / "bomb.yaml"
        file.write_text(bombed_yaml(tree, path))
        with pytest.raises(InputError) as info:
            load(file)
        message = str(info.value)
        assert "alias" in message, (path, message)
        assert len(message) < MESSAGE_CHARS, (path, message)


def test_a_bomb_of_merge_keys_is_refused_like_one_of_lists():
    levels = ["a0: &a0 {x: 1, y: 2}"]
    levels += [f"a{k}: &a{k} {{<<: [{', '.join([f'*a{k - 1}'] * 10)}]}}" for k in range(1, 10)]
    with pytest.raises(InputError, match="alias"):
        parse_yaml("\n".join(levels), "merge.yaml")


def test_an_alias_inside_its_own_anchor_is_refused():
    with pytest.raises(InputError, match="refers to its own anchor"):
        parse_yaml("a: &a [1, *a]\n", "self.yaml")


def test_shared_defaults_below_the_bound_still_load():
    text = "d: &d {R: 0.01, la: 0.03}\nrobots: [" + ", ".join(["{<<: *d, name: r}"] * 50) + "]\n"
    data = parse_yaml(text, "defaults.yaml")
    assert len(data["robots"]) == 50 and data["robots"][49]["la"] == 0.03
    assert MAX_ALIAS_NODES >= 10_000


def test_a_bag_whose_metadata_is_an_alias_bomb_is_read_from_its_splits_with_a_short_warning(tmp_path):
    from sim_runtime.bag.reader import BagWarning, open_bag

    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: " + alias_bomb() + "\n")
    with pytest.warns(BagWarning, match="alias") as warned, pytest.raises(InputError) as info:
        open_bag(bag)

    def ours(text: str) -> str:  # the message without the file's path, which is the caller's length
        return text.replace(str(bag / "metadata.yaml"), "<file>").replace(str(bag), "<bag>")

    assert any("alias" in str(w.message) and len(ours(str(w.message))) < MESSAGE_CHARS for w in warned)
    assert len(ours(str(info.value))) < MESSAGE_CHARS


@pytest.mark.parametrize(
    "value",
    [
        "x" * 10_000_000,
        10**4000 if sys.get_int_max_str_digits() == 0 else 2**20000,
        [[list(range(1000))] * 1000] * 1000,
        {i: [i] * 100 for i in range(100_000)},
    ],
    ids=["long string", "huge integer", "shared lists", "big mapping"],
)
def test_a_value_shown_in_a_message_is_cut_short_whatever_its_size(value):
    assert len(short(value)) <= 60


def test_a_self_containing_list_is_shown_without_recursing():
    loop: list = [1]
    loop.append(loop)
    assert short(loop).startswith("[1, [1, ")


def test_an_arm_config_name_that_is_not_text_is_refused(tmp_path):
    tree = _arm_tree()
    tree["name"] = [1, 2, 3]
    path = tmp_path / "arm.yaml"
    path.write_text(yaml.safe_dump(tree))
    with pytest.raises(InputError, match=r"arm\.yaml: name: expected text"):
        load_robot_config(path)


def test_a_simrobot_world_bomb_through_the_executable_ends_at_once_with_a_short_error(tmp_path):
    tree = _world_tree()
    world = tmp_path / "bomb.yaml"
    world.write_text(bombed_yaml(tree, ("robots", 0, "color")))
    exe = Path(sys.executable).with_name("robot_sims")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    result = subprocess.run(
        [str(exe), "simrobot_world", "--ros-args", "-p", f"world_file:={world}"],
        capture_output=True,
        timeout=120,  # a ceiling on a busy machine; the bomb is refused while parsing
        env=env,
    )
    assert result.returncode != 0
    assert b"alias" in result.stderr + result.stdout
    assert len(result.stderr) + len(result.stdout) < 5000
