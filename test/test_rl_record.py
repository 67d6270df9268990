"""RecordEpisodeBags: learning-env episodes written as bags that the bag tools read as any recording."""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
import pytest
import yaml
from rerun_test_helpers import column, load_entities

import sim_tools.rl  # noqa: F401 (registers the ids)
from create_sim.synthetic_run import world_topics
from sim_runtime.bag.reader import open_bag
from sim_runtime.errors import InputError
from sim_runtime.msgs import yaw_from_quaternion
from sim_runtime.paths import config_path
from sim_tools.rl.create_nav import GOAL_COLOR
from sim_tools.rl.record import EPISODE_FILE, GOAL_NS, RecordEpisodeBags
from studio.replay.draw import markers_svg
from studio.replay.frames import Replay
from studio.shell.svg import View, rgb_hex

SEED = 7
ACTION = np.array([0.3, 0.4], dtype=np.float32)
START, GOAL = (-1.5, 0.0, 0.0), (-0.5, 1.8)


def play(env: gymnasium.Env, steps: int, seed: int = SEED) -> tuple[list[np.ndarray], list[float], dict]:
    """One episode (at most ``steps`` steps) of ACTION; its observations, rewards and last info."""
    obs, info = env.reset(seed=seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(ACTION)
        observations.append(obs)
        rewards.append(float(reward))
        if terminated or truncated:
            break
    return observations, rewards, info


@pytest.fixture(scope="module")
def episode(tmp_path_factory) -> tuple[Path, dict, int, list[float]]:
    """A recorded CreateNav episode (fixed seed): its bag, last info, steps and rewards."""
    env = RecordEpisodeBags(
        gymnasium.make("robot_sims/CreateNav-v0", max_episode_steps=25), tmp_path_factory.mktemp("rec")
    )
    _obs, rewards, info = play(env, 25)
    steps = env.unwrapped.steps
    env.close()
    (bag,) = env.recorded
    return bag, info, steps, rewards


def last_messages(bag: Path) -> dict:
    last = {}
    for m in open_bag(bag).messages():
        last[m.topic] = m
    return last


def test_a_recorded_episode_is_a_bag_of_the_worlds_topics_ending_where_the_env_ended(episode):
    bag, info, steps, rewards = episode
    assert bag.name == "rl-bag-episode-0"
    reader = open_bag(bag)
    assert set(reader.topics) == set(world_topics(full=True))
    last = last_messages(bag)
    # the sim time: the last /clock is steps × the control period (0.1 s = 10 physics steps)
    assert last["/clock"].log_time_ns == steps * 100_000_000
    pose = last["/overhead_pose"].msg.pose
    x, y, theta = info["pose"].tolist()
    assert (pose.position.x, pose.position.y) == (x, y)
    assert yaw_from_quaternion(pose.orientation) == pytest.approx(theta, abs=1e-12)
    assert last["/overhead_pose"].log_time_ns == steps * 100_000_000
    assert last["/overhead_pose"].msg.header.frame_id == "map" and last["/odom"].msg.header.frame_id == "odom"
    assert last["/cmd_vel"].log_time_ns == (steps - 1) * 100_000_000  # the last action, at its period's start
    counts = {t: sum(1 for _ in reader.messages(topics=[t])) for t in ("/odom", "/scan", "/sonar/front", "/cmd_vel")}
    # the world's default rates (50, 10, 20 Hz) from t = 0, one command per env step
    assert counts == {"/odom": 5 * steps + 1, "/scan": steps + 1, "/sonar/front": 2 * steps + 1, "/cmd_vel": steps}
    summary = yaml.safe_load((bag / EPISODE_FILE).read_text())
    assert summary["seed"] == SEED and summary["steps"] == steps and summary["finished"] is True
    assert summary["return"] == pytest.approx(sum(rewards))
    assert summary["is_success"] == info["is_success"] and summary["goal"] == info["goal"].tolist()


def test_recording_leaves_a_noisy_episode_exactly_as_it_plays_unrecorded(tmp_path):
    noisy = {"config_file": config_path("create/example_config.txt"), "sensors": ("lidar", "sonar", "bump", "goal")}
    plain = play(gymnasium.make("robot_sims/CreateNav-v0", max_episode_steps=15, **noisy), 15)
    env = RecordEpisodeBags(gymnasium.make("robot_sims/CreateNav-v0", max_episode_steps=15, **noisy), tmp_path)
    recorded = play(env, 15)
    env.close()
    assert len(plain[0]) == len(recorded[0])
    assert all(np.array_equal(a, b) for a, b in zip(plain[0], recorded[0], strict=True))
    assert plain[1] == recorded[1]
    assert len(env.recorded) == 1 and (env.recorded[0] / "metadata.yaml").exists()


def test_bag_to_rerun_converts_a_recorded_episode_with_its_goal_region(episode, tmp_path, capsys):
    from sim_tools.rerun_view.convert import main

    bag, info, _steps, _rewards = episode
    rrd = tmp_path / "episode.rrd"
    main([str(bag), "-o", str(rrd), "--no-progress"])
    assert "wrote" in capsys.readouterr().out
    entities = load_entities(rrd)
    (circle,) = column(entities["/top/map/map_markers/goal/0"], "LineStrips2D:strips")[0]
    centre = np.mean(np.array(circle)[:-1], axis=0)
    assert centre == pytest.approx(info["goal"].tolist(), abs=1e-6)  # in map coordinates


def test_the_track_picture_and_the_studio_replay_draw_a_recorded_episode(episode, tmp_path, capsys):
    from sim_tools.rerun_view.tracks import main

    bag, info, steps, _rewards = episode
    png = tmp_path / "tracks.png"
    main([str(bag), "-o", str(png)])
    assert png.stat().st_size > 0 and "wrote" in capsys.readouterr().out
    replay = Replay.open(bag)
    assert replay.duration_s == pytest.approx(steps * 0.1)
    frame = replay.frame(replay.end_ns)
    assert frame.map is not None and len(frame.robots) == 1
    assert frame.robots[0].pose[:2] == pytest.approx(info["pose"][:2].tolist())
    # the goal region, which is no part of the map, drawn beside it in the env's goal colour
    assert frame.map_extras is not None and [m.ns for m in frame.map_extras.markers] == [GOAL_NS]
    drawn = markers_svg(View(), frame.map_extras)
    assert drawn.count("<polyline") == 1 and rgb_hex(GOAL_COLOR) in drawn


def test_only_triggered_episodes_are_recorded_and_an_episode_cut_short_says_so(tmp_path):
    env = RecordEpisodeBags(
        gymnasium.make("robot_sims/CreateCover-v0", max_episode_steps=3), tmp_path, episode_trigger=lambda n: n != 1
    )
    for seed in (1, 2, 3):
        play(env, 3, seed)
    env.reset(seed=4)
    env.step(ACTION)
    env.close()
    assert [p.name for p in env.recorded] == [f"rl-bag-episode-{n}" for n in (0, 2, 3)]
    outcomes = [yaml.safe_load((p / EPISODE_FILE).read_text()) for p in env.recorded]
    assert [o["finished"] for o in outcomes] == [True, True, False]
    assert "goal" not in outcomes[0] and outcomes[0]["area_covered_m2"] > 0
    markers = next(open_bag(env.recorded[0]).messages(topics=["/map_markers"])).msg.markers
    assert "goal" not in {m.ns for m in markers}  # covering has no goal


def test_bags_are_never_overwritten_and_only_create_envs_are_recorded(tmp_path):
    (tmp_path / "rl-bag-episode-0").mkdir()
    with pytest.raises(InputError, match=r"rl-bag-episode-0.*exists"):
        RecordEpisodeBags(gymnasium.make("robot_sims/CreateNav-v0"), tmp_path)
    RecordEpisodeBags(gymnasium.make("robot_sims/CreateNav-v0"), tmp_path, name_prefix="other").close()
    with pytest.raises(InputError, match="CartPoleEnv"):
        RecordEpisodeBags(gymnasium.make("CartPole-v1"), tmp_path / "cartpole")


def test_a_recorded_arm_reach_episode_is_a_bag_of_the_arm_worlds_topics_that_replay_and_rerun_draw(tmp_path):
    from sim_tools.rerun_view.convert import main

    env = RecordEpisodeBags(gymnasium.make("robot_sims/ArmReach-v0", max_episode_steps=20), tmp_path)
    env.reset(seed=SEED)
    for _ in range(20):
        env.step(np.full(env.action_space.shape, 0.5, dtype=np.float32))  # some joints reach a limit
    env.close()
    (bag,) = env.recorded
    reader = open_bag(bag)
    arm_topics = {"/joint_states", "/end_effector_pose", "/robot_markers", "/robot_description", "/tf", "/tf_static"}
    assert arm_topics | {"/clock", "/target_pose"} == set(reader.topics)
    last = last_messages(bag)
    assert last["/clock"].log_time_ns == 20 * 50_000_000  # 20 steps of 0.05 s
    assert list(last["/joint_states"].msg.position) == env.unwrapped.q.tolist()
    assert sum(1 for _ in reader.messages(topics=["/joint_states"])) == 50 + 1  # 50 Hz over 1 s, and t = 0
    arm = env.unwrapped.arm
    at_limit = np.isclose(env.unwrapped.q, arm.upper)
    assert at_limit.any() and not at_limit.all()
    assert np.array_equal(last["/joint_states"].msg.velocity, np.where(at_limit, 0.0, 0.5))  # a held joint stands
    replay = Replay.open(bag)
    frame = replay.frame(replay.end_ns)
    assert [q for _name, q in frame.joints[""]] == env.unwrapped.q.tolist() and len(frame.arm_groups) == 1
    main([str(bag), "-o", str(tmp_path / "arm.rrd"), "--no-progress"])
    assert "/world/poses/target_pose" in load_entities(tmp_path / "arm.rrd")
    assert yaml.safe_load((bag / EPISODE_FILE).read_text())["steps"] == 20


def test_robot_sims_replay_plays_a_recorded_episode_back_on_the_worlds_topics(episode, executor, make_node):
    from geometry_msgs.msg import PoseStamped
    from rosgraph_msgs.msg import Clock

    from sim_runtime.bag.replay import play_bag
    from sim_runtime.testing import Collector, spin_until

    bag, info, steps, _rewards = episode
    node = make_node("rollout_listener")
    poses = Collector(node, PoseStamped, "/overhead_pose", 1000)
    clock = Collector(node, Clock, "/clock", 1000)
    stats = play_bag(bag, executor, wait_for_subscribers=1, rate=4.0, topics=["/overhead_pose", "/clock"])
    assert stats.published == (5 * steps + 1) + (10 * steps + 1)
    assert spin_until(executor, lambda: len(poses.msgs) == 5 * steps + 1 and len(clock.msgs) == 10 * steps + 1)
    assert (poses.last.pose.position.x, poses.last.pose.position.y) == tuple(info["pose"][:2].tolist())
    assert clock.last.clock.sec * 10**9 + clock.last.clock.nanosec == steps * 100_000_000
