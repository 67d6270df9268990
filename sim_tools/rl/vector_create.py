"""Many independent Create navigation worlds stepped together, as one Gymnasium vector env.

Each sub-environment is a :class:`~sim_tools.rl.create_nav.CreateNavEnv` (its own map, model and
noise stream); :func:`vector_create_nav` steps them one after the other in this process
(Gymnasium's ``SyncVectorEnv``: bit-identical to running the envs one by one, see
test_rl_vector_create). ``reset(seed=s)`` seeds sub-env ``i`` with ``s + i``; an episode that
ends is reset on the next step (Gymnasium's default ``next_step`` autoreset).
"""

from __future__ import annotations

import functools
from typing import Any

from gymnasium.vector import AutoresetMode, SyncVectorEnv

from sim_runtime.errors import InputError
from sim_tools.rl.create_nav import CreateNavEnv


def vector_create_nav(num_envs: int, **env_kwargs: Any) -> SyncVectorEnv:
    """``num_envs`` Create navigation envs built with ``env_kwargs`` (``CreateNavEnv``'s
    arguments: map, config, sensors, start, goal, …), stepped together."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
        raise InputError(f"num_envs: expected an integer >= 1, got {num_envs!r}")
    make = functools.partial(CreateNavEnv, **env_kwargs)
    return SyncVectorEnv([make] * num_envs, autoreset_mode=AutoresetMode.NEXT_STEP)
