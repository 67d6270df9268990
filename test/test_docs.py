"""The documentation tells the truth: its examples run, its parameter tables match the nodes."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from rclpy.parameter import Parameter

ROOT = Path(__file__).resolve().parent.parent
SKIP_MARK = "<!-- needs a running world"


def python_blocks(path: Path) -> list[str]:
    """Every ```python block of a Markdown file, except those marked as needing a running world."""
    text = path.read_text()
    blocks = []
    for match in re.finditer(r"(<!--[^\n]*-->\n)?```python\n(.*?)```", text, re.S):
        if not (match.group(1) or "").startswith(SKIP_MARK):
            blocks.append(match.group(2))
    return blocks


PACKAGES = ("create_sim", "simrobot_sim", "arm_sim", "sim_runtime", "studio")
EXAMPLE_MODULES = sorted(
    ".".join(path.relative_to(ROOT).with_suffix("").parts)
    for package in PACKAGES
    for path in (ROOT / package).rglob("*.py")
    if ">>> " in path.read_text()
)


@pytest.mark.parametrize("module", EXAMPLE_MODULES)
def test_the_docstring_examples_of_each_module_run(module):
    import doctest
    import importlib

    failed, attempted = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0


def test_the_readmes_python_examples_run():
    blocks = python_blocks(ROOT / "README.md")
    assert blocks
    for block in blocks:
        result = subprocess.run([sys.executable, "-c", block], cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, f"README example failed:\n{block}\n{result.stderr}"


def test_the_controller_test_in_the_docs_passes_as_written(tmp_path):
    block = next(b for b in python_blocks(ROOT / "docs/controllers.md") if "def test_" in b)
    test_file = tmp_path / "test_my_controller.py"
    test_file.write_text(block)
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test_file)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env={**__import__("os").environ, "PYTHONPATH": str(ROOT)},
    )
    assert result.returncode == 0, result.stdout + result.stderr


def _declared(node) -> set[str]:
    rclpys_own = {"use_sim_time", "start_type_description_service"}
    return {n for n in node._parameters if n not in rclpys_own and not n.startswith("qos_overrides")}


@pytest.mark.parametrize(
    "executable", ["create_world", "simrobot_world", "simrobot_avoid", "create_bump_turn", "create_teleop", "arm"]
)
def test_every_parameter_a_node_declares_is_in_its_docs_table(ros, executable, tmp_path):
    import numpy as np

    from arm_sim.arm_node import ArmNode
    from create_sim.bump_turn import BumpTurnNode
    from create_sim.teleop import TeleopNode
    from create_sim.world_node import CreateWorldNode
    from simrobot_sim.avoid import AvoidNode
    from simrobot_sim.world_file import RobotSpec, WorldSpec
    from simrobot_sim.world_node import SimrobotWorldNode

    make = {
        "create_world": lambda: CreateWorldNode(parameter_overrides=[Parameter("map_file", value="")]),
        "simrobot_world": lambda: SimrobotWorldNode(
            WorldSpec(walls=np.zeros((10, 10), dtype=bool), robots=(RobotSpec("r", (0.05, 0.05)),))
        ),
        "simrobot_avoid": AvoidNode,
        "create_bump_turn": BumpTurnNode,
        "create_teleop": TeleopNode,
        "arm": ArmNode,
    }[executable]
    node = make()
    try:
        text = (ROOT / "docs/executables.md").read_text()
        section = text.split(f"### `{executable}`", 1)[1].split("\n### ", 1)[0]
        documented = set(re.findall(r"`([a-z_.]+)`", section))
        missing = sorted(_declared(node) - documented)
        assert not missing, f"docs/executables.md, {executable}: parameters not documented: {missing}"
    finally:
        node.destroy_node()


def _qos_text(profile) -> str:
    """A QoS profile as the docs' tables write it: "reliable, volatile, depth 100"."""
    reliability = profile.reliability.name.lower().replace("_", " ")
    durability = profile.durability.name.lower().replace("_", " ")
    return f"{reliability}, {durability}, depth {profile.depth}"


def test_the_qos_column_of_the_arm_topics_table_is_what_the_arm_node_uses(ros):
    from arm_sim.arm_node import ArmNode

    rows = re.findall(r"^\| `([a-z_]+)` \| [^|]+ \| (in|out) \| ([^|]+) \|", (ROOT / "docs/arm.md").read_text(), re.M)
    assert len(rows) >= 7
    node = ArmNode()
    try:
        used = {p.topic_name.lstrip("/"): _qos_text(p.qos_profile) for p in node.publishers}
        used |= {s.topic_name.lstrip("/"): _qos_text(s.qos_profile) for s in node.subscriptions}
        wrong = {topic: (doc.strip(), used.get(topic)) for topic, _dir, doc in rows if used.get(topic) != doc.strip()}
        assert not wrong, f"docs/arm.md says (doc, node): {wrong}"
    finally:
        node.destroy_node()
