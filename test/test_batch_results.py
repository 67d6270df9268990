"""What `robot_sims batch` tells a teacher: the summary, the table's columns, NaN ("never
happened") counted and shown, plots faceted by every grid parameter with plain axes, and metric
options checked before anything runs. Pure tests on rows, and one short sweep as a user runs it."""

from __future__ import annotations

import io
import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from test_batch import batch

from sim_runtime.errors import InputError
from sim_tools.adapters.create.world import create_min_clearance_m
from sim_tools.batch import output
from sim_tools.batch.metrics import EpisodeData
from sim_tools.batch.row import Row, column_order
from sim_tools.batch.sweep import load_sweep

NAN = math.nan


def episode(index: int, status: str = "ok", controller: str = "ours", world: str = "map", **columns: Any) -> dict:
    """A row as an episode logs it: ids, ``param.*`` (``p_<name>=`` keywords), status, metrics."""
    row = Row(
        episode=index,
        key=f"k{index}",
        world=world,
        controller=controller,
        params={k[2:]: v for k, v in columns.items() if k.startswith("p_")},
        pose=None,
        seed=0,
        status="ok" if status == "ok" else "error",
        error="" if status == "ok" else "RuntimeError: boom",
        sim_time_s=20.0,
        metrics={k: v for k, v in columns.items() if not k.startswith("p_")} if status == "ok" else {},
    )
    return output.with_reached(row.columns())


def test_a_rows_columns_come_in_the_tables_order_ids_settings_outcome_metrics() -> None:
    row = Row(
        episode=3,
        key="k3",
        world="map",
        controller="ours",
        params={"speed": 0.2},
        pose=(1.0, -2.0, 0.5),
        seed=7,
        status="ok",
        sim_time_s=20.0,
        metrics={"distance_m": 4.0, "bumps": 2},
    )
    columns = row.columns()
    assert (
        list(columns)
        == column_order([columns])
        == [
            "episode",
            "key",
            "world",
            "controller",
            "param.speed",
            "pose_x",
            "pose_y",
            "pose_theta",
            "seed",
            "status",
            "error",
            "sim_time_s",
            "distance_m",
            "bumps",
        ]
    )
    assert columns["pose_y"] == -2.0 and columns["error"] == ""
    never_started = Row(**{**row.__dict__, "status": "error", "error": "boom", "sim_time_s": None, "metrics": {}})
    assert "sim_time_s" not in never_started.columns()  # no world, no sim time: the cell stays empty


def summary_text(rows: list[dict], grid_keys: list[str] | None = None) -> str:
    out = io.StringIO()
    output.summary(rows, grid_keys or [], out)
    return out.getvalue()


GOALS = [
    episode(0, distance_m=5.0, goal_time_s=12.5),
    episode(1, distance_m=4.0, goal_time_s=NAN),
    episode(2, distance_m=3.0, goal_time_s=NAN),
    episode(3, status="error"),
]


# ------------------------------------------------------------------------------ summary, table
def test_the_summary_says_how_many_reached_the_goal_and_averages_only_those() -> None:
    text = summary_text(GOALS)
    assert "4 episodes: 3 ok, 1 failed" in text
    assert "goal_time_s: reached 1/3 (33 %), mean of those 12.5 s" in text
    lines = text.splitlines()
    table = lines.index("mean per group (a time: over the episodes that reached it):")
    head, values = lines[table + 1].split(), lines[table + 2].split()
    assert dict(zip(head, values, strict=True)) == {
        "controller": "ours",
        "world": "map",
        "n": "3",
        "failed": "1",
        "distance_m": "4",
        "goal_reached": "1/3",
        "goal_time_s": "12.5",
    }


def test_a_group_where_nobody_reached_shows_zero_and_no_time() -> None:
    rows = [episode(0, goal_time_s=NAN), episode(1, goal_time_s=NAN)]
    text = summary_text(rows)
    assert "goal_time_s: reached 0/2 (0 %)" in text and "mean of those" not in text
    assert text.splitlines()[-2].split()[-2:] == ["0/2", "-"]


def test_each_group_of_the_summary_counts_its_failed_episodes() -> None:
    rows = [*GOALS, episode(4, status="error", controller="alice"), episode(5, status="error", controller="alice")]
    groups = {line.split()[0]: line.split() for line in summary_text(rows).splitlines() if line.endswith(("-", "12.5"))}
    assert groups["ours"][2:5] == ["3", "1", "4"]  # n ok, failed, mean distance
    assert groups["alice"][2:] == ["0", "2", "-", "0/0", "-"]  # every episode failed: no means


def test_a_nan_in_any_other_metric_is_counted_in_the_summary() -> None:
    rows = [episode(0, score=1.0), episode(1, score=NAN), episode(2, score=3.0)]
    assert "score: NaN in 1 of 3 episodes, left out of its mean" in summary_text(rows)


def test_the_table_has_a_reached_column_before_each_time_and_keeps_nan(tmp_path: Path) -> None:
    output.write_table(GOALS, tmp_path)
    table = pq.read_table(tmp_path / "episodes.parquet")
    names = table.column_names
    assert names.index("goal_reached") == names.index("goal_time_s") - 1
    assert str(table.schema.field("goal_reached").type) == "bool"
    assert table.column("goal_reached").to_pylist() == [True, False, False, None]  # None: failed episode
    times = table.column("goal_time_s").to_pylist()
    assert times[0] == 12.5 and math.isnan(times[1]) and math.isnan(times[2]) and times[3] is None
    csv_lines = (tmp_path / "episodes.csv").read_text().splitlines()
    assert csv_lines[2].endswith("false,nan")


def test_a_time_metric_of_a_user_named_like_ours_gets_its_reached_column_too() -> None:
    row = episode(0, dock_time_s=NAN, sim_time_s=3.0)
    assert row["dock_reached"] is False and "sim_reached" not in row


def test_min_clearance_is_zero_when_the_body_touched_a_wall_not_the_physics_gap() -> None:
    t = np.arange(3) * 0.01
    touched = EpisodeData(t, {"clearance": np.array([0.5, 1e-8, 0.3])})
    clear = EpisodeData(t, {"clearance": np.array([0.5, 0.2, 0.3])})
    assert create_min_clearance_m(touched) == 0.0 and create_min_clearance_m(clear) == 0.2


# -------------------------------------------------------------------------------------- plots
def grid_rows() -> list[dict]:
    """turn × speed × mode, two episodes each: distance = 10·speed + turn (+ 0.1 for mode b, + 0.01
    for the second episode), so that averaging any parameter away shows."""
    rows = []
    for turn in (0.0, 0.5, 1.0):
        for speed in (0.2, 0.4):
            for mode in ("a", "b"):
                for k in (0, 1):
                    value = 10 * speed + turn + (0.1 if mode == "b" else 0.0) + 0.01 * k
                    goal = 3.0 if turn == 0.0 and k == 0 else NAN
                    fields = {"distance_m": value, "goal_time_s": goal}
                    rows.append(episode(len(rows), p_turn=turn, p_speed=speed, p_mode=mode, **fields))
    return rows


@pytest.fixture
def close_figures():
    yield
    output._pyplot().close("all")


@pytest.mark.usefixtures("close_figures")
def test_a_plot_has_a_panel_per_value_of_the_second_grid_parameter_and_a_row_per_third() -> None:
    fig = output.figure(grid_rows(), ["turn", "speed", "mode"], "distance_m")
    axes = fig.axes
    assert len(axes) == 4
    assert [ax.get_title() for ax in axes] == [
        "speed = 0.2, mode = a",
        "speed = 0.4, mode = a",
        "speed = 0.2, mode = b",
        "speed = 0.4, mode = b",
    ]
    for ax, (speed, extra) in zip(axes, [(0.2, 0.0), (0.4, 0.0), (0.2, 0.1), (0.4, 0.1)], strict=True):
        (line,) = ax.lines
        assert list(line.get_xdata()) == [0.0, 0.5, 1.0]
        assert list(line.get_ydata()) == pytest.approx([10 * speed + t + extra + 0.005 for t in (0.0, 0.5, 1.0)])
    assert axes[2].get_xlabel() == "turn" and axes[0].get_ylabel() == "distance (m)"
    assert fig.get_suptitle() == "distance_m: 24 episodes"


@pytest.mark.usefixtures("close_figures")
def test_a_near_constant_metric_is_drawn_on_plain_ticks_without_an_offset() -> None:
    rows = [episode(k, min_clearance_m=1e-8 + k * 1e-16, bumps=3) for k in range(5)]
    for column in ("min_clearance_m", "bumps"):
        fig = output.figure(rows, [], column)
        fig.canvas.draw()
        (ax,) = fig.axes
        assert ax.yaxis.get_offset_text().get_text() == ""
        labels = [t.get_text() for t in ax.get_yticklabels()]
        assert labels and not any("e" in label.lower() for label in labels), labels
        bottom, top = ax.get_ylim()
        assert top - bottom >= output.MIN_SPAN and bottom >= 0  # a clearance axis never goes below 0
    assert all(float(t.replace("−", "-")).is_integer() for t in labels)  # bumps: whole ticks


@pytest.mark.usefixtures("close_figures")
def test_a_time_plot_says_how_many_reached_and_counts_each_grid_value() -> None:
    rows = grid_rows()
    fig = output.figure(rows, ["turn", "speed"], "goal_time_s")
    assert fig.get_suptitle() == "goal_time_s: 4 of 24 episodes reached (20 never: not drawn)"
    assert [ax.get_title() for ax in fig.axes] == ["speed = 0.2, 2 of 12 reached", "speed = 0.4, 2 of 12 reached"]
    counts = [t.get_text() for t in fig.axes[0].texts]
    assert counts == ["2/4", "0/4", "0/4"]  # turn 0.5 and 1.0: nobody reached, shown as such
    assert fig.axes[0].get_xlim()[1] > 1.0  # the axis spans every grid value, reached or not

    share = output.figure(rows, ["turn", "speed"], "goal_reached")
    (line,) = share.axes[0].lines
    assert list(line.get_ydata()) == [50.0, 0.0, 0.0]
    assert share.axes[0].get_ylabel() == "goal reached (% of episodes)"


@pytest.mark.usefixtures("close_figures")
def test_without_a_grid_each_controller_and_world_gets_a_box_with_its_reached_count() -> None:
    rows = [*GOALS, episode(4, controller="alice", distance_m=2.0, goal_time_s=7.0)]
    fig = output.figure(rows, [], "goal_time_s")
    ticks = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert ticks == ["ours\nmap\n1/3 reached", "alice\nmap\n1/1 reached"]
    assert fig.get_suptitle().endswith("; 1 failed (x at the foot)")
    assert output.plot_columns(rows) == ["distance_m", "goal_reached", "goal_time_s"]


def failing_class(students: int, broken: int) -> list[dict]:
    """A class's rows: every broken student's two episodes failed, each with a reason of its own."""
    rows = []
    for s in range(students):
        for seed in range(2):
            i = len(rows)
            if s < broken:
                row = episode(i, status="error", controller=f"student{s:02d}")
                row["error"] = f"ValueError: bug number {s} (at student{s:02d}.py:{10 + s}) [log: logs/k{i}.log]"
            else:
                row = episode(i, controller=f"student{s:02d}", distance_m=float(s + seed))
            rows.append(row)
    return rows


def test_summary_txt_lists_every_failure_with_its_reason_and_the_terminal_says_how_many_more(tmp_path: Path) -> None:
    rows = failing_class(30, 5)
    path = output.write_summary(rows, [], tmp_path)
    text = path.read_text()
    assert path == tmp_path / "summary.txt"
    assert text.startswith("60 episodes: 50 ok, 10 failed\n")
    for s in range(5):
        assert text.count(f"ValueError: bug number {s} (at student{s:02d}.py:{10 + s})") == 2
    terminal = io.StringIO()
    output.summary(rows, [], terminal, full=path)
    shown = terminal.getvalue()
    assert shown.count("ValueError: bug number") == 5
    assert f"... and 5 more failed episodes: every one in {path}" in shown


def test_summary_txt_gives_each_groups_spread_min_max_and_sd(tmp_path: Path) -> None:
    rows = [episode(i, distance_m=d) for i, d in enumerate([1.0, 2.0, 4.0])]
    text = output.write_summary(rows, [], tmp_path).read_text()
    spread = text[text.index("spread per group") :].splitlines()
    assert spread[1].split() == ["controller", "world", "metric", "n", "mean", "sd", "min", "max"]
    assert spread[2].split() == ["ours", "map", "distance_m", "3", "2.333", "1.528", "1", "4"]


def test_the_summary_says_which_controllers_a_grid_parameter_was_not_applied_to() -> None:
    rows = [episode(0, controller="alice", p_turn=0.5, distance_m=1.0), episode(1, distance_m=2.0)]
    out = io.StringIO()
    output.summary(rows, ["turn"], out, applies={"alice": ["turn"], "ours": []})
    assert "grid turn: swept for alice; not for ours (it does not declare it: run once" in out.getvalue()
    assert ["ours", "map", "-", "1", "2"] in [line.split() for line in out.getvalue().splitlines()]  # no value


@pytest.mark.usefixtures("close_figures")
def test_a_student_whose_every_episode_failed_is_a_cross_at_the_foot_with_the_reason_in_the_legend() -> None:
    rows = failing_class(3, 1)
    fig = output.figure(rows, [], "distance_m")
    ax = fig.axes[0]
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert ticks == ["student00\nmap", "student01\nmap", "student02\nmap"]  # the broken one keeps its place
    (legend,) = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == "student00 / map: 2 failed: ValueError: bug number 0 (at student00.py:10)"
    crosses = [c for c in ax.collections if c.get_label() == legend]
    assert len(crosses[0].get_offsets()) == 2
    assert all(0.5 <= x <= 1.5 for x, _ in crosses[0].get_offsets())  # under the first box


@pytest.mark.usefixtures("close_figures")
def test_against_a_grid_failures_are_crosses_at_their_value_and_an_unswept_controller_a_dashed_line() -> None:
    rows = [
        episode(0, controller="alice", p_turn=0.5, distance_m=1.0),
        episode(1, controller="alice", p_turn=1.5, distance_m=3.0),
        episode(2, status="error", controller="bob", p_turn=1.5),
        episode(3, controller="ours", distance_m=2.0),
    ]
    ax = output.figure(rows, ["turn"], "distance_m").axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "ours / map (not swept over turn)" in labels
    assert "bob / map: 1 failed: RuntimeError: boom" in labels
    (cross,) = [c for c in ax.collections if c.get_label().startswith("bob")]
    assert [x for x, _ in cross.get_offsets()] == [1.5]
    dashed = [line for line in ax.lines if line.get_label().startswith("ours")]
    assert list(dashed[0].get_ydata()) == [2.0, 2.0]


def test_plots_writes_a_png_per_column(tmp_path: Path) -> None:
    written = output.plots(grid_rows(), ["turn", "speed", "mode"], tmp_path)
    assert [p.name for p in written] == ["distance_m.png", "goal_reached.png", "goal_time_s.png"]
    assert all(p.stat().st_size > 10_000 for p in written)


@pytest.mark.parametrize(
    ("name", "label"),
    [("area_covered_m2", "area covered (m²)"), ("goal_time_s", "goal time (s)"), ("bumps", "bumps")],
)
def test_axis_labels_carry_the_unit_of_the_column_name(name: str, label: str) -> None:
    assert output._axis_label(name) == label


# ------------------------------------------------------------------------------ metric options
USER_METRICS = """
def reach(data, center: list[float], within_m: float = 0.5):
    return 0.0


def anything(data, **options):
    return 0.0
"""


@pytest.mark.parametrize(
    ("metric", "field", "message"),
    [
        (
            "{goal_time_s: {centre: [2, 0]}}",
            "goal_time_s.centre",
            "unknown option of goal_time_s (it takes: center, radius_m)",
        ),
        ("{goal_time_s: {radius_m: 0.3}}", "goal_time_s.center", "missing: goal_time_s needs it"),
        ("{goal_time_s: {center: 2}}", "goal_time_s.center", "2: expected [x, y] in metres"),
        ("{goal_time_s: {center: [1, 2, 3]}}", "goal_time_s.center", "[1, 2, 3]: expected [x, y] in metres"),
        ("{goal_time_s: {center: [1, 2], radius_m: big}}", "goal_time_s.radius_m", "'big': expected a radius > 0 m"),
        ("{area_covered_m2: {cell_m: [1]}}", "area_covered_m2.cell_m", "[1]: expected a cell side > 0 m"),
        ("{bumps: {cell_m: 1}}", "bumps.cell_m", "unknown option of bumps (it takes no options)"),
        ("{user_metrics_a:reach: {centre: [1, 2]}}", "user_metrics_a:reach.centre", "(it takes: center, within_m)"),
        (
            "{user_metrics_a:reach: {center: [1, 2], within_m: true}}",
            "user_metrics_a:reach.within_m",
            "expected a number (m)",
        ),
    ],
)
def test_a_bad_metric_option_names_the_field_the_option_and_the_accepted_ones(
    tmp_path: Path, metric: str, field: str, message: str
) -> None:
    (tmp_path / "user_metrics_a.py").write_text(USER_METRICS, encoding="utf-8")
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        f"worlds: [{{map: create/example.map}}]\ncontrollers: [create_bump_turn]\nduration_s: 1\nmetrics: [{metric}]\n"
    )
    with pytest.raises(InputError) as error:
        load_sweep(sweep)
    assert str(error.value) == f"{sweep}: field 'metrics[0].{field}': " + str(error.value).split("': ", 1)[1]
    assert message in str(error.value)


def test_good_metric_options_and_a_metric_taking_any_options_load(tmp_path: Path) -> None:
    (tmp_path / "user_metrics_b.py").write_text(USER_METRICS.replace("reach", "reach_b"), encoding="utf-8")
    sweep = tmp_path / "sweep.yaml"
    metrics = "[{goal_time_s: {center: [2, 0]}}, {user_metrics_b:anything: {x: 1}}, {area_covered_m2: {cell_m: 0.1}}]"
    sweep.write_text(
        f"worlds: [{{map: create/example.map}}]\ncontrollers: [create_bump_turn]\nduration_s: 1\nmetrics: {metrics}\n"
    )
    assert len(load_sweep(sweep).episodes) == 1


# ---------------------------------------------------------------------------------- end to end
CONTROLLER = '''
def drive(model, params, seed):
    """Straight at speed, or an arc: only the straight ones reach the goal ahead."""
    def control(model, t):
        model.set_velocity(params["speed"], params["turn"])

    return control
'''


def test_a_short_sweep_writes_the_reached_share_in_its_summary_table_and_plots(tmp_path: Path) -> None:
    (tmp_path / "arc_driver.py").write_text(CONTROLLER, encoding="utf-8")
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        textwrap.dedent(
            """
            worlds: [{map: create/example.map}]
            controllers: [arc_driver:drive]
            grid: {turn: [0.0, 1.0], speed: [0.2, 0.4]}
            poses: [[0.0, 0.0, 0.0]]
            duration_s: 3
            metrics: [distance_m, min_clearance_m, {goal_time_s: {center: [0.5, 0.0], radius_m: 0.2}}]
            """
        )
    )
    done = batch(str(sweep), "--workers", "1", "--out", "out", "--quiet", cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    table = pq.read_table(tmp_path / "out" / "episodes.parquet").to_pylist()
    by = {(r["param.turn"], r["param.speed"]): r for r in table}
    # 0.3 m to the goal's edge: 1.5 s at 0.2 m/s, 0.75 s at 0.4 m/s; an arc of radius 0.2 or
    # 0.4 m never gets 0.3 m ahead
    assert {k: r["goal_reached"] for k, r in by.items()} == {
        (0.0, 0.2): True,
        (0.0, 0.4): True,
        (1.0, 0.2): False,
        (1.0, 0.4): False,
    }
    times = [by[0.0, 0.2]["goal_time_s"], by[0.0, 0.4]["goal_time_s"]]
    assert times == pytest.approx([1.5, 0.75], abs=0.02)
    assert f"goal_time_s: reached 2/4 (50 %), mean of those {sum(times) / 2:.4g} s" in done.stdout
    assert all(math.isnan(by[1.0, s]["goal_time_s"]) for s in (0.2, 0.4))
    plots = {p.name for p in (tmp_path / "out" / "plots").iterdir()}
    assert plots == {"distance_m.png", "min_clearance_m.png", "goal_reached.png", "goal_time_s.png"}
