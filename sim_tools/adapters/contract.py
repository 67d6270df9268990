"""What a simulator's ``world`` part gives batch, demo, warm-up and ``--help`` (:mod:`sim_tools.adapters`).

A ``world`` part is a module (``<adapter package>.world``) with the members of :class:`WorldAdapter`.
It imports its simulator lazily, inside its functions: the driver of a sweep and ``robot_sims
--help`` read the constants without ROS or a model. A member a simulator has nothing for is
``None`` (``random_poses``, ``demo``, ``sample_run``). The tools reach it through the registry:

>>> from sim_tools.adapters import simulator
>>> world = simulator("create").part("world")   # a WorldAdapter

A batch episode (:mod:`sim_tools.batch.episode`) uses it like this: :func:`~WorldAdapter.make_world`
from the sweep's world entry (read by :func:`~WorldAdapter.read_world`), the controller node(s) from
:func:`~WorldAdapter.controller_nodes`, then it steps the world with :meth:`SimWorldNode.step`
(``real_time_factor`` 0; :meth:`SimWorldNode.republish` once when a lockstep world waits for
controllers built after it) and calls the :func:`~WorldAdapter.probe`'s ``sample()`` after every step;
the probe's :class:`EpisodeData` goes to the :data:`~WorldAdapter.METRICS`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np

if TYPE_CHECKING:
    from rclpy.node import Node

    from sim_runtime.world_node import SimWorldNode

#: A start pose: x, y (m), theta (rad).
Pose = tuple[float, float, float]


@dataclass
class EpisodeData:
    """What an episode recorded: ``arrays`` of per-step samples, ``t`` their sim times (s).

    Row 0 is the start, row k the state after step k. Which arrays there are is the simulator's
    (its adapter's ``probe`` docstring says): the Create's ``x, y, theta`` (m, rad), ``bump``,
    ``clearance`` (m); SIMROBOT's ``x, y`` (steps × robots, m), ``crashed``; the arm's ``error``
    (m, flange to the current target), ``target``. ``info`` holds constants (``radius_m``,
    ``names``, ``dt``, ``ik_failures``...); ``params`` and ``seed`` are the episode's.
    """

    t: np.ndarray
    arrays: dict[str, np.ndarray]
    info: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    seed: int = 0


class EntryReader(Protocol):
    """The checks a sweep file's reader offers :func:`WorldAdapter.read_world`; each raises an
    :class:`~sim_runtime.errors.InputError` naming the sweep file and ``where``."""

    def fail(self, where: str, message: str) -> Exception: ...

    def number(self, value: Any, where: str, *, positive: bool = False) -> float: ...

    def listing(self, value: Any, where: str) -> list[Any]: ...

    def file(self, value: Any, where: str) -> str:
        """A path relative to the sweep file, else to the shipped ``config/``, resolved; ``''`` stays."""
        ...


class Probe(Protocol):
    """Samples a world's model after every step (not its topics: the same over any transport)."""

    def sample(self) -> None: ...

    def data(self, params: dict[str, Any], seed: int) -> EpisodeData: ...


#: Builds one controller node of class ``cls`` with the episode's parameters; keyword arguments
#: (``namespace``, ``sensor``...) are passed on when the class takes them.
MakeController = Callable[..., "Node"]
#: Adds nodes (a recorder) to a demo's executor, given the demo's rclpy context.
ExtraNodes = Callable[[Any], Sequence["Node"]]


class WorldAdapter(Protocol):
    """The ``world`` part of a simulator's adapter (every name here is a module member).

    The constants are read-only members (properties to a type checker), so a module's own
    narrower types fit them: a ``dict`` of functions is a ``Mapping`` of callables, a ``demo``
    function is an optional one. :mod:`sim_tools.adapters.checks` checks the built-in ones.
    """

    #: The simulator's name in messages ("Create", "SIMROBOT").
    @property
    def LABEL(self) -> str: ...
    #: The key of a sweep's world entry that says "this simulator" (exactly one per entry).
    @property
    def WORLD_KEY(self) -> str: ...
    #: The entry's other keys this simulator takes → what they are, for "only <LABEL> worlds take ...".
    @property
    def WORLD_OPTIONS(self) -> Mapping[str, str]: ...
    #: The entry's keys that name files → the parser each is checked with before a sweep runs.
    @property
    def WORLD_FILES(self) -> Mapping[str, Callable[[str], Any]]: ...
    #: World parameters the sweep sets itself → the sweep field that says them.
    @property
    def RESERVED(self) -> Mapping[str, str]: ...
    #: Our executables that drive this simulator in a sweep → their node class, ``module:Class``.
    @property
    def CONTROLLERS(self) -> Mapping[str, str]: ...
    #: The world node's name (its logger's).
    @property
    def WORLD_NODE_NAME(self) -> str: ...
    #: Node executables → (``module:Class``, what follows the name in the usage), for ``--help``.
    @property
    def NODE_EXECUTABLES(self) -> Mapping[str, tuple[str, str]]: ...
    #: Whether a controller class runs once per robot in the robot's namespace (and must take **kwargs).
    @property
    def ROBOT_NAMESPACES(self) -> bool: ...
    #: Whether a sweep may give its worlds an m-file controller: a program of this simulator's
    #: MATLAB toolbox (matlab/), run in Octave over the MATLAB bridge.
    @property
    def MFILE_CONTROLLERS(self) -> bool: ...
    #: Built-in metrics: name → ``function(data: EpisodeData, **options)``; those without a
    #: required option are the default set.
    @property
    def METRICS(self) -> Mapping[str, Callable[..., Any]]: ...
    #: What the metrics' type hints cannot say about an option: ``(metric, option)`` → a test and
    #: what it expects (``(lambda v: v > 0, "a radius > 0 m")``).
    @property
    def METRIC_RULES(self) -> Mapping[tuple[str, str], tuple[Callable[[Any], bool], str]]: ...
    #: ``random_poses(world, count, seed, margin_m)``: start poses for a sweep's ``poses: {random: n}``;
    #: None: its episodes start where the world file puts the robots (no ``poses`` field).
    @property
    def random_poses(self) -> Callable[[dict[str, Any], int, int, float], list[Pose]] | None: ...
    #: ``demo(out_dir, extra_nodes)`` → a summary (``make demo``); None: no demo.
    @property
    def demo(self) -> Callable[[Path, ExtraNodes], dict[str, Any]] | None: ...
    #: ``sample_run(folder)`` → a short recorded run (a bag) for warming the bag readers; None: none.
    @property
    def sample_run(self) -> Callable[[Path], Path] | None: ...

    def read_world(self, r: EntryReader, entry: dict[str, Any], where: str) -> dict[str, Any]:
        """The world of a sweep entry (keys checked already): files resolved, options checked."""
        ...

    def make_world(
        self, world: dict[str, Any], pose: Pose | None, overrides: list[Any], **node_kwargs: Any
    ) -> SimWorldNode:
        """The world node; ``overrides`` (rclpy Parameters: the sweep's, ``seed``,
        ``real_time_factor``) come first, then the world's own from ``world`` and ``pose``."""
        ...

    def controller_nodes(
        self, cls: type, world_node: Any, world: dict[str, Any], make: MakeController, **node_kwargs: Any
    ) -> list[Node]:
        """The controller node(s) of class ``cls`` for this world (``make`` builds one;
        ``node_kwargs`` are for a node the adapter builds itself)."""
        ...

    def probe_kwargs(self, cls: type) -> dict[str, str] | None:
        """What to pass ``make`` when a controller is built once, without a world, to learn its
        parameters; None: the class declares none (the adapter builds it from the world)."""
        ...

    def probe(self, world_node: Any, world: dict[str, Any], steps: int) -> Probe:
        """A probe that has sampled the start and has room for ``steps`` more samples."""
        ...

    def warm_up(self) -> None:
        """Compile every numba kernel the world can use, into numba's on-disk cache."""
        ...

    def describe_kwargs(self, executable: str) -> dict[str, Any]:
        """Constructor arguments for the node of ``executable`` in describe mode (``--help``)."""
        ...


def world_part(name: str) -> WorldAdapter:
    """The ``world`` part of the registered simulator ``name``."""
    from sim_tools.adapters import simulator

    # A module found by name at run time: no checker can follow it. The built-in ones are checked
    # against WorldAdapter statically in sim_tools.adapters.checks.
    return cast(WorldAdapter, simulator(name).part("world"))


def world_parts() -> dict[str, WorldAdapter]:
    """The ``world`` part of every registered simulator that has one, in registry order."""
    from sim_tools.adapters import simulators

    return {name: world_part(name) for name, sim in simulators().items() if sim.has_part("world")}
