"""Serial arm model: DH kinematics, inverse kinematics and dynamics, meshes (no rclpy).

In the spirit of Robotics Toolbox's ``DHRobot``:

>>> from sim_runtime.paths import config_path
>>> arm = Arm.from_file(config_path("arm/irb120.yaml"))
>>> q = np.array([0.0, 0.3, 0.0, 0.0, 0.5, 0.0])
>>> T = arm.fkine(q)                         # 4x4 world pose of the flange
>>> arm.jacob0(q).shape                      # geometric Jacobian, world frame (v then omega)
(6, 6)
>>> sol = arm.ikine(T)                       # IKResult(q, success, residual, searches)
>>> bool(sol.success) and bool(np.allclose(arm.fkine(sol.q), T, atol=1e-8))
True
>>> tau = arm.rne(q, 0 * q, 0 * q)           # inverse dynamics (Newton-Euler): here gravity only
>>> bool(np.allclose(tau, arm.gravload(q)))
True

Batched variants take (m, n) arrays: ``fkine_batch``, ``jacob0_batch``, ``ikine_batch``,
``rne_batch``. Every kernel is a numba function in :mod:`arm_sim.kinematics`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
import numpy.typing as npt

from arm_sim import kinematics as kin
from arm_sim.robot_config import MeshElement, RobotConfig, load_robot_config
from arm_sim.stl import load_stl
from sim_runtime.errors import InputError

PLACEHOLDER_SIZE = 0.05  # edge (m) of the cube drawn for a mesh that failed to load


@dataclass(frozen=True)
class IKResult:
    """Inverse kinematics outcome: ``q`` is a solution only if ``success``."""

    q: np.ndarray
    success: bool
    residual: float  # norm of the pose error (m and rad) at q
    searches: int  # starts used (1 = converged from q0)


@dataclass(frozen=True)
class LoadedElement:
    """A link element with its mesh: ``triangles`` (F, 3, 3) in metres in the link frame.

    ``placeholder`` is True when the STL could not be loaded (``skip_missing_meshes``): the
    triangles are then a small cube and ``error`` says why.
    """

    link: int
    element: MeshElement
    triangles: np.ndarray
    placeholder: bool = False
    error: str = ""


# numba checks a named-table argument's class and field names on every call from Python (~0.6 µs
# a table: a one-pose fkine took 1.2 -> 2.2 µs, an rne 3.3 -> 5.4 µs). The one-pose calls pass the
# tables' arrays and numbers instead and rebuild the tables inside the kernel, where it costs
# nothing; the kernels themselves (and the batched calls, which cross once) keep their tables.
@numba.njit(cache=True)
def _fk_of(q: np.ndarray, dh: np.ndarray, base: np.ndarray, modified: bool) -> np.ndarray:
    return kin.fk(q, kin.Chain(dh, base, modified))


@numba.njit(cache=True)
def _jacob0_of(q: np.ndarray, dh: np.ndarray, base: np.ndarray, modified: bool) -> np.ndarray:
    return kin.jacob0(q, kin.Chain(dh, base, modified))


@numba.njit(cache=True)
def _rne_of(
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    dh: np.ndarray,
    base: np.ndarray,
    modified: bool,
    mass: np.ndarray,
    cog: np.ndarray,
    inertia: np.ndarray,
    gravity: np.ndarray,
) -> np.ndarray:
    return kin.rne(q, qd, qdd, kin.Chain(dh, base, modified), kin.Dynamics(mass, cog, inertia, gravity))


@numba.njit(cache=True)
def _ikine_of(
    T: np.ndarray,
    q0: np.ndarray,
    dh: np.ndarray,
    base: np.ndarray,
    modified: bool,
    lower: np.ndarray,
    upper: np.ndarray,
    tol: float,
    ilimit: int,
    slimit: int,
    seed: int,
) -> tuple[np.ndarray, bool, float, int]:
    limits, search = kin.Limits(lower, upper), kin.IKSearch(tol, ilimit, slimit, seed)
    return kin.ikine_lm(T, q0, kin.Chain(dh, base, modified), limits, search)


def placeholder_cube(size: float = PLACEHOLDER_SIZE) -> np.ndarray:
    """Triangles (12, 3, 3) of a cube of edge ``size`` centred on the origin."""
    corners = (np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)]) - 0.5) * size
    faces = [
        (0, 1, 3),
        (0, 3, 2),
        (4, 6, 7),
        (4, 7, 5),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ]
    triangles: np.ndarray = corners[np.array(faces)].astype(np.float32)
    return triangles


class Arm:
    """A serial arm built from a :class:`RobotConfig`.

    ``base`` (4x4) overrides the config's base transform (several arms in one world).
    ``load_meshes`` reads every STL element (errors raise InputError naming the file) unless
    ``skip_missing_meshes``, which draws a placeholder cube for each unreadable element instead.
    """

    def __init__(
        self,
        config: RobotConfig,
        *,
        base: np.ndarray | None = None,
        load_meshes: bool = True,
        skip_missing_meshes: bool = False,
    ) -> None:
        self.config = config
        self.name = config.name
        self.n = config.dof
        self.joint_names = config.joint_names
        dh = kin.pack_dh(config.theta, config.d, config.a, config.alpha, [t == "p" for t in config.joint_types])
        #: The kernels' named tables: geometry, joint limits, link dynamics (:mod:`arm_sim.kinematics`).
        self.chain = kin.Chain(
            dh, np.array(config.base if base is None else base, dtype=float), bool(config.modified_dh)
        )
        self.qlim = np.ascontiguousarray(config.position_limits, dtype=float)
        self.limits = kin.Limits(np.ascontiguousarray(self.qlim[:, 0]), np.ascontiguousarray(self.qlim[:, 1]))
        self.velocity_limits = np.array(config.velocity_limits, dtype=float)
        dyn = config.dynamics
        self.dynamics = kin.Dynamics(
            np.ascontiguousarray(dyn.mass, dtype=float),
            np.ascontiguousarray(dyn.cog, dtype=float),
            np.ascontiguousarray(dyn.inertia, dtype=float),
            np.ascontiguousarray(dyn.gravity, dtype=float),
        )
        self.elements: list[LoadedElement] = []
        if load_meshes:
            self.elements = load_elements(config, skip_missing_meshes)
        self.element_links = np.array([e.link for e in self.elements], dtype=np.int64)

    @classmethod
    def from_file(cls, path: str | os.PathLike[str], **kwargs: Any) -> Arm:
        """Load a robot config file and build the arm (keyword arguments as the constructor)."""
        return cls(load_robot_config(path), **kwargs)

    @property
    def base(self) -> np.ndarray:
        """World-from-frame-0 transform (4x4)."""
        return self.chain.base

    @property
    def lower(self) -> np.ndarray:
        """Lower joint position limits (n,)."""
        return self.limits.lower

    @property
    def upper(self) -> np.ndarray:
        """Upper joint position limits (n,)."""
        return self.limits.upper

    @property
    def gravity(self) -> np.ndarray:
        """The config's world gravity vector (m/s^2)."""
        return self.dynamics.gravity

    # --- kinematics -------------------------------------------------------------------------
    # The kernels are numba dispatchers, untyped to mypy: each result is named with its type.
    def fkine(self, q: npt.ArrayLike) -> np.ndarray:
        """World pose (4x4) of the flange (last DH frame) at joint coordinates q."""
        pose: np.ndarray = _fk_of(np.asarray(q, dtype=float), *self.chain)
        return pose

    def fkine_all(self, q: npt.ArrayLike) -> np.ndarray:
        """World poses (n+1, 4, 4) of frames 0 (base) .. n (flange)."""
        poses: np.ndarray = kin.fk_all(np.asarray(q, dtype=float), self.chain)
        return poses

    def fkine_batch(self, Q: npt.ArrayLike) -> np.ndarray:
        """Flange poses (m, 4, 4) for configurations Q (m, n)."""
        poses: np.ndarray = kin.fk_batch(np.ascontiguousarray(Q, dtype=float), self.chain)
        return poses

    def jacob0(self, q: npt.ArrayLike) -> np.ndarray:
        """Geometric Jacobian (6, n) of the flange in the world frame (v then omega)."""
        jacobian: np.ndarray = _jacob0_of(np.asarray(q, dtype=float), *self.chain)
        return jacobian

    def jacob0_batch(self, Q: npt.ArrayLike) -> np.ndarray:
        """Jacobians (m, 6, n) for configurations Q (m, n)."""
        jacobians: np.ndarray = kin.jacob0_batch(np.ascontiguousarray(Q, dtype=float), self.chain)
        return jacobians

    def ikine(
        self,
        T: npt.ArrayLike,
        q0: npt.ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        ilimit: int = 30,
        slimit: int = 100,
        seed: int = 0,
    ) -> IKResult:
        """Joint coordinates reaching world pose T (4x4), within joint limits.

        Levenberg–Marquardt from ``q0`` (default: mid-range), then random restarts; success
        when the pose error norm is below ``tol``. On failure ``success`` is False and ``q``
        is the best attempt: never use it as a solution.
        """
        goal = np.ascontiguousarray(T, dtype=float)
        start = self.mid_range() if q0 is None else np.asarray(q0, dtype=float)
        search = kin.IKSearch(float(tol), int(ilimit), int(slimit), int(seed))
        # mypy pairs the three unpacked tables with the kernel's parameters wrongly (it expects an
        # int where IKSearch.tol goes); the call is _ikine_of's signature, field for field
        q, ok, res, searches = _ikine_of(goal, start, *self.chain, *self.limits, *search)  # type: ignore[arg-type]
        return IKResult(q=q, success=bool(ok), residual=float(res), searches=int(searches))

    def ikine_batch(
        self,
        Ts: npt.ArrayLike,
        Q0: npt.ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        ilimit: int = 30,
        slimit: int = 100,
        seed: int = 0,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """IK for poses Ts (m, 4, 4): returns (Q (m, n), success (m,), residual (m,))."""
        goals = np.ascontiguousarray(Ts, dtype=float)
        if Q0 is None:
            Q0 = np.tile(self.mid_range(), (len(goals), 1))
        search = kin.IKSearch(float(tol), int(ilimit), int(slimit), int(seed))
        solved: tuple[np.ndarray, np.ndarray, np.ndarray] = kin.ikine_lm_batch(
            goals, np.ascontiguousarray(Q0, dtype=float), self.chain, self.limits, search
        )
        return solved

    def mid_range(self) -> np.ndarray:
        """Middle of every joint's range."""
        middle: np.ndarray = 0.5 * (self.lower + self.upper)
        return middle

    def within_limits(self, q: npt.ArrayLike) -> bool:
        """True when every joint coordinate is inside its position limits."""
        coordinates = np.asarray(q, dtype=float)
        return bool(np.all((coordinates >= self.lower) & (coordinates <= self.upper)))

    # --- dynamics ---------------------------------------------------------------------------
    def _dynamics(self, gravity: npt.ArrayLike | None) -> kin.Dynamics:
        # the config's table, or the same links under another gravity vector
        if gravity is None:
            return self.dynamics
        return self.dynamics._replace(gravity=np.asarray(gravity, dtype=float))

    def rne(
        self, q: npt.ArrayLike, qd: npt.ArrayLike, qdd: npt.ArrayLike, gravity: npt.ArrayLike | None = None
    ) -> np.ndarray:
        """Joint torques/forces (n,) for positions, velocities, accelerations (Newton–Euler)."""
        as_array = np.asarray
        q_, qd_, qdd_ = (as_array(x, dtype=float) for x in (q, qd, qdd))
        tau: np.ndarray = _rne_of(q_, qd_, qdd_, *self.chain, *self._dynamics(gravity))
        return tau

    def rne_batch(
        self, Q: npt.ArrayLike, QD: npt.ArrayLike, QDD: npt.ArrayLike, gravity: npt.ArrayLike | None = None
    ) -> np.ndarray:
        """Inverse dynamics (m, n) for states Q, QD, QDD (m, n)."""
        as_array = np.ascontiguousarray
        Q_, QD_, QDD_ = (as_array(X, dtype=float) for X in (Q, QD, QDD))
        tau: np.ndarray = kin.rne_batch(Q_, QD_, QDD_, self.chain, self._dynamics(gravity))
        return tau

    def gravload(self, q: npt.ArrayLike) -> np.ndarray:
        """Joint torques (n,) that hold the arm still against gravity at q."""
        zero = np.zeros(self.n)
        return self.rne(q, zero, zero)

    def inertia(self, q: npt.ArrayLike) -> np.ndarray:
        """Joint-space inertia matrix M(q) (n, n), column k = rne(q, 0, e_k) without gravity."""
        Q = np.tile(np.asarray(q, dtype=float), (self.n, 1))
        return self.rne_batch(Q, np.zeros_like(Q), np.eye(self.n), gravity=np.zeros(3)).T

    # --- meshes -----------------------------------------------------------------------------
    def element_poses(self, q: npt.ArrayLike) -> np.ndarray:
        """World poses (E, 4, 4) of every mesh element at q (its link frame's pose)."""
        poses: np.ndarray = self.fkine_all(q)[self.element_links]
        return poses


def load_elements(config: RobotConfig, skip_missing_meshes: bool = False) -> list[LoadedElement]:
    """Load every link element's STL (scaled to metres), or a placeholder if allowed."""
    loaded = []
    for link, elements in enumerate(config.links):
        for element in elements:
            try:
                triangles = load_stl(element.mesh) * np.float32(element.scale)
            except InputError as exc:
                error = InputError(f"{element.where}: {exc}") if element.where else exc  # the config's field
                if not skip_missing_meshes:
                    raise error from None
                loaded.append(LoadedElement(link, element, placeholder_cube(), True, str(error)))
                continue
            loaded.append(LoadedElement(link, element, triangles))
    return loaded
