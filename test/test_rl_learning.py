"""The learning example learns: a short CMA-ES run beats random actions, and the shipped trained
policy (examples/learning/create_nav_policy.npz) reaches more goals than random actions and than
bump-and-turn, with fewer collisions, driving forwards; the one trained with the example noise
(create_nav_policy_noisy.npz) does so with that noise, where the noise-free one falls behind it.
The training code is the example's own (examples/learning/train_create_nav.py)."""

from __future__ import annotations

import signal
import sys
from pathlib import Path

import numpy as np
import pytest

from sim_runtime.paths import config_path
from sim_tools.rl.policy import load_policy

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "learning"
sys.path.insert(0, str(EXAMPLE))  # the example is a script, not a package
import train_create_nav as example  # noqa: E402

#: An easy fixed task for the short run: the goal 1.6 m away, 90° to the right of the start heading.
START, GOAL = (-1.0, -1.0, np.pi / 2), (0.5, -0.5)
SHORT = {"start": START, "goal": GOAL, "max_steps": 100}
SEEDS = range(example.EVAL_SEED0, example.EVAL_SEED0 + 10)


def test_a_few_generations_of_cma_es_improve_on_the_policy_they_start_from_and_beat_random_actions():
    # the search starts from a policy heading for the goal (train_create_nav.initial_params)
    config = example.TrainConfig(episodes=1, popsize=8, max_generations=4, sigma0=0.2, env_overrides=SHORT)
    policy, history = example.train(config, log=lambda _line: None)
    env = example.make_env(**SHORT)
    start = example.new_policy(env)
    start = start.with_params(example.initial_params(start, config.head_for_goal))
    first = example.rollout(env, example.PolicyController(start), seed=0)
    trained = example.rollout(env, example.PolicyController(policy), seed=0)
    randoms = [example.rollout(env, example.RandomController(env), seed).ret for seed in range(5)]
    assert len(history) == 4
    assert trained.success and trained.ret > first.ret and trained.time_s < first.time_s, (trained, first)
    assert trained.ret > max(randoms) + 1.0, (trained, randoms)


def test_the_search_starts_driving_forwards_and_turning_towards_the_goal():
    env = example.make_env(sensors=["goal"])  # observation: goal distance, bearing
    policy = example.new_policy(env)
    policy = policy.with_params(example.initial_params(policy, 1.0))
    left, right = policy.act(np.array([1.0, 1.0], dtype=np.float32)), policy.act(np.array([1.0, -1.0], np.float32))
    assert left[0] > 0.3 and right[0] > 0.3  # forwards
    assert left[1] > 0.5 and right[1] < -0.5  # towards the goal's side


@pytest.fixture(scope="module")
def shipped():
    policy = load_policy(EXAMPLE / "create_nav_policy.npz")
    env = example.make_env(**policy.env_kwargs)
    return policy, env


def test_the_shipped_policy_file_names_its_env_and_options(shipped):
    policy, env = shipped
    assert policy.env_id == "robot_sims/CreateNav-v0"
    assert policy.env_kwargs == example.ENV_KWARGS
    assert policy.weights[0].shape[0] == env.observation_space.shape[0]


def test_the_shipped_policy_reaches_more_goals_than_random_actions_and_bump_and_turn(shipped):
    policy, env = shipped
    learned = example.evaluate(example.PolicyController(policy), SEEDS, env)
    rivals = [example.evaluate(c, SEEDS, env) for c in (example.RandomController(env), example.BumpTurnController(env))]
    assert all(learned["success_rate"] > r["success_rate"] for r in rivals), (learned, rivals)
    assert all(learned["mean_return"] > r["mean_return"] for r in rivals), (learned, rivals)


def test_played_on_after_collisions_as_in_a_batch_the_shipped_policy_beats_bump_and_turn_on_goals_and_collisions(
    shipped,
):
    policy, env = shipped
    learned = example.evaluate(example.PolicyController(policy), SEEDS, env, collisions_end=False)
    bump_turn = example.evaluate(example.BumpTurnController(env), SEEDS, env, collisions_end=False)
    assert learned["success_rate"] > bump_turn["success_rate"], (learned, bump_turn)
    assert learned["mean_collisions"] < bump_turn["mean_collisions"], (learned, bump_turn)


def test_the_shipped_policy_drives_forwards_most_of_the_time(shipped):
    policy, env = shipped
    learned = example.evaluate(example.PolicyController(policy), SEEDS, env, collisions_end=False)
    assert learned["backward_share"] < 0.5 and learned["mean_v_mps"] > 0.0, learned


def test_a_controller_reversing_into_a_wall_is_counted_as_colliding_though_it_never_bumps():
    class Reverse:
        def reset(self, seed: int) -> None:
            pass

        def act(self, obs: np.ndarray) -> np.ndarray:
            return np.array([-0.3, 0.0], dtype=np.float32)

    env = example.make_env(start=(-1.74, 0.0, 0.0), goal=(1.0, 0.0))  # its back 0.26 m from a wall
    episode = example.rollout(env, Reverse(), seed=0, collisions_end=False)
    assert episode.collisions == 1 and episode.bumps == 0 and episode.backward_steps == episode.steps
    assert episode.contact_steps > 0.8 * episode.steps  # pushing against the wall: a stall


def test_with_the_example_noise_the_noise_trained_policy_reaches_more_goals_than_the_noise_free_one_and_bump_and_turn():
    noisy = example.make_env(config_file=str(config_path("create/example_config.txt")))
    policies = [load_policy(EXAMPLE / name) for name in ("create_nav_policy_noisy.npz", "create_nav_policy.npz")]
    trained, noise_free = (
        example.evaluate(example.PolicyController(p), SEEDS, noisy, collisions_end=False) for p in policies
    )
    bump_turn = example.evaluate(example.BumpTurnController(noisy), SEEDS, noisy, collisions_end=False)
    assert trained["success_rate"] > max(noise_free["success_rate"], bump_turn["success_rate"]), (
        trained,
        noise_free,
        bump_turn,
    )
    assert trained["mean_collisions"] < bump_turn["mean_collisions"], (trained, bump_turn)


def test_the_training_pools_workers_end_on_sigterm_even_when_the_program_catches_sigterm():
    caught = signal.signal(signal.SIGTERM, lambda *_: None)  # as rclpy and our executables do
    try:
        pool = example._pool(example.TrainConfig(workers=1, env_overrides=SHORT))
    finally:
        signal.signal(signal.SIGTERM, caught)
    try:  # train() leaves the pool by terminate(), which hung when a worker had inherited the handler
        assert pool.apply(signal.getsignal, (signal.SIGTERM,)) == signal.SIG_DFL
    finally:
        pool.close()  # ends the workers whatever their handlers
        pool.join()
