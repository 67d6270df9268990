"""Static checks, for mypy only: every built-in adapter's ``world`` part is a :class:`WorldAdapter`.

The tools reach a ``world`` part through the registry (:func:`~sim_tools.adapters.contract.world_part`),
a module found by name at run time, which no type checker can follow. Here each built-in one is
assigned to the Protocol, so ``make lint`` fails when a member is missing or has the wrong type
(mypy checks a module against a Protocol member by member). Nothing imports this module.
"""

from __future__ import annotations

from sim_tools.adapters.arm import world as arm_world
from sim_tools.adapters.contract import WorldAdapter
from sim_tools.adapters.create import world as create_world
from sim_tools.adapters.simrobot import world as simrobot_world

CREATE: WorldAdapter = create_world
SIMROBOT: WorldAdapter = simrobot_world
ARM: WorldAdapter = arm_world
