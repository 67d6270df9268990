"""SIMROBOT algorithm m-files as a ``robot_sims batch`` controller (an in-process model controller).

A sweep's controller entry::

    controllers:
      - {name: mine, use: "sim_tools.matlab.simrobot_batch:algorithm", parameters: {algorithm: mine.m}}

runs ``mine.m`` (``function new = mine(simrobot, matrix, step)``; a path absolute or relative to
the current folder) on every robot of the episode's world, once per robot before each step, in
one Octave session per episode (:class:`simrobot_sim.matlab_alg.OctaveAlgorithms`): episodes stay
deterministic. A robot whose algorithm fails stops; the failure is printed on stderr.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sim_runtime.errors import InputError
from simrobot_sim.matlab_alg import OctaveAlgorithms
from simrobot_sim.model import SimrobotWorld


def _report(line: str) -> None:
    print(f"simrobot_batch: {line}", file=sys.stderr)


def algorithm(model: SimrobotWorld, params: dict[str, Any], seed: int) -> Callable[[SimrobotWorld, float], None]:
    """The batch model-controller form: ``params['algorithm']`` (an m-file) drives every robot."""
    path = params.get("algorithm")
    if not isinstance(path, str) or not path.endswith(".m"):
        raise InputError(f"parameter 'algorithm': the path of an algorithm m-file (e.g. alg2.m), got {path!r}")
    algorithms = OctaveAlgorithms(model, dict.fromkeys(range(len(model.names)), Path(path)), report=_report)

    def control(world: SimrobotWorld, t: float) -> None:
        algorithms.run()

    control.algorithms = algorithms  # type: ignore[attr-defined]  # its session ends with it
    return control
