"""The input fuzzer: a 2,000-input sample of every format finds no defect; crashes are caught."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from sim_runtime.fuzz.campaign import run_campaign
from sim_runtime.fuzz.targets import TARGETS


def test_two_thousand_mutated_inputs_of_every_format_load_or_raise_input_error(tmp_path):
    report = run_campaign(2000, seconds=600, workers=2, seed=20261123, out=tmp_path, progress=False)
    assert report.inputs == 2000, report.table()
    assert report.failures == 0, report.table()
    assert set(report.counts) == set(TARGETS), report.table()  # every format had its turn
    assert sum(c["ok"] for c in report.counts.values()) > 200, report.table()  # not only rejections


def test_a_worker_killed_by_a_segfault_is_counted_its_input_saved_and_the_campaign_goes_on(tmp_path):
    env = {**os.environ, "ROBOT_SIMS_FUZZ_SELFTEST": "1"}
    run = subprocess.run(
        [sys.executable, "-m", "sim_runtime.fuzz", "--inputs", "60", "--seconds", "120", "--out", str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    counts = summary["counts"]["selftest"]
    assert run.returncode == 1, run.stderr
    assert summary["inputs"] == 60 and sum(counts.values()) == 60
    assert counts["crash"] > 0 and counts["defect"] > 0 and counts["input_error"] > 0 and counts["ok"] > 0
    assert summary["restarts"] == counts["crash"]
    crashed = sorted(tmp_path.glob("defects/selftest-crash-*"))
    assert crashed and (crashed[0] / "number.txt").read_text() in {str(n) for n in range(0, 35, 7)}
    assert "selftest: crash" in run.stdout
