"""The classroom: one JupyterHub for a course (``robot_sims classroom ...``, docs/classroom.md).

Subcommands are declared in :mod:`sim_tools.classroom.cli`; each lives in its own module.
"""
