"""The create simulator as the tools see it: one module per tool (see :mod:`sim_tools.adapters`)."""
