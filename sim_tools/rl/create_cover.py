"""``robot_sims/CreateCover-v0``: cover as much floor as possible without bumping.

:class:`~sim_tools.rl.create_nav.CreateNavEnv`'s world, actions, sensors (but no ``goal``),
random starts and rendering. The floor is counted as ``robot_sims batch``'s
``create_area_covered_m2`` counts it: 5 cm squares whose centre the body covered, here sampled
once per env step.

- **Reward** per step: ``100 × m² newly covered − 0.01``; a bump adds ``-10`` and terminates;
  ``max_steps`` steps truncate (there is no goal: covering never terminates).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from create_sim.model import CreateModel
from sim_runtime.errors import InputError
from sim_tools.adapters.create.world import COVERAGE_CELL_M
from sim_tools.rl.create_nav import BUMP_PENALTY, STEP_COST, TRACK_COLOR, CreateNavEnv

AREA_REWARD = 100.0  # per m² newly covered (one 5 cm square: 0.25)


def disc_cells(radius_m: float, cell_m: float) -> np.ndarray:
    """(k, 2) cell offsets whose centre is within ``radius_m`` of a cell's centre."""
    reach = int(math.ceil(radius_m / cell_m)) + 1
    di, dj = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1), indexing="ij")
    inside = (np.hypot(di, dj) * cell_m <= radius_m).ravel()
    return np.column_stack([di.ravel()[inside], dj.ravel()[inside]])


class CreateCoverEnv(CreateNavEnv):
    """Cover the floor without bumping (see the module's docstring)."""

    def __init__(self, *args: Any, sensors: Sequence[str] = ("lidar", "bump"), **kwargs: Any) -> None:
        if "goal" in sensors:
            raise InputError("sensors: CreateCover has no goal (choose from lidar, sonar, bump, cliff)")
        super().__init__(*args, sensors=sensors, **kwargs)
        self._disc = disc_cells(CreateModel.RADIUS, COVERAGE_CELL_M)
        self.covered: set[tuple[int, int]] = set()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        obs, _info = super().reset(seed=seed, options=options)
        self.covered = set()
        self._cover()
        return obs, self._cover_info(False)

    def step(self, action: np.ndarray):
        model = self._advance(action)
        obs = self._observe()
        reward = AREA_REWARD * self._cover() - STEP_COST
        bumped = any(model.bumps())
        if bumped:
            reward -= BUMP_PENALTY
        truncated = self.steps >= self.max_steps and not bumped
        return obs, float(reward), bumped, truncated, self._cover_info(bumped)

    def _cover(self) -> float:
        """Add the cells under the body now; the area newly covered (m²)."""
        x, y, _ = self._model().pose
        here = np.floor(np.array([x, y]) / COVERAGE_CELL_M).astype(np.int64)
        before = len(self.covered)
        self.covered.update(map(tuple, (self._disc + here).tolist()))
        return (len(self.covered) - before) * COVERAGE_CELL_M**2

    def _drawn(self) -> tuple[dict[str, np.ndarray], dict[str, tuple[float, float, float]]]:
        return {"create": np.array(self.track)}, {"create": TRACK_COLOR}

    def _cover_info(self, bumped: bool) -> dict[str, Any]:
        return {
            "pose": self._model().pose,
            "area_covered_m2": len(self.covered) * COVERAGE_CELL_M**2,
            "bumped": bumped,
        }
