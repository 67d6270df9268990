"""The SIMROBOT PettingZoo environment: PettingZoo's own checkers, seeding, the world's physics."""

from __future__ import annotations

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from sim_tools.rl.simrobot_parallel import SimrobotParallelEnv
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import load_world

LASER_WORLD = """\
map: {map}
resolution: 0.01
dt: 1.0
robots:
  - name: scout
    position: [1.3, 1.55]
    heading: 90
    sensors:
      - {{name: front, type: ultrasonic, position: [0.05, 0], axis: 0, beamwidth: 60, range: 0.30, rays: 30}}
      - {{name: scan, type: laser, position: [0, 0], axis: 0, beamwidth: 180, range: 1.0, rays: 9}}
  - name: other
    position: [4.0, 2.0]
    heading: 180
    sensors:
      - {{name: scan, type: laser, position: [0, 0], axis: 0, beamwidth: 90, range: 0.5, rays: 5}}
"""


@pytest.fixture(scope="module")
def laser_world(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("rl") / "laser.yaml"
    path.write_text(LASER_WORLD.format(map=config_path("simrobot/demo_map.png")))
    return str(path)


def play(env: SimrobotParallelEnv, actions: list[dict[str, np.ndarray]], **reset: object) -> list[tuple]:
    """Every step's (observations, rewards, terminations, truncations) for the actions given to
    the live agents, until the actions run out or no agent is left."""
    obs, _ = env.reset(**reset)  # type: ignore[arg-type]
    out: list[tuple] = [(obs,)]
    for step in actions:
        if not env.agents:
            break
        obs, rewards, terms, truncs, _ = env.step({a: step[a] for a in env.agents})
        out.append((obs, rewards, terms, truncs))
    return out


def random_actions(env: SimrobotParallelEnv, steps: int, seed: int) -> list[dict[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    limit = env.max_wheel_speed
    return [{a: rng.uniform(-limit, limit, 2).astype(np.float32) for a in env.possible_agents} for _ in range(steps)]


def test_the_demo_world_passes_pettingzoos_parallel_api_test() -> None:
    parallel_api_test(SimrobotParallelEnv(), num_cycles=300)


def test_a_world_with_lasers_and_random_starts_passes_pettingzoos_parallel_api_test(laser_world: str) -> None:
    parallel_api_test(SimrobotParallelEnv(laser_world, random_start=True), num_cycles=300)


def test_the_environment_passes_pettingzoos_parallel_seed_test_with_random_starts() -> None:
    parallel_seed_test(lambda: SimrobotParallelEnv(random_start=True), num_cycles=300)


def test_the_same_seed_gives_the_same_episode_and_another_seed_other_start_poses() -> None:
    env = SimrobotParallelEnv(random_start=True, max_steps=200)
    actions = random_actions(env, 200, seed=1)
    first = play(env, actions, seed=7)
    poses = env.world.start_poses()
    again = play(SimrobotParallelEnv(random_start=True, max_steps=200), actions, seed=7)
    assert len(first) == len(again) > 1
    for a, b in zip(first, again, strict=True):
        for da, db in zip(a, b, strict=True):
            assert da.keys() == db.keys()
            assert all(np.array_equal(da[k], db[k]) for k in da)
    env.reset(seed=8)
    assert not np.array_equal(env.world.start_poses(), poses)


def test_an_action_sequence_gives_the_same_observations_as_stepping_the_world_directly(laser_world: str) -> None:
    env = SimrobotParallelEnv(laser_world, max_steps=400)
    actions = random_actions(env, 400, seed=2)
    # forward most of the time, so the robots reach walls and crash
    for step in actions:
        for a in step:
            step[a] = np.abs(step[a]) * np.float32(0.5) + np.float32(0.5)
    episode = play(env, actions)
    world = SimrobotWorld(load_world(laser_world), threads=1)

    def direct_observation(robot: str) -> np.ndarray:
        values = []
        for s in world.sensors:
            if world.names[s.robot] == robot:
                reading = world.read(robot, s.name)[0]
                values.append(np.minimum(np.atleast_1d(reading) / s.range, 1.0))
        return np.concatenate(values).astype(np.float32)

    alive, crashes = set(world.names), 0
    for k, record in enumerate(episode):
        obs = record[0]
        assert all(np.array_equal(obs[a], direct_observation(a)) for a in obs), f"step {k}"
        if k > 0:
            alive -= {a for a in obs if record[2][a] or record[3][a]}
        if k < len(episode) - 1:
            for a in alive:
                world.set_wheel_speeds(world.index[a], *map(float, actions[k][a]))
            crashes += len(world.step())
    assert crashes >= 1  # the episode covered a crash


def test_a_crash_ends_only_that_agent_with_the_crash_penalty() -> None:
    env = SimrobotParallelEnv(max_steps=1000)
    env.reset()
    crashed = None
    while crashed is None:
        _, rewards, terms, truncs, _ = env.step({a: np.array([1.0, 1.0], dtype=np.float32) for a in env.agents})
        assert not any(truncs.values())
        crashed = next((a for a, t in terms.items() if t), None)
    assert rewards[crashed] == -env.crash_penalty
    assert crashed not in env.agents
    assert all(rewards[a] == pytest.approx(1.0) for a in env.agents)  # full speed straight on


def test_every_agent_is_truncated_at_the_step_limit() -> None:
    env = SimrobotParallelEnv(max_steps=3)
    env.reset()
    for _ in range(3):
        _, _, terms, truncs, _ = env.step({a: np.zeros(2, dtype=np.float32) for a in env.agents})
    assert all(truncs.values()) and not any(terms.values())
    assert env.agents == []


def test_rgb_array_rendering_draws_the_robots_and_their_tracks_and_none_draws_nothing() -> None:
    env = SimrobotParallelEnv(render_mode="rgb_array", max_steps=20)
    env.reset()
    first = env.render()
    for _ in range(20):
        env.step({a: np.array([1.0, 0.5], dtype=np.float32) for a in env.agents})
    frame = env.render()
    assert first is not None and frame is not None
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert not np.array_equal(first, frame)  # the tracks grew (and the step in the title)
    assert SimrobotParallelEnv().render() is None


def test_unsupported_settings_raise_input_errors() -> None:
    with pytest.raises(InputError, match="render_mode"):
        SimrobotParallelEnv(render_mode="ansi")
    with pytest.raises(InputError, match="max_wheel_speed"):
        SimrobotParallelEnv(max_wheel_speed=float("nan"))
    with pytest.raises(InputError, match="world_file"):
        SimrobotParallelEnv("no/such/world.yaml")
