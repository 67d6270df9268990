"""The simulator registry: what each simulator gives the tools, found by name.

A simulator's adapter is a package with one module per tool that uses it (``world``: batch,
demo, warm-up; ``fuzz``: the fuzzer's targets; ``rerun``: how its messages are drawn in
Rerun). The tools (batch, fuzz, Rerun conversion, demo, warm-up) loop over :func:`simulators`
and import a part with :meth:`Simulator.part`; none of them names a simulator. What each part
holds is written once: the ``world`` part in :mod:`sim_tools.adapters.contract`, the ``fuzz``
part in :mod:`sim_tools.fuzz.targets`, the ``rerun`` part in :mod:`sim_tools.rerun_view.logger`;
``docs/architecture.md`` sums them up.

The three simulators of this package are listed here. Another one (a course's own, or the
point robot of the tests) is added without touching the tools:

- installed: an entry point in the group ``robot_sims.simulators``, ``name = package.of.adapter``;
- for one process and its children: ``ROBOT_SIMS_SIMULATORS="name=package.of.adapter[,...]"``.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from dataclasses import dataclass
from functools import cache
from importlib.metadata import entry_points
from types import ModuleType

#: This package's simulators, in the order the tools list them.
BUILT_IN: dict[str, str] = {
    "create": "sim_tools.adapters.create",
    "simrobot": "sim_tools.adapters.simrobot",
    "arm": "sim_tools.adapters.arm",
}

ENTRY_POINT_GROUP = "robot_sims.simulators"
ENVIRONMENT_VARIABLE = "ROBOT_SIMS_SIMULATORS"


@dataclass(frozen=True)
class Simulator:
    """One registry entry: a simulator's name and the package of its adapter."""

    name: str
    package: str

    def part(self, tool: str) -> ModuleType:
        """The adapter's module for ``tool`` (``"world"``, ``"fuzz"``, ``"rerun"``), imported now."""
        return importlib.import_module(f"{self.package}.{tool}")

    def has_part(self, tool: str) -> bool:
        """Whether the adapter gives ``tool`` anything (a simulator may leave a tool out)."""
        return importlib.util.find_spec(f"{self.package}.{tool}") is not None


def _from_environment(value: str) -> dict[str, str]:
    """``"a=pkg.a,b=pkg.b"`` → ``{"a": "pkg.a", "b": "pkg.b"}``; a malformed item is an error."""
    found: dict[str, str] = {}
    for item in filter(None, (part.strip() for part in value.split(","))):
        name, sep, package = item.partition("=")
        if not sep or not name.strip() or not package.strip():
            raise ValueError(f"{ENVIRONMENT_VARIABLE}: '{item}' is not name=package.of.adapter")
        found[name.strip()] = package.strip()
    return found


@cache
def _registry(environment: str) -> dict[str, Simulator]:
    packages = dict(BUILT_IN)
    packages.update({ep.name: ep.value for ep in entry_points(group=ENTRY_POINT_GROUP)})
    packages.update(_from_environment(environment))
    return {name: Simulator(name, package) for name, package in packages.items()}


def simulators() -> dict[str, Simulator]:
    """Every registered simulator by name: the built-in ones, then installed and environment ones."""
    return _registry(os.environ.get(ENVIRONMENT_VARIABLE, ""))


def simulator(name: str) -> Simulator:
    """The simulator called ``name``; an unknown name raises KeyError listing the known ones."""
    known = simulators()
    if name not in known:
        raise KeyError(f"unknown simulator '{name}' (known: {', '.join(known)})")
    return known[name]
