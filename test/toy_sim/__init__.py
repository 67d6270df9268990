"""A test-only fourth simulator: a point robot on an empty plane.

It exists to prove that the tools (batch, fuzz, Rerun conversion) work from a registry entry
alone (``ROBOT_SIMS_SIMULATORS="toy=toy_sim.adapter"`` with ``test/`` on ``PYTHONPATH``): nothing
in ``sim_tools`` names it.

- :mod:`toy_sim.model`: the pure model (numpy; pose x, y, theta; ``cmd_vel`` integrates);
- :mod:`toy_sim.world_node`: its world node (``toy_world``), publishing ``odom`` and taking ``cmd_vel``;
- :mod:`toy_sim.adapter`: what the tools need from it, one module per tool.
"""
