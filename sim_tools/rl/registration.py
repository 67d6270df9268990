"""The environments' Gymnasium ids: ``gymnasium.make("robot_sims/CreateNav-v0")`` and the rest.

:func:`register_envs` is the ``gymnasium.envs`` entry point in setup.py (Gymnasium releases that
load plugins call it) and runs when :mod:`sim_tools.rl` is imported: Gymnasium 1.x no longer loads
entry points, so there ``import sim_tools.rl`` first, or name the module in the id:
``gymnasium.make("sim_tools.rl:robot_sims/CreateNav-v0")``.
"""

from __future__ import annotations

NAMESPACE = "robot_sims"
#: id (without the namespace) → ``module:Class``.
ENVS = {
    "CreateNav-v0": "sim_tools.rl.create_nav:CreateNavEnv",
    "CreateCover-v0": "sim_tools.rl.create_cover:CreateCoverEnv",
    "ArmReach-v0": "sim_tools.rl.arm_reach:ArmReachEnv",
}
#: id → ``module:function(num_envs, **kwargs)`` that ``gymnasium.make_vec`` uses.
VECTOR_ENVS = {"CreateNav-v0": "sim_tools.rl.vector_create:vector_create_nav"}


def register_envs() -> None:
    """Register every environment of :data:`ENVS` once (again is a no-op, not a warning)."""
    import gymnasium

    for name, entry_point in ENVS.items():
        env_id = f"{NAMESPACE}/{name}"
        if env_id not in gymnasium.registry:
            # The envs truncate themselves (max_steps): no TimeLimit wrapper on top.
            gymnasium.register(id=env_id, entry_point=entry_point, vector_entry_point=VECTOR_ENVS.get(name))
