"""The fuzzer runs a simulator it has never heard of from its registry entry alone: the test-only
toy (``test/toy_sim``), registered by ``ROBOT_SIMS_SIMULATORS``, gets its own target's row."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from sim_runtime.errors import InputError
from sim_tools.fuzz.targets import target_table

TEST_DIR = Path(__file__).resolve().parent
ROOT = TEST_DIR.parent


def test_the_toy_simulators_start_file_is_fuzzed_from_its_registry_entry_alone(tmp_path):
    assert "toy_start" not in target_table()  # nothing in sim_tools names it
    path = os.pathsep.join([str(TEST_DIR), str(ROOT), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "ROBOT_SIMS_SIMULATORS": "toy=toy_sim.adapter", "PYTHONPATH": path}
    env.pop("ROBOT_SIMS_FUZZ_SELFTEST", None)
    options = ["--inputs", "150", "--seconds", "120", "--workers", "1", "--seed", "5", "--out", str(tmp_path)]
    run = subprocess.run(
        [sys.executable, "-m", "sim_tools.fuzz", *options], env=env, capture_output=True, text=True, timeout=300
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    toy = summary["counts"]["toy_start"]
    assert toy.get("ok", 0) > 0 and toy.get("input_error", 0) > 0, run.stdout  # mutations both load and fail
    assert sum(toy.values()) == toy.get("ok", 0) + toy.get("input_error", 0), run.stdout
    assert {"create_map", "simrobot_world", "arm_config", "bag_reader"} <= set(summary["counts"])  # beside the others
    assert sorted(p.name for p in (tmp_path / "seeds/toy/starts").iterdir()) == ["formula.yaml", "plain.yaml"]
    assert run.returncode == 0 and summary["inputs"] == 150, run.stdout + run.stderr


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("pose: [.nan, 0, 0]\nmax_speed: 1\nmax_turn: 1\n", "pose[0]"),
        ("pose: [0, 2e6, 0]\nmax_speed: 1\nmax_turn: 1\n", "pose[1]"),
        ("pose: [0, 0]\nmax_speed: 1\nmax_turn: 1\n", "pose"),
        ("pose: [0, 0, 0]\nmax_speed: 1e300\nmax_turn: 1\n", "max_speed"),
        ("pose: [0, 0, 0]\nmax_speed: 1\n", "max_turn"),
        ("pose: [0, 0, 0]\nmax_speed: 1\nmax_turn: 1\nspeed: 2\n", "speed"),
    ],
)
def test_a_bad_toy_start_file_is_refused_naming_the_file_and_field(tmp_path, text, field):
    from toy_sim.toy_file import load_start

    path = tmp_path / "start.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=rf"start\.yaml: .*{re.escape(field)}"):
        load_start(path)
