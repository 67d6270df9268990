"""The vector env of Create navigation worlds: each sub-env is exactly a CreateNavEnv on its own."""

from __future__ import annotations

import numpy as np
import pytest

from sim_runtime.errors import InputError
from sim_tools.rl.create_nav import CreateNavEnv
from sim_tools.rl.vector_create import vector_create_nav

SETTINGS = {"sensors": ("lidar", "bump", "goal"), "max_steps": 15}


def test_every_sub_env_plays_exactly_as_a_create_nav_env_alone_through_autoresets() -> None:
    envs = vector_create_nav(3, **SETTINGS)
    alone = [CreateNavEnv(**SETTINGS) for _ in range(3)]
    obs, _ = envs.reset(seed=11)
    assert obs.shape == (3, *alone[0].observation_space.shape)
    assert all(np.array_equal(obs[i], env.reset(seed=11 + i)[0]) for i, env in enumerate(alone))
    rng = np.random.default_rng(0)
    done = [False] * 3
    episodes_ended = 0
    for _ in range(40):  # past max_steps: every sub-env ends and is reset at least once
        actions = rng.uniform(envs.single_action_space.low, envs.single_action_space.high, (3, 2)).astype(np.float32)
        obs, rewards, terms, truncs, _ = envs.step(actions)
        assert envs.observation_space.contains(obs)
        for i, env in enumerate(alone):
            if done[i]:  # Gymnasium's next-step autoreset: the action is ignored
                expected, reward, term, trunc = env.reset()[0], 0.0, False, False
            else:
                expected, reward, term, trunc, _ = env.step(actions[i])
            assert np.array_equal(obs[i], expected)
            assert (rewards[i], terms[i], truncs[i]) == (reward, term, trunc)
            done[i] = term or trunc
            episodes_ended += done[i]
    assert episodes_ended >= 3
    envs.close()


def test_a_vector_of_no_envs_is_an_input_error() -> None:
    with pytest.raises(InputError, match="num_envs"):
        vector_create_nav(0)
