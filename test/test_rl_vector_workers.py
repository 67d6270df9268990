"""The vector Create env on several worker processes: the same episodes as in one process."""

from __future__ import annotations

import signal

import gymnasium
import numpy as np
import pytest

import sim_tools.rl  # noqa: F401 (registers the ids)
from sim_runtime.errors import InputError
from sim_tools.rl.vector_create import vector_create_nav

SETTINGS = {"sensors": ("lidar", "sonar", "bump", "goal"), "max_steps": 12}


def _play(envs, steps: int) -> list[tuple]:
    rng = np.random.default_rng(5)
    played = [envs.reset(seed=21)]
    for _ in range(steps):
        actions = rng.uniform(envs.single_action_space.low, envs.single_action_space.high, (envs.num_envs, 2))
        played.append(envs.step(actions.astype(np.float32)))
    envs.close()
    return played


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return np.array_equal(a, b)


def test_two_and_three_workers_play_exactly_the_episodes_of_one_process_through_autoresets() -> None:
    one = _play(vector_create_nav(5, **SETTINGS), 30)  # past max_steps: every sub-env resets
    assert any(step[3].any() for step in one[1:])  # truncations happened
    for workers in (2, 3):
        envs = vector_create_nav(5, workers=workers, **SETTINGS)
        assert envs.workers == workers and len(envs.envs) == {2: 3, 3: 2}[workers]  # this process: the first batch
        assert all(_same(x, y) for x, y in zip(one, _play(envs, 30), strict=True))


def test_gymnasium_make_vec_passes_workers_and_more_workers_than_envs_are_as_many_as_envs() -> None:
    envs = gymnasium.make_vec("robot_sims/CreateNav-v0", num_envs=2, workers=4, sensors=("goal",))
    assert envs.unwrapped.workers == 2
    obs, infos = envs.reset(seed=0)
    assert obs.shape == (2, 2) and infos["_pose"].all() and infos["pose"].shape == (2, 3)
    envs.close()


def test_an_error_in_a_worker_process_is_raised_here_and_close_ends_the_workers() -> None:
    envs = vector_create_nav(2, workers=2, **SETTINGS)
    envs.reset(seed=0)
    workers = list(envs._processes)
    actions = np.zeros((2, 2), dtype=np.float32)
    actions[1] = np.nan  # the second sub-env lives in the worker process
    with pytest.raises(ValueError, match="not finite"):
        envs.step(actions)
    assert envs.step(np.zeros((2, 2), dtype=np.float32))[0].shape[0] == 2  # still answering
    envs.close()
    assert workers and not any(process.is_alive() for process in workers)


def test_bad_worker_counts_and_action_rows_are_input_errors() -> None:
    with pytest.raises(InputError, match="workers"):
        vector_create_nav(2, workers=0)
    envs = vector_create_nav(2, **SETTINGS)
    envs.reset(seed=0)
    with pytest.raises(InputError, match="2 rows"):
        envs.step(np.zeros((3, 2), dtype=np.float32))
    envs.close()


def test_a_worker_process_that_dies_is_named_in_an_error_and_close_still_works() -> None:
    envs = vector_create_nav(3, workers=3, **SETTINGS)
    envs.reset(seed=0)
    workers = list(envs._processes)
    workers[1].kill()  # as a crash would end it
    workers[1].join()
    with pytest.raises(RuntimeError, match="worker process 2 has died"):
        envs.step(np.zeros((3, 2), dtype=np.float32))
    envs.close()
    assert not any(process.is_alive() for process in workers)
    with pytest.raises(RuntimeError, match="after close"):
        envs.step(np.zeros((3, 2), dtype=np.float32))


def test_ctrl_c_in_the_middle_of_a_step_closes_the_workers_rather_than_leave_their_replies_unread(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    envs = vector_create_nav(2, workers=2, **SETTINGS)
    envs.reset(seed=0)
    workers = list(envs._processes)

    def interrupted(_actions: np.ndarray) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(envs._local, "step", interrupted)
    with pytest.raises(KeyboardInterrupt):
        envs.step(np.zeros((2, 2), dtype=np.float32))
    assert envs.closed and not any(process.is_alive() for process in workers)


def test_a_worker_ends_on_sigterm_even_when_the_program_it_was_forked_from_catches_sigterm() -> None:
    caught = signal.signal(signal.SIGTERM, lambda *_: None)  # as rclpy and our executables do
    try:
        envs = vector_create_nav(2, workers=2, **SETTINGS)
    finally:
        signal.signal(signal.SIGTERM, caught)
    try:
        envs.reset(seed=0)  # the worker is serving (a signal before it set its own would find the parent's)
        worker = envs._processes[0]
        worker.terminate()  # what close() does to a worker that does not finish in time
        worker.join(10.0)
        assert worker.exitcode == -signal.SIGTERM
    finally:
        envs.close()  # a worker that outlived SIGTERM still ends on "close"


def _play_then_home(envs, steps: int, home_at: int) -> list[tuple]:
    """As _play, the workers' envs taken into this process after ``home_at`` steps."""
    rng = np.random.default_rng(5)
    played = [envs.reset(seed=21)]
    for k in range(steps):
        if k == home_at:
            envs._come_home()
            assert envs.workers == 1 and len(envs.envs) == envs.num_envs and not envs._processes
        actions = rng.uniform(envs.single_action_space.low, envs.single_action_space.high, (envs.num_envs, 2))
        played.append(envs.step(actions.astype(np.float32)))
    envs.close()
    return played


def test_workers_envs_taken_into_this_process_mid_episode_play_on_exactly_as_before() -> None:
    one = _play(vector_create_nav(5, **SETTINGS), 30)
    moved = _play_then_home(vector_create_nav(5, workers=3, fallback=False, **SETTINGS), 30, home_at=7)
    assert all(_same(x, y) for x, y in zip(one, moved, strict=True))


def test_workers_measure_themselves_and_whatever_they_decide_the_episodes_are_those_of_one_process() -> None:
    steps = 60  # past the first measurement (5 + 40 steps)
    one = _play(vector_create_nav(4, **SETTINGS), steps)
    envs = vector_create_nav(4, workers=2, **SETTINGS)
    played = _play(envs, steps)
    assert (envs.fell_back is None) == (envs.workers == 2) == envs.fallback, envs.fell_back
    assert all(_same(x, y) for x, y in zip(one, played, strict=True))
