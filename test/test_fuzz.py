"""The input fuzzer: a 2,000-input sample of every format finds no defect; crashes are caught."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings

from sim_tools.fuzz.campaign import Campaign
from sim_tools.fuzz.targets import target_table


def test_two_thousand_mutated_inputs_of_every_format_load_or_raise_input_error(tmp_path):
    report = Campaign(2000, seconds=600, workers=2, seed=20261123, out=tmp_path, progress=False).run()
    assert report.inputs == 2000, report.table()
    assert report.failures == 0, report.table()
    if report.stalls:  # not the inputs' doing (they ended when run alone), but worth seeing in the log
        warnings.warn(f"fuzz sample: {report.table()}", stacklevel=1)
    assert set(report.counts) == set(target_table()), report.table()  # every format had its turn
    assert sum(c["ok"] for c in report.counts.values()) > 200, report.table()  # not only rejections


def test_a_worker_killed_by_a_segfault_or_a_hang_is_counted_its_input_saved_and_the_campaign_goes_on(tmp_path):
    env = {**os.environ, "ROBOT_SIMS_FUZZ_SELFTEST": "1"}
    options = ["--inputs", "40", "--seconds", "120", "--hang-seconds", "3", "--seed", "31", "--out", str(tmp_path)]
    options += ["--batch", "5", "--recycle-after", "10"]
    run = subprocess.run(
        [sys.executable, "-m", "sim_tools.fuzz", *options],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    counts = summary["counts"]["selftest"]
    assert run.returncode == 1, run.stderr
    assert summary["inputs"] == 40 and sum(counts.values()) == 40
    assert counts["crash"] > 0 and counts["defect"] > 0 and counts["input_error"] > 0 and counts["ok"] > 0
    assert "selftest: crash" in run.stdout
    crashed = sorted(tmp_path.glob("defects/selftest-crash-*"))
    assert crashed and (crashed[0] / "number.txt").read_text() in {str(n) for n in range(0, 35, 7)}
    # Seed 31 draws 33 (hangs wherever it runs) once and 34 (hangs only after other inputs) once;
    # each is run again alone in the fresh worker, where 33 hangs again (a second restart).
    assert counts["hang"] == 1 and counts["stall"] == 1
    assert summary["restarts"] == counts["crash"] + 2 * counts["hang"] + counts["stall"]
    (hung,) = tmp_path.glob("defects/selftest-hang-*")
    assert (hung / "number.txt").read_text() == "33"
    (stalled,) = tmp_path.glob("defects/selftest-stall-*")
    assert (stalled / "number.txt").read_text() == "34"
    for folder in (hung, stalled):  # the hung worker's stack, for a hang that may not replay
        assert "_selftest_hang" in (folder / "defect.txt").read_text()
    assert "STALL x1 selftest: stall" in run.stdout and summary["stalls"]
    assert summary["recycled"] >= 1  # a worker that ran 10 inputs was replaced, and nothing was lost
