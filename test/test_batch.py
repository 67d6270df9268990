"""`robot_sims batch`: sweeps of isolated episodes → one table, the same whatever runs them.

Every sweep runs as a user runs it, in its own process; episodes are a few sim seconds long."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pyarrow.parquet as pq
import pytest

ROOT = Path(__file__).resolve().parent.parent

USER_MODULE = '''
import math

import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import Range

from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS


class Spinner(Node):
    """Drives an arc; with fail_at > 0 it raises once the sim time gets there."""

    def __init__(self, **kwargs):
        super().__init__("spinner", **kwargs)
        self.turn = self.declare_parameter("turn", 0.5).value
        self.fail_at = self.declare_parameter("fail_at", 0.0).value
        self.pub = self.create_publisher(Twist, "cmd_vel", COMMAND_PUBLISHER_QOS)
        self.create_subscription(Range, "bump/left", self.on_bump, SENSOR_SUBSCRIBER_QOS)

    def on_bump(self, msg):
        now = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        if 0 < self.fail_at <= now:
            raise RuntimeError(f"spinner gave up at {now:.2f} s")
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = 0.3, float(self.turn)
        self.pub.publish(cmd)


def main():
    rclpy.init()
    node = Spinner()
    rclpy.spin(node)
    node.destroy_node()
    rclpy.shutdown()


def drive(model, params, seed):
    def control(model, t):
        model.set_velocity(0.3, params.get("turn", 0.5))

    return control


def net_displacement(data):
    return math.hypot(data.arrays["x"][-1] - data.arrays["x"][0], data.arrays["y"][-1] - data.arrays["y"][0])
'''


def batch(
    *args: str, cwd: Path, extra_env: dict[str, str] | None = None, timeout: float = 240
) -> subprocess.CompletedProcess:
    """``robot_sims batch args...`` in its own process (``extra_env`` may set PYTHONPATH too)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), **(extra_env or {})}
    return subprocess.run(
        [sys.executable, "-m", "sim_tools.batch.cli", *args],
        cwd=cwd,
        env=env,
        text=True,
        capture_output=True,
        timeout=timeout,
    )


def write_sweep(folder: Path, name: str, body: str) -> Path:
    path = folder / name
    path.write_text(textwrap.dedent(body), encoding="utf-8")
    return path


def rows(csv_path: Path) -> list[dict[str, str]]:
    with csv_path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


BUMP_TURN = """
    worlds: [{map: create/example.map}]
    controllers: [%s]
    poses: {random: 4, seed: 3}
    seeds: [0]
    duration_s: 8
"""


@pytest.fixture(scope="module")
def bump_turn_local(tmp_path_factory) -> Path:
    """Four bump-and-turn episodes on one worker over the direct bus: the reference table."""
    folder = tmp_path_factory.mktemp("local")
    sweep = write_sweep(folder, "sweep.yaml", BUMP_TURN % "create_bump_turn")
    done = batch(str(sweep), "--workers", "1", "--out", "out", cwd=folder)
    assert done.returncode == 0, done.stderr
    return folder / "out"


def test_a_sweep_writes_a_row_per_episode_a_summary_and_plots(bump_turn_local: Path) -> None:
    table = rows(bump_turn_local / "episodes.csv")
    assert [r["episode"] for r in table] == ["0", "1", "2", "3"]
    assert all(r["status"] == "ok" and float(r["sim_time_s"]) == 8.0 for r in table)
    assert all(float(r["distance_m"]) > 0.5 for r in table)  # 8 s at 0.3 m/s, minus bumps
    parquet = pq.read_table(bump_turn_local / "episodes.parquet")
    assert parquet.num_rows == 4 and parquet.schema.field("bumps").type == "int64"
    assert {"distance_m.png", "bumps.png", "area_covered_m2.png"} <= {
        p.name for p in (bump_turn_local / "plots").iterdir()
    }


def test_two_workers_over_dds_give_the_table_of_one_worker_over_the_direct_bus(
    tmp_path: Path, bump_turn_local: Path
) -> None:
    sweep = write_sweep(tmp_path, "sweep.yaml", BUMP_TURN % "{use: create_bump_turn, transport: ros}")
    done = batch(str(sweep), "--workers", "2", "--out", "out", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "episodes.csv").read_text() == (bump_turn_local / "episodes.csv").read_text()
    transports = {r["transport"] for r in rows(tmp_path / "out" / "timings.csv")}
    assert transports == {"ros"}
    # Both workers start, but on a busy machine one can finish all four episodes while the other is
    # still warming up: the claim is the table, whichever of the two ran each episode.
    assert 1 <= len({r["pid"] for r in rows(tmp_path / "out" / "timings.csv")}) <= 2


def test_a_rerun_skips_finished_episodes_and_runs_new_ones(tmp_path: Path) -> None:
    sweep = write_sweep(tmp_path, "sweep.yaml", BUMP_TURN.replace("random: 4", "random: 2") % "create_bump_turn")
    first = batch(str(sweep), "--workers", "1", "--no-plots", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    folder = tmp_path / "out" / "batch" / "sweep"
    before = rows(folder / "episodes.csv")
    sweep.write_text(sweep.read_text().replace("seeds: [0]", "seeds: [0, 1]"))
    second = batch(str(sweep), "--workers", "1", "--no-plots", cwd=tmp_path)
    assert second.returncode == 0, second.stderr
    assert "4 episodes (2 already done)" in second.stderr
    assert "] 4/4 100%" in second.stderr  # the progress bar's last line
    after = rows(folder / "episodes.csv")
    assert len(after) == 4
    kept = {r["key"]: r for r in after}
    for old in before:  # same key, same results; only the episode number follows the new order
        assert {k: v for k, v in kept[old["key"]].items() if k != "episode"} == {
            k: v for k, v in old.items() if k != "episode"
        }


def test_user_nodes_main_functions_and_metrics_and_a_failing_episode(tmp_path: Path) -> None:
    (tmp_path / "my_ctl.py").write_text(USER_MODULE, encoding="utf-8")
    sweep = write_sweep(
        tmp_path,
        "sweep.yaml",
        """
        worlds: [{map: create/example.map}]
        controllers:
          - my_ctl:Spinner
          - {name: spinner_direct, use: my_ctl:Spinner, transport: direct}
          - my_ctl:main
          - {name: main_again, use: my_ctl:main}
          - my_ctl:drive
          - {name: quitter, use: my_ctl:Spinner, parameters: {fail_at: 1.5}}
        poses: [[0.0, 0.0, 0.0]]
        grid: {turn: [0.4]}
        duration_s: 3
        metrics: [distance_m, final_pose, my_ctl:net_displacement]
        keep_bags: failures
        """,
    )
    done = batch(str(sweep), "--workers", "1", "--out", "out", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    table = {r["controller"]: r for r in rows(tmp_path / "out" / "episodes.csv")}
    node, direct, main, function, quitter = (
        table[k] for k in ("my_ctl:Spinner", "spinner_direct", "my_ctl:main", "my_ctl:drive", "quitter")
    )
    assert node["status"] == direct["status"] == main["status"] == function["status"] == "ok"
    same = ("distance_m", "final_x", "final_y", "final_theta", "net_displacement")
    assert [node[k] for k in same] == [direct[k] for k in same] == [main[k] for k in same]
    assert [table["main_again"][k] for k in same] == [main[k] for k in same]  # a fresh global context each time
    assert float(node["distance_m"]) > 0.5 and float(node["net_displacement"]) > 0.3
    assert float(function["distance_m"]) > float(node["distance_m"])  # drives from step 1, not the first bump message
    assert quitter["status"] == "error" and "spinner gave up at 1.5" in quitter["error"]
    bags = list((tmp_path / "out" / "bags").iterdir())
    assert [b.name for b in bags] == [f"episode_{int(quitter['episode']):05d}"]
    assert list(bags[0].glob("*.mcap"))


def test_simrobot_and_arm_sweeps_report_their_metrics(tmp_path: Path) -> None:
    simrobot = write_sweep(
        tmp_path,
        "simrobot.yaml",
        """
        worlds: [{world_file: simrobot/demo.yaml}]
        controllers: [simrobot_avoid, {name: avoid_dds, use: simrobot_avoid, transport: ros}]
        grid: {threshold: [0.02, 0.2]}
        duration_s: 40
        """,
    )
    done = batch(str(simrobot), "--workers", "1", "--out", "sr", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    table = rows(tmp_path / "sr" / "episodes.csv")
    assert {r["status"] for r in table} == {"ok"}
    assert {"distance_m.r1", "crashed.r4", "steps_survived.r2"} <= set(table[0])
    by = {(r["controller"], r["param.threshold"]): r for r in table}
    for threshold in ("0.02", "0.2"):
        direct, dds = by["simrobot_avoid", threshold], by["avoid_dds", threshold]
        assert [direct[k] for k in direct if k not in ("episode", "key", "controller")] == [
            dds[k] for k in dds if k not in ("episode", "key", "controller")
        ]
    assert float(by["simrobot_avoid", "0.2"]["steps_survived"]) == 40.0  # alg2 with its 20 cm keeps clear

    arm = write_sweep(
        tmp_path,
        "arm.yaml",
        """
        worlds: [{robot_config: arm/irb120.yaml, targets: [[0.4, 0.0, 0.5], [3.0, 0.0, 0.5]], hold_s: 1.5}]
        controllers: [arm_targets]
        duration_s: 3
        """,
    )
    done = batch(str(arm), "--workers", "1", "--out", "arm", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    (row,) = rows(tmp_path / "arm" / "episodes.csv")
    assert row["status"] == "ok" and row["ik_failures"] == "1"  # 3 m is out of the IRB120's reach
    assert float(row["max_tracking_error_m"]) > 2.0


CREATE = "worlds: [{map: create/example.map}]\n"
BUMP = CREATE + "controllers: [create_bump_turn]\n"


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ("worlds: [{map: nowhere.map}]\ncontrollers: [create_bump_turn]\nduration_s: 1\n", "worlds[0].map"),
        (CREATE + "controllers: [simrobot_avoid]\nduration_s: 1\n", "controllers[0]"),
        (CREATE + "controllers: [x]\nduration_s: 1\n", "controllers[0]"),
        (CREATE + "controllers: [no_such_module:Node]\nduration_s: 1\n", "controllers[0].use"),
        (BUMP + "duration_s: -1\n", "duration_s"),
        (BUMP + "duration_s: 1\nmetrics: [speed]\n", "metrics[0]"),
        (BUMP + "duration_s: 1\nmetrics: [os:nope]\n", "metrics[0]"),
        (BUMP + "duration_s: 1\nkeep_bags: some\n", "keep_bags"),
        (BUMP + "duration_s: 1\nseed: [1]\n", "seed"),
    ],
)
def test_a_bad_sweep_file_is_one_line_naming_the_file_and_field(tmp_path: Path, body: str, field: str) -> None:
    sweep = write_sweep(tmp_path, "bad.yaml", body)
    done = batch(str(sweep), cwd=tmp_path, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {sweep}: field '{field}") and "Traceback" not in done.stderr


RAY_CLUSTER = """
import sys
from ray.cluster_utils import Cluster

from sim_tools.batch.cli import main

store = 80 * 2**20
cluster = Cluster(
    initialize_head=True, head_node_args={"num_cpus": 1, "object_store_memory": store, "include_dashboard": False}
)
cluster.add_node(num_cpus=1, object_store_memory=store)
cluster.wait_for_nodes()
try:
    code = main([*sys.argv[1:], "--ray", cluster.address])
finally:
    cluster.shutdown()
sys.exit(code)
"""


def test_ray_locally_and_on_a_two_node_cluster_gives_the_local_table(tmp_path: Path, bump_turn_local: Path) -> None:
    sweep = write_sweep(tmp_path, "sweep.yaml", BUMP_TURN % "create_bump_turn")
    short = Path("/tmp") / f"ray{os.getpid()}"  # Ray's socket paths must stay short
    env = {"RAY_AUTH_MODE": "disabled", "RAY_TMPDIR": str(short)}
    local = batch(
        str(sweep), "--ray", "--workers", "2", "--out", "ray_local", "--no-plots", cwd=tmp_path, extra_env=env
    )
    assert local.returncode == 0, local.stderr
    assert (tmp_path / "ray_local" / "episodes.csv").read_text() == (bump_turn_local / "episodes.csv").read_text()

    script = tmp_path / "cluster.py"
    script.write_text(RAY_CLUSTER, encoding="utf-8")
    cluster = subprocess.run(
        [sys.executable, str(script), str(sweep), "--out", "ray_cluster", "--no-plots"],
        cwd=tmp_path,
        env=dict(os.environ, PYTHONPATH=str(ROOT), **env),
        text=True,
        capture_output=True,
        timeout=240,
    )
    assert cluster.returncode == 0, cluster.stderr
    assert (tmp_path / "ray_cluster" / "episodes.csv").read_text() == (bump_turn_local / "episodes.csv").read_text()
