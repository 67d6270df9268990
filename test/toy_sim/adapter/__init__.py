"""The toy simulator as the tools see it: one module per tool (see :mod:`sim_tools.adapters`).

Registered for a test with ``ROBOT_SIMS_SIMULATORS="toy=toy_sim.adapter"`` (``test/`` on the path)."""
