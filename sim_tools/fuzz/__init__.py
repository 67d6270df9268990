"""Mutation fuzzer over every input format (``make fuzz``; ``python -m sim_tools.fuzz --help``).

Each registered simulator's adapter brings its targets and seeds (its ``fuzz`` part: see
:mod:`sim_tools.fuzz.targets`); the bag, replay, world-parameter and special-path targets are the
fuzzer's own. Seeds are the shipped files in ``config/`` plus small generated bitmaps, meshes and
bags (written by the project's own bag writer); inputs are text, YAML-tree and byte mutations of
them. Each input must either load — and then the model builds and steps with finite state — or
raise InputError. Anything else is a defect; a worker killed by a signal (segfault) is a crash and
is counted, its input rebuilt and saved. :class:`~sim_tools.fuzz.campaign.Campaign` runs the workers.
"""
