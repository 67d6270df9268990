"""A fourth simulator runs through `robot_sims batch` by its registry entry alone.

The toy simulator (``test/toy_sim``: a point robot on an empty plane) is added for the batch's
process and its workers with ``ROBOT_SIMS_SIMULATORS=toy=toy_sim.adapter``; nothing in sim_tools
names it."""

from __future__ import annotations

import math
import os
from pathlib import Path

from test_batch import ROOT, batch, rows, write_sweep

TOY = {
    "ROBOT_SIMS_SIMULATORS": "toy=toy_sim.adapter",
    "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "test")]),
}
START = "pose: [1.0, -0.5, 90*deg]\nmax_speed: 1.0\nmax_turn: 1.0\n"
USER_MODULE = '''
def straight(model, params, seed):
    """A model function: full speed ahead from the first step."""
    def control(model, t):
        model.command(params.get("speed", 0.4), 0.0)

    return control
'''


def test_a_toy_sweep_gives_ok_rows_with_its_own_metrics_from_its_registry_entry(tmp_path: Path) -> None:
    (tmp_path / "start.yaml").write_text(START, encoding="utf-8")
    (tmp_path / "toy_ctl.py").write_text(USER_MODULE, encoding="utf-8")
    sweep = write_sweep(
        tmp_path,
        "toy.yaml",
        """
        worlds: [{toy_start: start.yaml, name: plane}]
        controllers: [toy_circle, {name: circle_dds, use: toy_circle, transport: ros}, toy_ctl:straight]
        grid: {speed: [0.2, 0.4]}
        poses: {random: 2, seed: 5}
        duration_s: 2
        """,
    )
    done = batch(str(sweep), "--workers", "1", "--out", "out", "--no-plots", cwd=tmp_path, extra_env=TOY, timeout=120)
    assert done.returncode == 0, done.stderr
    table = rows(tmp_path / "out" / "episodes.csv")
    assert len(table) == 3 * 2 * 2 and {r["status"] for r in table} == {"ok"}, table
    assert {r["world"] for r in table} == {"plane"} and all(float(r["sim_time_s"]) == 2.0 for r in table)
    for r in table:
        speed = float(r["param.speed"])
        # the circle starts at the first odom (0.1 s), the model function at the first step
        assert 0.9 * speed * 1.9 <= float(r["distance_m"]) <= speed * 2.0 + 1e-9, r
        assert abs(float(r["pose_x"])) <= 2.0 and abs(float(r["pose_y"])) <= 2.0
    circle = [r for r in table if r["controller"] == "toy_circle"]
    assert all(math.isclose(float(r["turned_rad"]), 0.5 * 1.9, rel_tol=0.05) for r in circle), circle
    by_dds = {(r["param.speed"], r["pose_x"]): r["distance_m"] for r in table if r["controller"] == "circle_dds"}
    assert by_dds == {(r["param.speed"], r["pose_x"]): r["distance_m"] for r in circle}  # DDS = direct bus
    assert all(float(r["turned_rad"]) == 0.0 for r in table if r["controller"] == "toy_ctl:straight")


def test_a_toy_sweep_with_a_parameter_nobody_reads_is_one_error_naming_the_field(tmp_path: Path) -> None:
    (tmp_path / "start.yaml").write_text(START, encoding="utf-8")
    sweep = write_sweep(
        tmp_path,
        "toy.yaml",
        "worlds: [{toy_start: start.yaml}]\ncontrollers: [toy_circle]\ngrid: {speeed: [1]}\nduration_s: 1\n",
    )
    done = batch(str(sweep), cwd=tmp_path, extra_env=TOY, timeout=60)
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: {sweep}: field 'grid.speeed': 'speeed': no controller declares it")
    assert "the toy world has no such parameter" in done.stderr
