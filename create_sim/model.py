"""The simulated iRobot Create: a pure model (no ROS), usable from a notebook.

Geometry and constants follow the original MATLAB toolbox (the iRobot Create Simulator); the
original's bugs are fixed (wheel clamping, arc direction, odometry wrap and sign lag, IR false
positives, shared cliff noise, exact-equality occlusion). Angles are radians, counter-clockwise,
sensor angles relative to the heading; every noise draw comes from the ``rng`` given.

>>> from create_sim.mapfile import parse_map
>>> robot = CreateModel(parse_map("wall 1 -1 1 1"))
>>> robot.set_velocity(0.2, 0.0)
(0.2, 0.0)
>>> for _ in range(100):
...     robot.step(0.01)
>>> round(float(robot.sonar()[0]), 3)   # front sonar, from the body's edge to the wall
0.64
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import ClassVar, overload

import numpy as np

from create_sim import spec
from create_sim.configfile import NoiseConfig
from create_sim.geometry import SegmentGrid, circle_crossing_angles, nearest_distance
from create_sim.mapfile import CreateMap
from create_sim.physics import CONTACT_SKIN, OVERLAP_TOL, advance_unpacked
from create_sim.sensing import (
    bumper_hits_unpacked,
    camera_view,
    cliff_windows_crossed,
    range_fan_unpacked,
    virtual_wall_seen,
)
from sim_runtime.angles import wrap_angle
from sim_runtime.errors import InputError
from sim_runtime.kernels import compiled_aside
from sim_runtime.limits import MAX_COORDINATE_M

# A ray to a beacon or emitter counts as blocked only if a wall is hit this much before it.
_OCCLUSION_TOL = 1e-4


@dataclass(frozen=True)
class BeaconSighting:
    """One beacon seen by the camera: distance (m) and bearing (rad, left positive) from it."""

    id: str
    rgb: tuple[float, float, float]
    distance: float
    angle: float


def odometry_origin(
    pose: tuple[float, float, float], odometry: tuple[float, float, float]
) -> tuple[float, float, float]:
    """Where the odometry frame's origin is in the map (``map → odom``: x, y, yaw), from the true
    pose and the odometry pose of one instant."""
    x, y, theta = pose
    odom_x, odom_y, odom_theta = odometry
    yaw = theta - odom_theta
    c, s = math.cos(yaw), math.sin(yaw)
    return x - (c * odom_x - s * odom_y), y - (s * odom_x + c * odom_y), yaw


class CreateModel:
    """Kinematics, wall physics and every sensor of one Create in a map."""

    RADIUS = spec.RADIUS_M
    WHEEL_BASE = spec.WHEEL_BASE_M
    MAX_WHEEL_SPEED = spec.MAX_WHEEL_SPEED_MPS
    FRICTION = 0.35  # kinetic friction μ against walls
    MAX_STEP_S = 3600.0  # longest physics step (bounds the work of one step)
    LIDAR_BEAMS = spec.LIDAR_BEAMS
    LIDAR_FOV = math.radians(240.0)
    LIDAR_RANGE = (0.02, 4.0)
    SONAR_RANGE = (0.02, 3.0)
    CAMERA_RANGE = 6.0
    CAMERA_HALF_FOV = math.radians(60.0)
    CAMERA_OFFSET = spec.CAMERA_OFFSET_M
    IR_RANGE = 0.1
    IR_MOUNT_ANGLE = spec.IR_MOUNT_ANGLE_RAD  # on the perimeter, looking straight right
    VWALL_HALO = spec.VWALL_HALO_M
    # Virtual-wall field per setting 1, 2, 3: (range m, full opening angle rad).
    VWALL_FIELDS: ClassVar[dict[int, tuple[float, float]]] = spec.VWALL_FIELDS
    BUMP_FRONT_HALF = spec.BUMP_FRONT_HALF_RAD
    #: A wall this close to the body touches it (m): presses a bumper in front, a contact anywhere.
    CONTACT_M = CONTACT_SKIN
    CLIFF_FLOOR = spec.CLIFF_FLOOR_SIGNAL
    CLIFF_LINE = spec.CLIFF_LINE_SIGNAL
    # Cliff sensor windows on the perimeter, relative to the heading, order [L, FL, FR, R].
    CLIFF_WINDOWS = np.array(spec.CLIFF_WINDOWS_RAD)
    BATTERY_VOLTAGE = 17.2
    BATTERY_CURRENT = -3.0
    BATTERY_CHARGE = 3.0  # Ah
    BATTERY_CAPACITY = 3.0  # Ah
    TEMPERATURE = 25.0  # °C

    def __init__(
        self,
        create_map: CreateMap,
        noise: NoiseConfig | None = None,
        rng: np.random.Generator | None = None,
        pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        for name in ("walls", "lines", "beacon_xy", "virtwalls"):
            if not np.isfinite(getattr(create_map, name)).all():
                raise InputError(f"map {name} contain non-finite values")
        for name in ("walls", "lines", "beacon_xy"):
            if np.abs(getattr(create_map, name)).max(initial=0.0) > MAX_COORDINATE_M:
                raise InputError(f"map {name} have coordinates beyond ±{MAX_COORDINATE_M:g} m")
        if np.abs(create_map.virtwalls[:, :2]).max(initial=0.0) > MAX_COORDINATE_M:
            raise InputError(f"map virtwalls have coordinates beyond ±{MAX_COORDINATE_M:g} m")
        self.map = create_map
        self.noise = noise if noise is not None else NoiseConfig()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.grid = SegmentGrid.build(create_map.walls)
        self._lines = np.ascontiguousarray(create_map.lines, dtype=np.float64).reshape(-1, 4)
        self._virtwalls = np.ascontiguousarray(create_map.virtwalls, dtype=np.float64).reshape(-1, 4)
        self._vwall_ranges = np.array([self.VWALL_FIELDS[s][0] for s in (1, 2, 3)])
        self._vwall_angles = np.array([self.VWALL_FIELDS[s][1] for s in (1, 2, 3)])
        self._beacon_xy = np.ascontiguousarray(create_map.beacon_xy, dtype=np.float64).reshape(-1, 2)
        self._beacon_rgb = [tuple(float(c) for c in rgb) for rgb in create_map.beacon_rgb]
        self._crossing_buf = np.empty(max(2 * self._lines.shape[0], 1))
        lidar = np.linspace(-0.5 * self.LIDAR_FOV, 0.5 * self.LIDAR_FOV, self.LIDAR_BEAMS)
        self._lidar_fan = (np.cos(lidar), np.sin(lidar))
        sonar = np.array(spec.SONAR_BEARINGS_RAD)
        self._sonar_fan = (np.round(np.cos(sonar), 15), np.round(np.sin(sonar), 15))
        self._ir_fan = (np.array([0.0]), np.array([-1.0]))  # looking straight right
        self._normals = np.empty(0)
        self._normals_used = 0
        self._check_pose(*pose)
        self.initial_pose = (float(pose[0]), float(pose[1]), float(wrap_angle(float(pose[2]))))
        self.reset()

    # ----------------------------------------------------------------------------- state
    def reset(self) -> None:
        """Back to the initial pose, stopped, odometry cleared."""
        self._pose = list(self.initial_pose)  # plain floats: cheaper than numpy scalars per step
        self._command = (0.0, 0.0)
        self._velocity = (0.0, 0.0)
        # plain floats: numpy's small-array arithmetic cost half of every physics step
        self._odom_pose = (0.0, 0.0, 0.0)
        self._odom_totals = (0.0, 0.0)
        self._odom_variance = (0.0, 0.0)  # of the summed distance and turn

    @property
    def pose(self) -> np.ndarray:
        """Ground-truth [x, y, θ] in the map frame, θ in [-π, π)."""
        return np.array(self._pose)

    def set_pose(self, x: float, y: float, theta: float) -> None:
        """Place the robot (odometry keeps counting from where it was); InputError inside a wall."""
        self._check_pose(x, y, theta)
        self._pose = [float(x), float(y), wrap_angle(float(theta))]

    def clearance(self) -> float:
        """Gap between the body and the nearest wall (m); inf without walls."""
        return nearest_distance(self.grid.segments, self._pose[0], self._pose[1]) - self.RADIUS

    def touching(self) -> bool:
        """Whether a wall touches the body anywhere round it, bumper or not (a collision from any
        side: the bumpers cover only the front half). "Touching" is the bumpers' own reach, so a
        pressed bumper is always a touch."""
        return self.clearance() <= self.CONTACT_M

    def _check_pose(self, x: float, y: float, theta: float) -> None:
        if not all(math.isfinite(float(v)) for v in (x, y, theta)):
            raise InputError(f"pose ({x}, {y}, {theta}) is not finite")
        gap = nearest_distance(self.grid.segments, float(x), float(y)) - self.RADIUS
        if gap < -OVERLAP_TOL:
            raise InputError(
                f"pose ({x}, {y}, {theta}) puts the robot {-gap:.4g} m inside a wall "
                f"(the body is a circle of radius {self.RADIUS} m)"
            )

    # ----------------------------------------------------------------------------- motion
    def set_velocity(self, v: float, w: float) -> tuple[float, float]:
        """Command forward speed v (m/s) and turn rate w (rad/s); returns the applied pair.

        Each wheel is clamped to ±MAX_WHEEL_SPEED on its own and (v, w) recomputed from the
        clamped wheels (the original clamped the left wheel from the right one's value).
        """
        v = float(v)
        w = float(w)
        if not (math.isfinite(v) and math.isfinite(w)):
            raise ValueError(f"velocity command ({v}, {w}) is not finite")
        half = 0.5 * self.WHEEL_BASE
        limit = self.MAX_WHEEL_SPEED
        right = min(max(v + w * half, -limit), limit)
        left = min(max(v - w * half, -limit), limit)
        self._command = (0.5 * (right + left), (right - left) / self.WHEEL_BASE)
        return self._command

    @property
    def command(self) -> tuple[float, float]:
        """The (clamped) commanded (v, w)."""
        return self._command

    @property
    def velocity(self) -> tuple[float, float]:
        """The body's actual (v, w) over the last step (0 when blocked)."""
        return self._velocity

    def step(self, dt: float) -> None:
        """Advance the physics by dt seconds at the commanded velocity and update odometry."""
        dt = float(dt)
        if not (math.isfinite(dt) and 0.0 <= dt <= self.MAX_STEP_S):
            raise ValueError(f"time step {dt} must be finite, >= 0 and <= {self.MAX_STEP_S:g} s")
        x0, y0, th0 = self._pose
        v, w = self._command
        x1, y1, th1 = advance_unpacked(*self.grid, x0, y0, th0, v, w, dt, self.RADIUS, self.FRICTION)
        self._pose = [x1, y1, th1]
        dx = x1 - x0
        dy = y1 - y0
        turn = wrap_angle(th1 - th0)
        mid = th0 + 0.5 * turn
        # Signed by the actual motion in this step (no lag behind the previous step's velocity).
        along = dx * math.cos(mid) + dy * math.sin(mid)
        dist = math.copysign(math.hypot(dx, dy), along)
        if dt > 0.0:
            self._velocity = (float(along / dt), float(turn / dt))
        self._integrate_odometry(dist, turn)

    # ----------------------------------------------------------------------------- odometry
    def _integrate_odometry(self, dist: float, turn: float) -> None:
        _mean, std = self.noise.noise["odometry"]
        if dist != 0.0:
            dist += self._noise("odometry") * abs(dist)
        if turn != 0.0:
            turn += self._noise("odometry") * abs(turn)
        x, y, th = self._odom_pose
        mid = th + 0.5 * turn
        self._odom_pose = (x + dist * math.cos(mid), y + dist * math.sin(mid), wrap_angle(th + turn))
        self._odom_totals = (self._odom_totals[0] + dist, self._odom_totals[1] + turn)
        if std != 0.0:
            var_dist, var_turn = self._odom_variance
            self._odom_variance = (var_dist + (std * dist) ** 2, var_turn + (std * turn) ** 2)

    @property
    def odometry_pose(self) -> np.ndarray:
        """[x, y, θ] dead-reckoned from the noisy wheel odometry, from (0, 0, 0) at reset."""
        return np.array(self._odom_pose)

    @property
    def odometry_variance(self) -> tuple[float, float]:
        """Variance of the odometry's summed distance (m²) and turn (rad²) from its noise since reset:
        each step's proportional error adds (std·step)²; zero for noise-free odometry."""
        return float(self._odom_variance[0]), float(self._odom_variance[1])

    @property
    def odometry_totals(self) -> tuple[float, float]:
        """Noisy distance (m, signed) and angle (rad, CCW) summed since reset."""
        return float(self._odom_totals[0]), float(self._odom_totals[1])

    def _standard_normals(self, size: int) -> np.ndarray:
        """The next ``size`` N(0, 1) draws of the rng, taken from batches (one rng call per ~4k)."""
        if self._normals_used + size > self._normals.shape[0]:
            self._normals = self.rng.standard_normal(max(4096, size))
            self._normals_used = 0
        draws = self._normals[self._normals_used : self._normals_used + size]
        self._normals_used += size
        return draws

    @overload
    def _noise(self, sensor: str, size: None = None) -> float: ...
    @overload
    def _noise(self, sensor: str, size: int) -> np.ndarray: ...
    def _noise(self, sensor: str, size: int | None = None) -> float | np.ndarray:
        """mean + std·N(0, 1) of a sensor's noise; no draw when std is 0 (keeps ideal runs cheap)."""
        mean, std = self.noise.noise[sensor]
        if size is None:
            return mean if std == 0.0 else mean + std * float(self._standard_normals(1)[0])
        if std == 0.0:
            return np.full(size, mean)
        return mean + std * self._standard_normals(size)

    # ----------------------------------------------------------------------------- sensors
    def bumps(self) -> tuple[bool, bool]:
        """(left, right) bumpers; a hit in front presses both."""
        x, y, th = self._pose
        left, right = bumper_hits_unpacked(*self.grid, x, y, th, self.RADIUS + self.CONTACT_M, self.BUMP_FRONT_HALF)
        return bool(left), bool(right)

    def cliff_signals(self) -> np.ndarray:
        """Cliff signal strengths (%) [left, front_left, front_right, right]: 21.5 floor, 1.5 line."""
        x, y, th = self._pose
        n = circle_crossing_angles(self._lines, x, y, self.RADIUS, self._crossing_buf)
        signals = np.full(4, self.CLIFF_FLOOR)
        if n:
            signals[cliff_windows_crossed(self._crossing_buf[:n], th, self.CLIFF_WINDOWS)] = self.CLIFF_LINE
        noisy: np.ndarray = signals + self._noise("cliff", 4)
        return noisy

    def wall_sensor(self) -> bool:
        """IR wall sensor on the front-right, looking right: a wall within IR range (+ noise)."""
        reach = self.IR_RANGE + self._noise("wall")
        if reach <= 0.0:
            return False
        x, y, th = self._pose
        mount = th + self.IR_MOUNT_ANGLE
        hit = self.grid.cast_fan(
            x + self.RADIUS * math.cos(mount), y + self.RADIUS * math.sin(mount), th, *self._ir_fan, reach
        )
        return bool(hit[0] < math.inf)

    def virtual_wall(self) -> bool:
        """Whether the front receiver is in any emitter's halo or field, with no wall between."""
        if self.map.virtwalls.shape[0] == 0:
            return False
        return self._virtual_wall_seen()

    def _virtual_wall_seen(self) -> bool:
        x, y, th = self._pose
        return virtual_wall_seen(
            self.grid,
            x + self.RADIUS * math.cos(th),
            y + self.RADIUS * math.sin(th),
            self._virtwalls,
            self.VWALL_HALO,
            self._vwall_ranges,
            self._vwall_angles,
            _OCCLUSION_TOL,
        )

    def sonar(self) -> np.ndarray:
        """Sonar ranges [front, left, back, right] from the body's edge (m); +inf none, -inf too close."""
        x, y, th = self._pose
        lo, hi = self.SONAR_RANGE
        ranges: np.ndarray = range_fan_unpacked(
            *self.grid,
            x,
            y,
            th,
            *self._sonar_fan,
            self.RADIUS,
            lo,
            hi,
            self._noise("sonar", 4),
            -np.inf,
        )
        return ranges

    def lidar(self, beams: np.ndarray | None = None) -> np.ndarray:
        """LIDAR ranges (681,) float32 from -120° (index 0) to +120°; +inf no return within 4 m.

        ``beams`` (integer indices into the 681): only those beams, cast alone, ``lidar()[beams]``
        exactly, noise draws included (all 681 are drawn, so the stream advances the same).
        """
        x, y, th = self._pose
        lo, hi = self.LIDAR_RANGE
        noise = self._noise("lidar", self.LIDAR_BEAMS)
        cos_off, sin_off = self._lidar_fan
        if beams is not None:
            cos_off, sin_off, noise = cos_off[beams], sin_off[beams], noise[beams]
        scan = range_fan_unpacked(
            *self.grid,
            x + self.RADIUS * math.cos(th),
            y + self.RADIUS * math.sin(th),
            th,
            cos_off,
            sin_off,
            0.0,
            lo,
            hi,
            noise,
            lo,
        )
        ranges: np.ndarray = scan.astype(np.float32)
        return ranges

    def camera(self) -> list[BeaconSighting]:
        """Beacons within 6 m and ±60° of the camera (0.13 m ahead) with no wall in between."""
        if self._beacon_xy.shape[0] == 0:
            return []
        index, dist, bearing = self._camera_view()
        sightings = []
        for i, d, a in zip(index.tolist(), dist.tolist(), bearing.tolist(), strict=True):
            # Camera noise is proportional ("percent"), separate draws for distance and angle.
            sightings.append(
                BeaconSighting(
                    self.map.beacon_ids[i],
                    self._beacon_rgb[i],
                    d * (1.0 + self._noise("camera")),
                    a * (1.0 + self._noise("camera")),
                )
            )
        return sightings

    def _camera_view(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Indices, distances and bearings of the beacons the camera sees (no noise)."""
        x, y, th = self._pose
        seen: tuple[np.ndarray, np.ndarray, np.ndarray] = camera_view(
            self.grid,
            x + self.CAMERA_OFFSET * math.cos(th),
            y + self.CAMERA_OFFSET * math.sin(th),
            th,
            self._beacon_xy,
            self.CAMERA_RANGE,
            self.CAMERA_HALF_FOV,
            _OCCLUSION_TOL,
        )
        return seen

    # ----------------------------------------------------------------------------- numba
    def compile_kernels(self) -> None:
        """Run every numba kernel this model may call once, on a copy of it: each is compiled (or
        loaded from numba's cache) now, not when a sensor is first read (a world would stall for
        seconds then). This model, its state and its noise draws are untouched. Kernels are
        compiled for their arguments' types, not the map's contents, so any map loaded later is
        covered too."""
        twin = copy.deepcopy(self)
        twin.noise = NoiseConfig()  # noise-free: the IR wall sensor then always casts its ray
        twin.set_velocity(0.3, 0.5)
        with compiled_aside(twin, "_read_every_sensor"):  # on a cold cache, by a second process meanwhile
            SegmentGrid.build(np.array([[0.0, 0.0, 1.0, 0.0]]))  # a map without walls builds no grid
            twin.step(0.01)
        twin._read_every_sensor()

    def _read_every_sensor(self) -> None:
        self.bumps(), self.cliff_signals(), self.wall_sensor(), self.sonar(), self.lidar(), self.clearance()
        self._virtual_wall_seen(), self._camera_view()  # what the sensors skip on a map without them
        cliff_windows_crossed(self._crossing_buf[:1], 0.0, self.CLIFF_WINDOWS)  # skipped without lines


__all__ = ["BeaconSighting", "CreateModel"]
