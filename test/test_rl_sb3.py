"""A Stable-Baselines3 policy runs where ours run: a tiny PPO run on CreateNav, exported as a policy
file (sim_tools.rl.sb3), acts as SB3's deterministic predict does, in the env and as
``robot_sims policy_controller`` in ``robot_sims batch``. Needs the ``sb3`` extra (torch): CI
installs it and runs this file in ``make test-sb3``."""

from __future__ import annotations

import subprocess
import sys

import gymnasium
import numpy as np
import pytest

sb3 = pytest.importorskip("stable_baselines3", reason="the sb3 extra (pip install -e '.[sb3]'; make test-sb3)")

import sim_tools.rl  # noqa: E402, F401 (registers the ids)
from sim_tools.rl.kernels import physical_action  # noqa: E402
from sim_tools.rl.policy import load_policy  # noqa: E402
from sim_tools.rl.sb3 import export_sb3  # noqa: E402

ENV_ID = "robot_sims/CreateNav-v0"
OPTIONS = {"sensors": ["lidar", "bump", "goal"], "lidar_beams": 8, "start": [-1.5, -1.0, 0.0], "goal": [-0.5, -1.0]}


def _tiny_ppo(normalize: bool):
    env = gymnasium.make(ENV_ID, max_episode_steps=40, normalize_actions=normalize, **OPTIONS)
    model = sb3.PPO(
        "MlpPolicy", env, n_steps=64, batch_size=32, n_epochs=1, seed=0, device="cpu", policy_kwargs={"net_arch": [16]}
    )
    return model.learn(128), env


def _observations(env: gymnasium.Env, n: int) -> list[np.ndarray]:
    """Observations of random driving (both directions, near walls and not)."""
    obs, _ = env.reset(seed=1)
    env.action_space.seed(1)
    seen = [obs]
    for _ in range(n):
        obs, _r, terminated, truncated, _i = env.step(env.action_space.sample())
        seen.append(obs)
        if terminated or truncated:
            obs, _ = env.reset()
    return seen


@pytest.mark.parametrize("normalize", [True, False])
def test_an_exported_ppo_policy_acts_as_sb3s_deterministic_predict_in_the_robots_units(tmp_path, normalize):
    model, env = _tiny_ppo(normalize)
    path = export_sb3(model, tmp_path / "ppo.npz", ENV_ID, normalize_actions=normalize, **OPTIONS)
    policy = load_policy(path)
    assert policy.env_id == ENV_ID and "normalize_actions" not in policy.env_kwargs
    physical = env.unwrapped.physical_action_space
    for obs in _observations(env, 60):
        predicted, _state = model.predict(obs, deterministic=True)
        expected = physical_action(predicted, physical.low, physical.high) if normalize else predicted
        assert np.allclose(policy.act(obs), expected, atol=1e-5)


def test_an_sb3_zip_exported_from_the_command_line_runs_as_policy_controller_in_a_batch(tmp_path):
    from test_batch import batch, rows, write_sweep

    model, _env = _tiny_ppo(True)
    model.save(tmp_path / "ppo.zip")
    options = '{"normalize_actions": true, "sensors": ["lidar", "bump", "goal"], "lidar_beams": 8}'
    files = [str(tmp_path / "ppo.zip"), str(tmp_path / "ppo.npz")]
    done = subprocess.run(
        [sys.executable, "-m", "sim_tools.rl.sb3", *files, "--env", ENV_ID, "--env-kwargs", options],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    sweep = write_sweep(
        tmp_path,
        "sweep.yaml",
        """
        worlds: [{map: create/example.map}]
        controllers:
          - {name: ppo, use: policy_controller, parameters: {policy: ppo.npz, goal: [-0.5, -1.0]}}
        poses: [[-1.5, -1.0, 0.0]]
        duration_s: 3
        metrics: [distance_m, collisions]
        """,
    )
    ran = batch(str(sweep), "--workers", "1", "--out", "out", "--no-plots", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    (row,) = rows(tmp_path / "out" / "episodes.csv")
    assert row["status"] == "ok", row["error"]
    assert float(row["distance_m"]) > 0.0  # the policy drove the world


def test_a_file_that_is_no_sb3_model_is_refused_with_a_reason(tmp_path):
    (tmp_path / "junk.zip").write_bytes(b"not a zip")
    done = subprocess.run(
        [sys.executable, "-m", "sim_tools.rl.sb3", str(tmp_path / "junk.zip"), str(tmp_path / "out.npz")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2 and "error:" in done.stderr, done.stderr
    assert not (tmp_path / "out.npz").exists()
