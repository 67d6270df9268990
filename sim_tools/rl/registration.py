"""The environments' Gymnasium ids: ``gymnasium.make("robot_sims/CreateNav-v0")`` and the rest.

:func:`register_envs` is the ``gymnasium.envs`` entry point in setup.py (Gymnasium releases that
load plugins call it) and runs when :mod:`sim_tools.rl` is imported: Gymnasium 1.x no longer loads
entry points, so there ``import sim_tools.rl`` first, or name the module in the id:
``gymnasium.make("sim_tools.rl:robot_sims/CreateNav-v0")``.

Each id is registered with its episode length as ``max_episode_steps`` (``env.spec`` says it, and
``gymnasium.make`` adds its ``TimeLimit``): through ``gymnasium.make`` that is the one limit
(``gymnasium.make(id, max_episode_steps=N)`` changes it), so the env is made without its own
``max_steps``, and passing ``max_steps`` there is refused with that advice.
"""

from __future__ import annotations

import importlib
from typing import Any

from sim_runtime.errors import InputError

NAMESPACE = "robot_sims"
#: id (without the namespace) → ``module:Class``.
ENVS = {
    "CreateNav-v0": "sim_tools.rl.create_nav:CreateNavEnv",
    "CreateCover-v0": "sim_tools.rl.create_cover:CreateCoverEnv",
    "ArmReach-v0": "sim_tools.rl.arm_reach:ArmReachEnv",
}
#: id → the function of this module that ``gymnasium.make`` calls (:func:`made_by_gymnasium`).
CREATORS = {"CreateNav-v0": "make_create_nav", "CreateCover-v0": "make_create_cover", "ArmReach-v0": "make_arm_reach"}
#: id → its episode length in env steps (each env's ``max_steps`` default).
MAX_EPISODE_STEPS = {"CreateNav-v0": 600, "CreateCover-v0": 600, "ArmReach-v0": 200}
#: id → ``module:function(num_envs, **kwargs)`` that ``gymnasium.make_vec`` uses.
VECTOR_ENVS = {"CreateNav-v0": "sim_tools.rl.vector_create:vector_create_nav"}


def register_envs() -> None:
    """Register every environment of :data:`ENVS` once (again is a no-op, not a warning)."""
    import gymnasium

    for name in ENVS:
        env_id = f"{NAMESPACE}/{name}"
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point=f"{__name__}:{CREATORS[name]}",
                vector_entry_point=VECTOR_ENVS.get(name),
                max_episode_steps=MAX_EPISODE_STEPS[name],
            )


def made_by_gymnasium(name: str, kwargs: dict[str, Any]) -> Any:
    """The env ``name`` (an :data:`ENVS` key) as ``gymnasium.make`` builds it: no limit of its own
    (the ``TimeLimit`` around it truncates), ``max_steps`` refused."""
    if "max_steps" in kwargs:
        raise InputError(
            f"max_steps: through gymnasium.make the episode length is max_episode_steps (Gymnasium's TimeLimit, "
            f"registered {MAX_EPISODE_STEPS[name]}): gymnasium.make('{NAMESPACE}/{name}', "
            f"max_episode_steps={kwargs['max_steps']})"
        )
    module, _, cls = ENVS[name].partition(":")
    return getattr(importlib.import_module(module), cls)(max_steps=None, **kwargs)


def make_create_nav(**kwargs: Any) -> Any:
    return made_by_gymnasium("CreateNav-v0", kwargs)


def make_create_cover(**kwargs: Any) -> Any:
    return made_by_gymnasium("CreateCover-v0", kwargs)


def make_arm_reach(**kwargs: Any) -> Any:
    return made_by_gymnasium("ArmReach-v0", kwargs)
