"""``robot_sims/CreateCover-v0``: cover as much floor as possible without collisions.

:class:`~sim_tools.rl.create_nav.CreateNavEnv`'s world, actions, sensors (but no ``goal``),
random starts and rendering. The floor is counted as ``robot_sims batch``'s
``create_area_covered_m2`` counts it: 5 cm squares whose centre the body covered, here sampled
once per env step.

- **Reward** per step: ``100 × m² newly covered − 0.01``; a collision (a wall touching the body
  from any side, as CreateNav counts it) adds ``-10`` and terminates;
  ``max_steps`` steps truncate (there is no goal: covering never terminates).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from create_sim.model import CreateModel
from sim_runtime.errors import InputError
from sim_tools.adapters.create.world import COVERAGE_CELL_M, COVERAGE_KEY_SPAN, coverage_disc
from sim_tools.rl.create_nav import COLLISION_PENALTY, STEP_COST, CreateNavEnv

AREA_REWARD = 100.0  # per m² newly covered (one 5 cm square: 0.25)


class CreateCoverEnv(CreateNavEnv):
    """Cover the floor without touching a wall (see the module's docstring)."""

    def __init__(self, *args: Any, sensors: Sequence[str] = ("lidar", "bump"), **kwargs: Any) -> None:
        if "goal" in sensors:
            raise InputError("sensors: CreateCover has no goal (choose from lidar, sonar, bump, cliff)")
        super().__init__(*args, sensors=sensors, **kwargs)
        self._disc = coverage_disc(CreateModel.RADIUS)
        #: The cells covered so far (their keys, as ``create_area_covered_m2`` counts them).
        self.covered: set[int] = set()
        self._last_cell: int | None = None  # the cell the last count was made on

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        obs, _info = super().reset(seed=seed, options=options)
        self.covered = set()
        self._last_cell = None
        self._cover()
        self._show()
        return obs, self._cover_info(False, False)

    def step(self, action: np.ndarray):
        bumps = self._advance(action).bumps()
        obs = self._observe(bumps)
        reward = AREA_REWARD * self._cover() - STEP_COST
        collided = self.collided
        if collided:
            reward -= COLLISION_PENALTY
        truncated = self.steps >= self.max_steps and not collided
        self._show()
        return obs, float(reward), collided, truncated, self._cover_info(bumps[0] or bumps[1], collided)

    def _cover(self) -> float:
        """Add the cells under the body now; the area newly covered (m²)."""
        x, y = self.track[-1]  # where the body is now
        cell = math.floor(x / COVERAGE_CELL_M) * COVERAGE_KEY_SPAN + math.floor(y / COVERAGE_CELL_M)
        if cell == self._last_cell:  # most steps end on the cell they began on: nothing new
            return 0.0
        self._last_cell = cell
        before = len(self.covered)
        self.covered.update((self._disc + cell).tolist())
        return (len(self.covered) - before) * COVERAGE_CELL_M**2

    def _frame_goal(self) -> None:
        return None  # no goal to draw

    def _cover_info(self, bumped: bool, collided: bool) -> dict[str, Any]:
        return {
            "pose": self._pose,
            "area_covered_m2": len(self.covered) * COVERAGE_CELL_M**2,
            "bumped": bumped,
            "collided": collided,
        }
