"""The Gymnasium environments over the pure models: Gymnasium's own checker, seeding, the physics."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from create_sim import spec
from create_sim.configfile import load_config
from create_sim.mapfile import load_map
from create_sim.model import CreateModel
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_tools.adapters.contract import EpisodeData
from sim_tools.adapters.create.world import COVERAGE_CELL_M, coverage_disc, create_area_covered_m2
from sim_tools.rl.arm_reach import ArmReachEnv, pose_error
from sim_tools.rl.create_cover import CreateCoverEnv
from sim_tools.rl.create_nav import CreateNavEnv
from sim_tools.rl.create_regions import FloorRegions
from sim_tools.rl.create_sensors import SENSORS

NOISY = str(config_path("create/example_config.txt"))


def _checked(env: gymnasium.Env) -> None:
    with warnings.catch_warnings():
        # the checker advises [-1, 1] action boxes; ours are the robots' own units by design
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space.*")
        # the cliff signals are unbounded (their noise is): the observation box says so
        warnings.filterwarnings("ignore", message=".*Box observation space m.* is .*infinity.*")
        check_env(env, skip_render_check=True)


def _episode(env: gymnasium.Env, seed: int, steps: int) -> list[np.ndarray]:
    obs, _info = env.reset(seed=seed)
    env.action_space.seed(seed)
    seen = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, _info = env.step(env.action_space.sample())
        seen += [obs, np.array([reward])]
        if terminated or truncated:
            obs, _info = env.reset()
            seen.append(obs)
    return seen


def test_create_nav_passes_gymnasiums_env_checker_with_every_sensor_and_noise():
    _checked(CreateNavEnv(config_file=NOISY, sensors=SENSORS))


@pytest.mark.parametrize("robot", ["irb120", "csa7"])
def test_arm_reach_passes_gymnasiums_env_checker(robot):
    _checked(ArmReachEnv(robot))


def test_create_cover_passes_gymnasiums_env_checker():
    _checked(CreateCoverEnv(config_file=NOISY, sensors=("lidar", "sonar", "bump", "cliff")))


# (0.02, -0.02) is on the cell whose key is -1
@pytest.mark.parametrize("start", [(-1.5, -1.0, 0.0), (0.02, -0.02, 0.0)])
def test_create_cover_counts_the_area_as_the_batch_metric_does_and_rewards_it(start):
    env = CreateCoverEnv(start=start, max_steps=80)
    env.reset(seed=0)
    rewards = []
    for _ in range(80):
        _obs, reward, terminated, truncated, info = env.step(np.array([0.3, 0.6], dtype=np.float32))
        rewards.append(reward)
        if terminated or truncated:
            break
    xy = np.array(env.track)
    data = EpisodeData(np.arange(len(xy)) * 0.1, {"x": xy[:, 0], "y": xy[:, 1]}, {"radius_m": CreateModel.RADIUS})
    assert info["area_covered_m2"] == pytest.approx(create_area_covered_m2(data))
    assert info["area_covered_m2"] > 0.5
    # reset counts the start's cells unrewarded; each step pays 100 per m² it adds, a bump costs 10
    at_start = len(coverage_disc(CreateModel.RADIUS)) * COVERAGE_CELL_M**2
    paid = 100.0 * (info["area_covered_m2"] - at_start) - 0.01 * len(rewards) - 10.0 * info["bumped"]
    assert sum(rewards) == pytest.approx(paid)


def test_random_goals_are_reachable_from_the_start_and_outside_the_goal_region():
    regions = FloorRegions(load_map(config_path("create/example.map")).walls, CreateModel.RADIUS)
    # the example map's box (-1.2..-0.6, 0.8..1.4) is closed: its inside is a region of its own
    assert not regions.connected((-1.5, -1.0), (-0.9, 1.1))
    assert regions.connected((-1.5, -1.0), (3.0, 1.0))  # through the doorway
    env = CreateNavEnv(sensors=("goal",))
    for seed in range(30):
        _obs, info = env.reset(seed=seed)
        assert info["distance_m"] > 2 * env.goal_radius_m
        assert regions.connected(info["pose"], info["goal"])
    inside = CreateNavEnv(start=(-0.9, 1.1, 0.0), sensors=("goal",))
    with pytest.raises(InputError, match="no reachable goal"):
        inside.reset(seed=0)  # a 0.6 m box has no goal 0.6 m from its centre


def test_the_same_seed_gives_the_same_create_episode_and_another_seed_another():
    make = lambda: CreateNavEnv(config_file=NOISY, sensors=SENSORS, max_steps=50)  # noqa: E731
    first, again, other = _episode(make(), 7, 120), _episode(make(), 7, 120), _episode(make(), 8, 120)
    assert len(first) == len(again)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not np.array_equal(first[0], other[0])


def test_the_same_seed_gives_the_same_arm_episode():
    first = _episode(ArmReachEnv("csa7", max_steps=40), 3, 60)
    again = _episode(ArmReachEnv("csa7", max_steps=40), 3, 60)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))


def _readings(model: CreateModel) -> np.ndarray:
    """Every sensor but the goal, read straight from the model in the env's documented order."""
    lidar, sonar, bump, cliff = model.lidar(), model.sonar(), model.bumps(), model.cliff_signals()
    parts = [np.clip(lidar, *model.LIDAR_RANGE), np.clip(sonar, 0.0, model.SONAR_RANGE[1]), bump, cliff]
    return np.concatenate(parts).astype(np.float32)


def test_an_action_sequence_through_the_env_equals_stepping_the_create_model_directly():
    start = (-1.5, -1.0, 0.3)
    env = CreateNavEnv(config_file=NOISY, sensors=SENSORS, lidar_beams=681, start=start, goal=(3.0, 1.0))
    obs, _info = env.reset(seed=11)
    model = CreateModel(
        load_map(config_path("create/example.map")), load_config(NOISY), np.random.default_rng(env.model_seed), start
    )
    assert np.array_equal(obs[:-2], _readings(model))
    rng = np.random.default_rng(0)
    for k in range(60):
        action = np.array([rng.uniform(-0.2, 0.5), rng.uniform(-2.0, 2.0)], dtype=np.float32)  # wandering
        obs, _r, terminated, _t, info = env.step(action)
        model.set_velocity(float(action[0]), float(action[1]))
        for _ in range(round(0.1 * spec.PHYSICS_RATE)):
            model.step(1.0 / spec.PHYSICS_RATE)
        assert np.array_equal(obs[:-2], _readings(model)), f"step {k}"
        assert np.array_equal(info["pose"], model.pose)
        if terminated:
            break
    assert k > 10  # long enough to compare (no bump at once)


def test_driving_into_a_wall_ends_the_episode_with_the_collision_penalty():
    # 0.25 m from the outer wall at x = -2, facing it
    env = CreateNavEnv(start=(-1.75 + 0.01, 0.0, np.pi), goal=(3.0, 0.0), sensors=("bump", "goal"))
    env.reset(seed=0)
    for _ in range(20):
        obs, reward, terminated, truncated, info = env.step(np.array([0.3, 0.0], dtype=np.float32))
        if terminated:
            break
    assert terminated and info["collided"] and info["bumped"] and not truncated
    assert reward < -9.0
    assert obs[:2].tolist() == [1.0, 1.0]  # both bumpers: a hit in front


@pytest.mark.parametrize("env_class", [CreateNavEnv, CreateCoverEnv])
def test_reversing_into_a_wall_is_a_collision_though_no_bumper_is_pressed(env_class):
    # 0.25 m from the outer wall at x = -2, its back to it: the bumpers (front half) never touch it
    extra = {"goal": (3.0, 0.0)} if env_class is CreateNavEnv else {}
    env = env_class(start=(-1.75 + 0.01, 0.0, 0.0), sensors=("bump",), **extra)
    env.reset(seed=0)
    for _ in range(20):
        obs, reward, terminated, truncated, info = env.step(np.array([-0.3, 0.0], dtype=np.float32))
        if terminated:
            break
    assert terminated and info["collided"] and not truncated
    assert not info["bumped"] and obs.tolist() == [0.0, 0.0]
    assert reward < -9.0
    assert env.model is not None and env.model.touching() and env.model.clearance() < 1e-6


def test_the_collision_flag_is_the_models_contact_state_after_any_physics_step_of_the_period():
    # random actions, played on after collisions, against a bare model stepped with the same commands
    env = CreateNavEnv(start=(-1.5, -1.0, 0.0), goal=(3.0, 1.0), sensors=("goal",), max_steps=10**6)
    env.reset(seed=3)
    model = CreateModel(load_map(config_path("create/example.map")), pose=(-1.5, -1.0, 0.0))
    rng = np.random.default_rng(3)
    flags = []
    for k in range(400):
        if k % 15 == 0:  # wandering: each command held for 1.5 s
            action = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-1.0, 1.0)], dtype=np.float32)
        _obs, _reward, _terminated, _truncated, info = env.step(action)
        model.set_velocity(*action.tolist())
        touched = []
        for _ in range(env.substeps):
            model.step(1.0 / spec.PHYSICS_RATE)
            touched.append(model.touching())
        assert info["collided"] == any(touched)
        flags.append(info["collided"])
    assert 0 < sum(flags) < len(flags)  # both kinds of steps were seen


def test_reaching_the_goal_ends_the_episode_with_the_goal_reward():
    env = CreateNavEnv(start=(-1.5, -1.0, 0.0), goal=(-1.0, -1.0), sensors=("goal",), goal_radius_m=0.1)
    obs, _info = env.reset(seed=0)
    assert obs[0] == pytest.approx(0.5, abs=1e-6) and obs[1] == pytest.approx(0.0, abs=1e-6)
    for _ in range(30):
        _obs, reward, terminated, _truncated, info = env.step(np.array([0.3, 0.0], dtype=np.float32))
        if terminated:
            break
    assert terminated and info["is_success"] and reward > 9.0


def test_the_step_limit_truncates_a_create_episode():
    env = CreateNavEnv(start=(-1.5, -1.0, 0.0), goal=(3.0, 1.0), max_steps=5)
    env.reset(seed=0)
    results = [env.step(np.zeros(2, dtype=np.float32)) for _ in range(5)]
    assert [r[3] for r in results] == [False] * 4 + [True]
    assert not any(r[2] for r in results)


def test_a_resolved_rate_controller_reaches_the_target_of_the_7_dof_arm():
    env = ArmReachEnv("csa7", tolerance_m=0.005)
    env.reset(seed=1)
    for _ in range(200):
        qd = np.linalg.pinv(env.arm.jacob0(env.q)) @ (5.0 * pose_error(env.target, env.arm.fkine(env.q)))
        _obs, _reward, terminated, truncated, info = env.step(qd.astype(np.float32))
        if terminated or truncated:
            break
    assert terminated and info["is_success"] and info["position_error_m"] <= 0.005


@pytest.mark.parametrize("axis", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.0, 1.0, 0.0)])
@pytest.mark.parametrize("angle", [0.0, 1e-12, 0.3, 2.0, np.pi])
def test_the_arms_rotation_error_is_the_rotation_vector_between_the_poses(axis, angle):
    k = np.array(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    target = np.eye(4)
    target[:3, :3] = np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K  # Rodrigues
    target[:3, 3] = (0.1, -0.2, 0.3)
    error = pose_error(target, np.eye(4))
    assert error[:3] == pytest.approx([0.1, -0.2, 0.3])
    if angle == np.pi:  # a half turn about k is one about -k too
        assert abs(float(error[3:] @ k)) == pytest.approx(np.pi) and np.linalg.norm(error[3:]) == pytest.approx(np.pi)
    else:
        assert error[3:] == pytest.approx(angle * k, abs=1e-12)


def test_the_ids_make_the_envs_through_gymnasium():
    env = gymnasium.make("sim_tools.rl:robot_sims/CreateNav-v0", sensors=("lidar", "goal"), lidar_beams=8)
    obs, _info = env.reset(seed=0)
    assert obs.shape == (10,)
    arm = gymnasium.make("robot_sims/ArmReach-v0", robot="csa7")
    assert arm.reset(seed=0)[0].shape == (7 + 6,)
    many = gymnasium.make_vec("robot_sims/CreateNav-v0", num_envs=3, sensors=("goal",))
    assert many.reset(seed=0)[0].shape == (3, 2)


def test_the_ids_say_their_episode_length_and_gymnasium_make_truncates_there():
    env = gymnasium.make("robot_sims/CreateNav-v0", sensors=("goal",), start=(-1.5, -1.0, 0.0), goal=(3.0, 1.0))
    assert env.spec is not None and env.spec.max_episode_steps == 600
    assert gymnasium.spec("robot_sims/ArmReach-v0").max_episode_steps == 200
    short = gymnasium.make("robot_sims/CreateNav-v0", max_episode_steps=4, start=(-1.5, -1.0, 0.0), goal=(3.0, 1.0))
    short.reset(seed=0)
    truncations = [short.step(np.zeros(2, dtype=np.float32))[3] for _ in range(4)]
    assert truncations == [False, False, False, True]
    with pytest.raises(InputError, match="max_episode_steps=50"):
        gymnasium.make("robot_sims/CreateNav-v0", max_steps=50)
    many = gymnasium.make_vec("robot_sims/CreateNav-v0", num_envs=2, sensors=("goal",))
    assert all(e.max_steps == 600 for e in many.unwrapped.envs)


@pytest.mark.parametrize("env_class", [CreateNavEnv, ArmReachEnv])
def test_a_normalised_action_space_maps_minus_one_to_one_onto_the_robots_limits(env_class):
    plain, normal = env_class(), env_class(normalize_actions=True)
    box = plain.action_space
    assert np.array_equal(normal.action_space.low, -np.ones(box.shape)) and normal.action_space.high.max() == 1.0
    assert np.array_equal(normal.physical_action_space.high, box.high)
    rng = np.random.default_rng(0)
    for env in (plain, normal):
        env.reset(seed=4)
    for _ in range(20):
        a = rng.uniform(-1.0, 1.0, box.shape).astype(np.float32)
        physical = (box.low + 0.5 * (a.astype(float) + 1.0) * (box.high - box.low)).astype(np.float32)
        obs_plain, *_ = plain.step(physical)
        obs_normal, *_ = normal.step(a)
        assert np.allclose(obs_plain, obs_normal, atol=1e-5)
    _checked(env_class(normalize_actions=True))


def test_create_nav_renders_the_walls_and_the_track_as_an_rgb_array():
    env = CreateNavEnv(render_mode="rgb_array", start=(-1.5, -1.0, 0.0), goal=(3.0, 1.0))
    env.reset(seed=0)
    before = env.render()
    for _ in range(20):
        env.step(np.array([0.3, 0.5], dtype=np.float32))
    frame = env.render()
    assert frame is not None and before is not None
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert (frame.min(axis=2) < 60).sum() > 1000  # the walls, in black
    assert not np.array_equal(frame, before)  # the track grew
    assert CreateNavEnv().render() is None  # no render_mode: nothing drawn


def test_bad_options_raise_input_errors_that_say_what_is_allowed():
    with pytest.raises(InputError, match="choose one or more of"):
        CreateNavEnv(sensors=("radar",))
    with pytest.raises(InputError, match="inside a wall"):
        CreateNavEnv(start=(-2.0, 0.0, 0.0)).reset(seed=0)
    with pytest.raises(InputError, match="6 joint positions within the limits"):
        ArmReachEnv("irb120", start=[0.0] * 5)
    with pytest.raises(InputError, match="CreateCover has no goal"):
        CreateCoverEnv(sensors=("lidar", "goal"))
    with pytest.raises(InputError, match="None or one of"):
        CreateNavEnv(render_mode="ansi")
