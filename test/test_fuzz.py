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


def _hostile_seeds(tmp_path):
    from sim_tools.fuzz.targets import Seeds, prepare_seeds

    prepare_seeds(tmp_path / "seeds")
    return Seeds.load(tmp_path / "seeds")


def test_alias_bombs_odd_line_ends_and_huge_inputs_are_refused_or_read_within_the_budget(tmp_path):
    import random

    from sim_tools.fuzz.budget import Budget, Meter
    from sim_tools.fuzz.campaign import outcome_of
    from sim_tools.fuzz.hostile import alias_bomb_case, huge_input_case, odd_text_case

    seeds = _hostile_seeds(tmp_path)
    outcomes: dict[str, set[str]] = {}
    for name, make, count in (("bombs", alias_bomb_case, 40), ("odd", odd_text_case, 40), ("huge", huge_input_case, 6)):
        for i in range(count):
            folder = tmp_path / f"{name}-{i}"
            folder.mkdir()
            case = make(random.Random(f"test/{name}/{i}"), seeds, folder)
            meter = Meter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a bombed bag's metadata is warned about, then skipped
                outcome = outcome_of(case.run, meter)
            assert meter.over(Budget()) is None, (name, case.note)
            outcomes.setdefault(name, set()).add(outcome)
            if name == "bombs" and not case.note.startswith("bag"):
                assert outcome == "input_error", case.note
    assert outcomes["odd"] >= {"ok"} and outcomes["huge"] >= {"ok", "input_error"}


def test_an_input_over_its_budget_is_a_defect_saved_with_its_cost(tmp_path):
    from sim_tools.fuzz.budget import Budget
    from sim_tools.fuzz.campaign import _run_input

    seeds = _hostile_seeds(tmp_path)
    out = tmp_path / "out"
    _index, name, outcome, signature = _run_input(0, 5, seeds, tmp_path / "case", out, Budget(cpu_seconds=0.0))
    assert outcome == "defect" and signature == f"{name}: over budget (CPU)"
    (saved,) = out.glob(f"defects/{name}-defect-0")
    assert "over the per-input budget" in (saved / "defect.txt").read_text()


def test_the_meter_sees_the_memory_and_cpu_an_input_takes():
    from sim_tools.fuzz.budget import Budget, Meter

    with Meter() as meter:
        block = bytearray(300 * 2**20)
        block[::4096] = b"x" * len(block[::4096])  # touched: resident
        total = sum(range(2_000_000))
    del block
    assert total > 0
    assert meter.memory_mb > 250
    assert meter.over(Budget(memory_mb=100)) is not None and "MB" in meter.over(Budget(memory_mb=100))
    assert meter.over(Budget(cpu_seconds=0.0, memory_mb=1e6)).endswith("CPU s > 0")
