"""CreateModel.lidar(beams): the chosen beams alone, exactly as picked from the whole scan."""

from __future__ import annotations

import numpy as np
import pytest

from create_sim.configfile import load_config
from create_sim.mapfile import load_map
from create_sim.model import CreateModel
from sim_runtime.paths import config_path


@pytest.mark.parametrize("config", [None, "create/example_config.txt"])
def test_reading_chosen_beams_gives_those_beams_of_the_full_scan_and_the_same_noise_stream_after(config) -> None:
    noise = load_config(config_path(config)) if config else None
    floor = load_map(config_path("create/example.map"))
    whole, chosen = (CreateModel(floor, noise, np.random.default_rng(3), pose=(-1.5, -1.0, 0.0)) for _ in range(2))
    beams = np.array([0, 7, 340, 341, 680, 7])  # any order, repeats allowed
    rng = np.random.default_rng(1)
    for _ in range(300):
        v, w = rng.uniform(-0.5, 0.5), rng.uniform(-2.0, 2.0)
        for model in (whole, chosen):
            model.set_velocity(v, w)
            model.step(0.01)
        part = chosen.lidar(beams)
        assert part.dtype == np.float32 and np.array_equal(part, whole.lidar()[beams])
        assert np.array_equal(chosen.sonar(), whole.sonar())  # the noise stream advanced alike
    assert np.isfinite(part).any() and np.array_equal(chosen.pose, whole.pose)
