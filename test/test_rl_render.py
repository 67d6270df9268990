"""The learning envs' frames show what a user needs to see (the robot's body and heading, the goal
region, the sensors' rays, bumpers and collisions) and ``render_mode="human"`` shows them in a
window on a real (virtual) X display, where PettingZoo's own ``render_test`` runs."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
from collections.abc import Iterator

import numpy as np
import pytest

from sim_runtime.errors import InputError
from sim_tools.rl import frames
from sim_tools.rl.create_cover import CreateCoverEnv
from sim_tools.rl.create_nav import CreateNavEnv
from sim_tools.rl.simrobot_parallel import SimrobotParallelEnv

START, GOAL = (-1.5, -1.0, 0.0), (0.5, 1.0)


def _at(env: CreateNavEnv, frame: np.ndarray, x: float, y: float) -> tuple[int, ...]:
    assert env._view is not None
    col, row = env._view.px(x, y)
    return tuple(int(v) for v in frame[int(round(row)), int(round(col))])


def test_a_create_frame_shows_the_body_its_heading_the_goal_region_and_the_lidar_beams():
    env = CreateNavEnv(render_mode="rgb_array", start=START, goal=GOAL, sensors=("lidar", "bump", "goal"))
    env.reset(seed=0)
    frame = env.render()
    assert frame is not None and frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    r = env.model.RADIUS if env.model is not None else 0.0
    assert _at(env, frame, START[0], START[1] + 0.5 * r) == frames.BODY  # the body, off its heading line
    assert _at(env, frame, START[0] + 0.6 * r, START[1]) == frames.EDGE  # the heading line, along +x
    assert _at(env, frame, START[0] - 0.6 * r, START[1]) == frames.BODY  # none behind
    assert _at(env, frame, GOAL[0], GOAL[1]) == frames.GOAL_FILL
    rays = np.all(frame == frames.RAY, axis=2) | np.all(frame == frames.RAY_NONE, axis=2)
    assert rays.sum() > 500  # 24 beams


def test_a_create_frame_shows_a_collision_as_a_red_body_and_a_pressed_bumper_in_red():
    env = CreateCoverEnv(render_mode="rgb_array", start=(-1.75 + 0.01, 0.0, np.pi), sensors=("bump",))
    env.reset(seed=0)
    for _ in range(20):
        _obs, _r, terminated, _t, info = env.step(np.array([0.3, 0.0], dtype=np.float32))
        if terminated:
            break
    assert info["collided"] and info["bumped"]
    frame = env.render()
    assert frame is not None
    r = env.model.RADIUS if env.model is not None else 0.0
    x, y, _theta = env.model.pose.tolist() if env.model is not None else (0.0, 0.0, 0.0)
    assert _at(env, frame, x, y + 0.5 * r) == frames.BODY_HIT
    assert np.all(frame == frames.BUMPER, axis=2).sum() > 20  # the front rim


def test_a_simrobot_frame_shows_each_robot_in_its_colour():
    env = SimrobotParallelEnv(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame is not None and env._view is not None
    for i, (x, y, _heading) in enumerate(env.world.poses().tolist()):
        col, row = env._view.px(x, y)
        patch = frame[int(row) - 2 : int(row) + 3, int(col) - 2 : int(col) + 3].reshape(-1, 3)
        color = np.array([int(255 * c) for c in env.world.colors[i]])
        assert (np.abs(patch.astype(int) - color).sum(axis=1) == 0).any(), env.world.names[i]


def test_without_a_display_human_rendering_is_refused_with_the_reason(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    for make in (CreateNavEnv, SimrobotParallelEnv):
        with pytest.raises(InputError, match="needs a display"):
            make(render_mode="human")


@pytest.fixture(scope="module")
def display() -> Iterator[str]:
    """A virtual X display (Debian's xvfb; .ci/run installs it)."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb not installed (.ci/run installs xvfb)")
    # Xvfb picks a free display itself and writes its number here: a fixed or guessed one may be
    # another run's (parallel workers, other users of the machine).
    read, write = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        pass_fds=(write,),
    )
    os.close(write)
    try:
        ready, _, _ = select.select([read], [], [], 30.0)
        number = os.read(read, 64).decode().strip() if ready else ""
        assert number, "Xvfb exited" if server.poll() is not None else "Xvfb did not start in 30 s"
        yield f":{number}"
    finally:
        os.close(read)
        server.terminate()
        server.wait(10)


def test_human_rendering_shows_the_create_frames_in_a_window(display, monkeypatch):
    monkeypatch.setenv("DISPLAY", display)
    env = CreateNavEnv(render_mode="human", start=START, goal=GOAL)
    env.reset(seed=0)  # the first frame: the window opens
    for _ in range(3):
        env.step(np.array([0.3, 0.2], dtype=np.float32))
    assert env.render() is None
    window = env._window
    assert window is not None and window._root is not None
    assert window._root.winfo_viewable()
    env.close()
    assert env._window is None


def test_pettingzoos_render_test_passes_on_the_simrobot_env(display, monkeypatch):
    from pettingzoo.test import render_test
    from pettingzoo.utils.conversions import parallel_to_aec

    monkeypatch.setenv("DISPLAY", display)
    render_test(lambda render_mode=None: parallel_to_aec(SimrobotParallelEnv(render_mode=render_mode, max_steps=20)))
