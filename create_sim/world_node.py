"""``create_world``: the simulated iRobot Create on ROS 2.

A thin mapping of :class:`create_sim.model.CreateModel` onto topics, parameters, services and TF;
the interface (every topic, parameter and frame) is in ``docs/executables.md``. What the code
below has to keep true:

- physics runs at a fixed 100 Hz whatever ``real_time_factor`` is; each sensor is published at its
  own rate, stamped with the sim time at which it was measured;
- a command with a NaN/inf component, or one above :data:`sim_runtime.msgs.ABSURD_COMMAND`, is
  rejected with a throttled warning and leaves the state unchanged;
- sensors nobody subscribes to are not built, except those that draw seeded noise: a run with a
  given ``seed`` reads the same whoever listens;
- ``com_delay`` delays both directions: a command takes effect ``com_delay`` after it arrives, a
  message is published ``com_delay`` after its measurement and keeps the measurement's stamp.
"""

from __future__ import annotations

import math
import os
from collections import deque
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numpy as np
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point, PoseStamped, TransformStamped, Twist, TwistStamped, Vector3
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from sensor_msgs.msg import BatteryState, Illuminance, JointState, Joy, LaserScan, Range
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import Marker, MarkerArray

from create_sim import spec
from create_sim.configfile import NoiseConfig, load_config
from create_sim.geometry import MAX_MAP_CELLS, WALL_THICKNESS_M, rasterise_walls
from create_sim.mapfile import CreateMap, load_map
from create_sim.model import BeaconSighting, CreateModel, odometry_origin
from create_sim.physics import CONTACT_SKIN
from create_sim.spec import (
    BEACON_IDS_NS,
    BEACONS_NS,
    CLIFF_NAMES,
    DEFAULT_RATES,
    FOOTPRINT_FRAME,
    LINE_RGB,
    LINES_NS,
    ODOMETRY_RESOLUTION,
    PHYSICS_RATE,
    SENSOR_MOUNTS,
    SONAR_NAMES,
    VIRTUAL_WALL_FIELDS_NS,
    VIRTUAL_WALL_HALOS_NS,
    VIRTUAL_WALL_RGBA,
    VWALL_HALO_M,
    WALL_RGB,
    WALLS_NS,
    WHEEL_BASE_M,
    WHEEL_JOINTS,
    WHEEL_RADIUS_M,
    sonar_field_of_view,
    virtual_wall_field,
)
from create_sim.urdf import create_urdf
from sim_runtime.errors import InputError
from sim_runtime.inputfile import is_regular_file, shown
from sim_runtime.kernels import announce_compiling
from sim_runtime.limits import MAX_COORDINATE_M, all_within
from sim_runtime.msgs import (
    ABSURD_COMMAND,
    color_msg,
    command_ok,
    float32_array,
    occupancy_grid_msg,
    pose_msg,
    set_planar_pose,
    yaw_from_quaternion,
)
from sim_runtime.paths import config_path, resolve_input_file
from sim_runtime.qos import LATCHED_QOS, SENSOR_PUBLISHER_QOS, create_command_subscription, create_sensor_publisher
from sim_runtime.run import run_nodes
from sim_runtime.tf import TfBroadcaster, set_planar, transform_msg
from sim_runtime.world_node import SimWorldNode, namespace_prefix

try:
    from robot_sims_interfaces.srv import SetPose
except ImportError:  # a pip install without a compiler: see interfaces/build_interfaces.py
    SetPose = None

SET_POSE_SERVICE_OFF = (
    "the set_pose service is off: robot_sims_interfaces is not installed (interfaces/build_interfaces.py "
    "builds it, which needs a C/C++ compiler and the Python headers); the set_pose topic works"
)

BUMP_FOV = math.pi / 2  # each bumper half covers a quarter of the circle
# one ray per sonar: the cone within which that ray reads as a cone would, to the physics' contact skin
SONAR_FIELD_OF_VIEW = sonar_field_of_view(CreateModel.SONAR_RANGE[1], CONTACT_SKIN)
_DIST_STEP, _ANGLE_STEP, _SPEED_STEP = ODOMETRY_RESOLUTION
# rounding variance step²/12 of (x and y, yaw) and of (v, w): w = (v_right - v_left) / wheel base
POSE_RESOLUTION_VARIANCE = (_DIST_STEP**2 / 12.0, _ANGLE_STEP**2 / 12.0)
TWIST_RESOLUTION_VARIANCE = (_SPEED_STEP**2 / 12.0, 2.0 * _SPEED_STEP**2 / 12.0 / WHEEL_BASE_M**2)


class CreateWorldNode(SimWorldNode):
    """The simulated Create: parameters → :class:`CreateModel`, model state → messages."""

    def __init__(self, node_name: str = "create_world", **node_kwargs: Any) -> None:
        super().__init__(node_name, physics_rate=PHYSICS_RATE, **node_kwargs)
        try:
            self._declare_parameters()
            self.parameters_declared()
            with announce_compiling(self.get_logger().info), self.starting("building the model"):
                self.model = self._make_model()
                # every sensor's kernels now: compiling one when it is first subscribed would stall the world
                self.model.compile_kernels()
        except InputError:
            self.destroy_node()  # a half-built node must not linger in the graph
            raise
        self.com_delay = float(self.noise.com_delay)

        self._delayed_msgs: deque[tuple[float, Publisher, object]] = deque()
        self._delayed_cmds: deque[tuple[float, float, float]] = deque()
        self._last_cmd_time: float | None = None  # sim time the last command took effect
        self.commands_received = 0  # velocity commands handled, rejected ones included (tests sync on it)
        self.buttons_state = [0, 0]  # [play, advance]

        self.tf = TfBroadcaster(self)
        self._make_publishers()
        self._publish_static_transforms()
        self.create_publisher(String, "robot_description", LATCHED_QOS).publish(String(data=create_urdf(self.prefix)))
        self._make_inputs()
        self._publish_map()
        self.get_logger().info(self._summary())

    # ---------------------------------------------------------------- parameters
    def _declare_parameters(self) -> None:
        declare = self.declare_checked
        map_file = declare(
            "map_file",
            str(config_path("create/example.map")),
            None,
            "map file in the Create simulator's text format: a path, or relative to the current directory "
            "or to the shipped config/ ('' = an empty map); setting it loads the new map with the robot "
            "where it is (refused if that is inside a wall)",
            live=True,
            on_change=self._change_map,
        )
        config_file = declare(
            "config_file",
            "",
            None,
            "noise/com_delay config file in the Create simulator's text format ('' = noise-free); "
            "setting it applies the new noise and delay at once",
            live=True,
            on_change=self._change_noise,
        )
        pose = declare(
            "initial_pose",
            [0.0, 0.0, 0.0],
            lambda v: len(v) == 3 and all_within(v),
            f"initial pose [x, y, theta] in the map frame (m, rad; each within ±{MAX_COORDINATE_M:g}, the maps' "
            "bound); the reset service returns there",
        )
        self.cmd_vel_stamped = declare(
            "cmd_vel_stamped", False, None, "subscribe geometry_msgs/TwistStamped instead of Twist on cmd_vel"
        )
        self.cmd_vel_timeout = declare(
            "cmd_vel_timeout",
            0.0,
            None,
            "stop after this many sim seconds without cmd_vel (0 = hold the last command)",
            live=True,
            on_change=lambda v: setattr(self, "cmd_vel_timeout", v),
            bounds=(0.0, 1e9),
        )
        prefix = declare(
            "frame_prefix",
            "",
            None,
            "prefix of the robot's frames ('' = from the namespace: /robot1 -> robot1/)",
        )
        self.map_resolution = declare(
            "map_resolution",
            0.05,
            None,
            "cell size of the occupancy grid of the walls on 'map' (m); a huge map gets coarser cells",
            live=True,
            on_change=self._change_map_resolution,
            bounds=(0.001, 10.0),
        )
        self.publish_map_tf = declare(
            "publish_map_tf",
            False,
            None,
            "also publish the ground-truth map -> odom transform (off: a localisation node normally owns it)",
        )
        self.rates = {
            name: declare(
                f"rate.{name}",
                default,
                None,
                f"{name} publication rate in Hz (0 = never, at most the physics rate {PHYSICS_RATE:g})",
                live=True,
                on_change=partial(self._change_rate, name),
                bounds=(0.0, PHYSICS_RATE),
            )
            for name, default in DEFAULT_RATES.items()
        }
        self.prefix = prefix or namespace_prefix(self.get_namespace())
        self.map_file = self._resolve(map_file, "map_file")
        self.config_file = self._resolve(config_file, "config_file")
        self.map = self._load_map(self.map_file)
        self.noise = self._load_noise(self.config_file)
        # three finite numbers: checked above
        self.initial_pose = (float(pose[0]), float(pose[1]), float(pose[2]))

    @staticmethod
    def _resolve(value: str, parameter: str) -> str:
        return str(resolve_input_file(value, parameter)) if value else ""

    def _make_model(self) -> CreateModel:
        try:
            return CreateModel(self.map, self.noise, rng=self.rng, pose=self.initial_pose)
        except InputError as err:  # the pose overlaps a wall
            raise InputError(f"parameter 'initial_pose' = {list(self.initial_pose)}: {err}") from err

    def _load_map(self, path: str) -> CreateMap:
        if not path:
            return CreateMap()
        size = os.stat(path).st_size if is_regular_file(path) else 0
        if size > BIG_FILE_BYTES:  # said at once: reading it takes seconds
            self.get_logger().info(f"reading map {shown(path)} ({size / 1e6:.0f} MB)")
        try:  # skipped rows are logged (/rosout), not Python warnings on stderr
            with self.starting(f"reading map {shown(path)}"):
                return load_map(path, warn=self.get_logger().warning)
        except (InputError, OSError) as err:
            raise InputError(f"parameter 'map_file' = {path!r}: {err}") from err

    def _load_noise(self, path: str) -> NoiseConfig:
        if not path:
            return NoiseConfig()
        try:
            return load_config(path, warn=self.get_logger().warning)
        except (InputError, OSError) as err:
            raise InputError(f"parameter 'config_file' = {path!r}: {err}") from err

    def _summary(self) -> str:
        w = self.map
        counts = (
            f"{len(w.walls)} walls, {len(w.lines)} lines, {len(w.beacon_ids)} beacons, {len(w.virtwalls)} virtual walls"
        )
        return (
            f"map {self.map_file or '(empty)'} ({counts}); config {self.config_file or '(noise-free)'}; "
            f"robot at {list(self.initial_pose)}, frames {self.frame('base_link')}; {self.pace_text()}"
        )

    def _change_map(self, value: str) -> None:
        """Live ``map_file``: the robot stays where it is, stopped; refused if that is inside a wall."""
        path = self._resolve(value, "map_file")
        new_map = self._load_map(path)
        x, y, theta = self.model.pose.tolist()
        try:
            model = CreateModel(new_map, self.noise, rng=self.rng, pose=(x, y, theta))
        except InputError as err:
            raise InputError(f"the robot at ({x:.3f}, {y:.3f}) would be inside a wall of {path}: {err}") from err
        try:
            model.initial_pose = CreateModel(new_map, pose=self.initial_pose).initial_pose
        except InputError:
            self.get_logger().warning(
                f"initial_pose {list(self.initial_pose)} is inside a wall of {path}: reset now returns to "
                f"({x:.3f}, {y:.3f}, {theta:.3f})"
            )
        self.map, self.map_file, self.model = new_map, path, model
        self._delayed_cmds.clear()
        self._publish_map()
        self.get_logger().info(f"map_file: loaded {path or 'an empty map'}")

    def _change_map_resolution(self, value: float) -> None:
        self.map_resolution = value
        self._publish_map()

    def _change_noise(self, value: str) -> None:
        path = self._resolve(value, "config_file")
        self.noise = self._load_noise(path)
        self.model.noise = self.noise
        self.config_file = path
        self.com_delay = float(self.noise.com_delay)
        self._make_templates()
        self.get_logger().info(f"config_file: loaded {path or 'noise-free defaults'}")

    def _change_rate(self, name: str, rate_hz: float) -> None:
        self.rates[name] = rate_hz
        self._schedule[name].set_rate(rate_hz / self.physics_rate, self.step_count)
        if name == "scan":
            self._make_templates()  # scan_time follows the rate

    def frame(self, name: str) -> str:
        """The robot frame ``name`` with this robot's prefix (e.g. ``robot1/laser``)."""
        return self.prefix + name

    # ---------------------------------------------------------------- topics
    def _make_publishers(self) -> None:
        def pub(msg_type: Any, topic: str, qos: QoSProfile = SENSOR_PUBLISHER_QOS) -> Publisher:
            if qos is not SENSOR_PUBLISHER_QOS:
                return self.create_publisher(msg_type, topic, qos)
            return create_sensor_publisher(self, msg_type, topic)

        self.pub_odom = pub(Odometry, spec.ODOM_TOPIC)
        self.pub_overhead = pub(PoseStamped, spec.OVERHEAD_POSE_TOPIC)
        self.pub_bump = [pub(Range, spec.bump_topic(side)) for side in spec.BUMP_SIDES]
        self.pub_wall = pub(Range, spec.WALL_TOPIC)
        self.pub_virtual_wall = pub(Range, spec.VIRTUAL_WALL_TOPIC)
        self.pub_cliff = [pub(Illuminance, spec.cliff_topic(n)) for n in CLIFF_NAMES]
        self.pub_sonar = [pub(Range, spec.sonar_topic(n)) for n in SONAR_NAMES]
        self.pub_scan = pub(LaserScan, spec.SCAN_TOPIC)
        self.pub_camera = pub(MarkerArray, spec.CAMERA_BEACONS_TOPIC)
        self.pub_buttons = pub(Joy, spec.BUTTONS_TOPIC)
        self.pub_battery = pub(BatteryState, spec.BATTERY_TOPIC)
        self.pub_joints = pub(JointState, spec.JOINT_STATES_TOPIC)
        self.pub_map_markers = pub(MarkerArray, spec.MAP_MARKERS_TOPIC, LATCHED_QOS)
        self.pub_map = pub(OccupancyGrid, spec.MAP_TOPIC, LATCHED_QOS)
        self._map_published = False  # whether pub_map holds a latched grid
        self._make_templates()

        # rate name -> (CreateModel method reading it or None, publisher of its message, its publishers,
        # config noise it draws). Methods are looked up at each tick: a live map_file swaps the model.
        sensors: dict[str, tuple[str | None, Callable[..., None], list[Publisher], str | None]] = {
            "bump": ("bumps", self._publish_bumps, self.pub_bump, None),
            "cliff": ("cliff_signals", self._publish_cliffs, self.pub_cliff, "cliff"),
            "wall": ("wall_sensor", self._publish_wall, [self.pub_wall], "wall"),
            "virtual_wall": ("virtual_wall", self._publish_virtual_wall, [self.pub_virtual_wall], None),
            # odometry noise is drawn by the physics; /tf's odom -> base_link goes with the odometry
            # the wheels' joint_states come from the same odometry, at its rate
            "odom": (None, self._publish_odom, [self.pub_odom, self.pub_joints, *self.tf.publishers], None),
            "overhead_pose": (None, self._publish_overhead, [self.pub_overhead], None),
            "sonar": ("sonar", self._publish_sonar, self.pub_sonar, "sonar"),
            "scan": ("lidar", self._publish_scan, [self.pub_scan], "lidar"),
            "camera": ("camera", self._publish_camera, [self.pub_camera], "camera"),
            "buttons": (None, self._publish_buttons, [self.pub_buttons], None),
            "battery": (None, self._publish_battery, [self.pub_battery], None),
        }
        self._schedule = {
            name: self.every(self.rates[name], self._sensor_tick(read, publish, publishers, noise_key))
            for name, (read, publish, publishers, noise_key) in sensors.items()
        }

    def _sensor_tick(
        self,
        read: str | None,
        publish: Callable[..., None],
        publishers: list[Publisher],
        noise_key: str | None,
    ) -> Callable[[], None]:
        """A sensor's scheduled callback. Messages nobody subscribes to are not built (most of the cost
        at real_time_factor 0), but a sensor that draws seeded noise is still read: skipping it would
        shift the noise of the others, and a run must not depend on who listens."""

        def tick() -> None:
            heard = any(p.get_subscription_count() for p in publishers)
            if read is None:
                if heard:
                    publish()
            elif heard or (noise_key is not None and self.noise.noise[noise_key][1] != 0.0):
                reading = getattr(self.model, read)()
                if heard:
                    publish(reading)

        return tick

    def _make_inputs(self) -> None:
        if self.cmd_vel_stamped:
            create_command_subscription(self, TwistStamped, spec.CMD_VEL_TOPIC, self._on_cmd_vel_stamped)
        else:
            create_command_subscription(self, Twist, spec.CMD_VEL_TOPIC, self._on_cmd_vel)
        create_command_subscription(self, PoseStamped, spec.SET_POSE_TOPIC, self._on_set_pose)
        if SetPose is None:
            self.get_logger().warning(SET_POSE_SERVICE_OFF)
        else:
            self.create_service(SetPose, spec.SET_POSE_SERVICE, self._on_set_pose_service)
        self.create_service(Trigger, "reset", self._on_reset)
        self.create_service(SetBool, "press_play", lambda req, res: self._on_button(0, req, res))
        self.create_service(SetBool, "press_advance", lambda req, res: self._on_button(1, req, res))

    # ---------------------------------------------------------------- commands
    def _on_cmd_vel(self, msg: Twist) -> None:
        self.command(msg.linear.x, msg.angular.z)

    def _on_cmd_vel_stamped(self, msg: TwistStamped) -> None:
        self.command(msg.twist.linear.x, msg.twist.angular.z)

    def command(self, v: float, w: float) -> bool:
        """Queue a velocity command (m/s, rad/s); it takes effect after ``com_delay``.

        Returns False (and warns, throttled) if the command is rejected.
        """
        self.commands_received += 1
        if not command_ok(v, w):
            self.warn_throttled(
                "cmd_vel",
                f"rejected cmd_vel v={v!r} w={w!r}: not finite or absurdly large "
                f"(|value| > {ABSURD_COMMAND:g}); state unchanged",
            )
            return False
        self._delayed_cmds.append((self.sim_time + self.com_delay, float(v), float(w)))
        return True

    def _apply_due_commands(self, now: float) -> None:
        while self._delayed_cmds and self._delayed_cmds[0][0] <= now + 1e-9:
            _, v, w = self._delayed_cmds.popleft()
            self.model.set_velocity(v, w)
            self._last_cmd_time = now
        if (
            self.cmd_vel_timeout > 0.0
            and self._last_cmd_time is not None
            and now - self._last_cmd_time >= self.cmd_vel_timeout - 1e-9
        ):
            self.model.set_velocity(0.0, 0.0)
            self._last_cmd_time = None

    def place(self, msg: PoseStamped) -> str | None:
        """Move the robot to the pose ``msg`` gives in the map; None when done, else why not (the
        robot stays where it was). The one check behind the ``set_pose`` topic and service."""
        p = msg.pose.position
        yaw = yaw_from_quaternion(msg.pose.orientation)
        if msg.header.frame_id not in ("", "map"):
            return f"frame {msg.header.frame_id!r} is not 'map'"
        if not all_within((p.x, p.y, yaw)):
            return f"pose ({p.x:.6g}, {p.y:.6g}, {yaw:.6g}) not finite within ±{MAX_COORDINATE_M:g}"
        try:
            self.model.set_pose(p.x, p.y, yaw)
        except InputError as err:
            return str(err)
        return None

    def _on_set_pose(self, msg: PoseStamped) -> None:
        refused = self.place(msg)
        if refused is not None:
            self.warn_throttled("set_pose", f"set_pose ignored: {refused}")

    def _on_set_pose_service(self, request: Any, response: Any) -> Any:
        refused = self.place(request.pose)
        response.success = refused is None
        if refused is None:
            x, y, theta = self.model.pose
            response.message = f"robot at ({x:.6g}, {y:.6g}, {theta:.6g}) in the map"
        else:
            response.message = f"set_pose refused: {refused}"
        return response

    def _on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.model.reset()
        self._delayed_cmds.clear()
        self._last_cmd_time = None
        self.buttons_state = [0, 0]
        response.success = True
        response.message = "robot back at its initial pose, stopped, odometry cleared"
        return response

    def _on_button(self, index: int, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        # The original GUI's buttons are toggles that stay down until pressed again (several may be down).
        self.buttons_state[index] = int(bool(request.data))
        response.success = True
        response.message = "pressed" if request.data else "released"
        return response

    # ---------------------------------------------------------------- stepping
    def physics_step(self) -> None:
        """Apply due commands, advance the model one fixed step, release due sensor messages."""
        now = self.sim_time
        self._apply_due_commands(now)
        self.model.step(self.physics_dt)
        self._flush_delayed(now + self.physics_dt)

    def _flush_delayed(self, now: float) -> None:
        queue = self._delayed_msgs
        while queue and queue[0][0] <= now + 1e-9:
            _, publisher, msg = queue.popleft()
            publisher.publish(msg)

    def _message(self, publisher: Publisher) -> Any:
        """The message to fill for ``publisher``, its constant fields already set: one object reused
        for every publication (rclpy serialises on publish), or a fresh one while ``com_delay``
        holds messages back. Building messages is most of a world's cost at real_time_factor 0."""
        if self.com_delay > 0.0:
            return self._templates[publisher]()
        msg = self._reusable.get(publisher)
        if msg is None:
            msg = self._reusable[publisher] = self._templates[publisher]()
        return msg

    def _send(self, publisher: Publisher, msg: object) -> None:
        if self.com_delay > 0.0:
            self._delayed_msgs.append((self.sim_time + self.com_delay, publisher, msg))
        else:
            publisher.publish(msg)

    # ---------------------------------------------------------------- sensors
    def _make_templates(self) -> None:
        """Per publisher, a factory of its message with the fields that never change."""
        templates = {**self._detector_templates(), **self._range_templates(), **self._state_templates()}
        if self.tf.publisher is not None:
            moving = [(self.frame("odom"), self.frame("base_link"))]
            if self.publish_map_tf:
                moving.append(("map", self.frame("odom")))
            # the wheels, as robot_state_publisher would send them from joint_states (last two)
            half = 0.5 * WHEEL_BASE_M
            base = self.frame("base_link")
            wheels = [(half, self.frame(WHEEL_JOINTS[0])), (-half, self.frame(WHEEL_JOINTS[1]))]
            templates[self.tf.publisher] = lambda: self.tf.message(
                [transform_msg(p, c, 0.0, 0.0) for p, c in moving]
                + [transform_msg(base, joint.removesuffix("_joint"), 0.0, y, WHEEL_RADIUS_M) for y, joint in wheels]
            )
        self._templates: dict[Publisher, Callable[[], Any]] = templates
        self._reusable: dict[Publisher, Any] = {}

    def _variance(self, sensor: str) -> float:
        """The config noise's variance (its std squared): what the readings scatter by."""
        return self.noise.noise[sensor][1] ** 2

    def _detector(self, frame: str, distance: float, fov: float, variance: float = 0.0) -> Callable[[], Range]:
        # REP-117 fixed-distance detector: min == max, -inf = detection, +inf = nothing.
        return _stamped(
            Range,
            self.frame(frame),
            radiation_type=Range.INFRARED,
            field_of_view=fov,
            min_range=distance,
            max_range=distance,
            variance=variance,
        )

    def _detector_templates(self) -> dict[Publisher, Callable[[], Any]]:
        """Bumpers, the IR wall sensor, the virtual-wall receiver and the cliff sensors."""
        return {
            self.pub_bump[0]: self._detector("bump_left", 0.0, BUMP_FOV),
            self.pub_bump[1]: self._detector("bump_right", 0.0, BUMP_FOV),
            self.pub_wall: self._detector("wall_ir", CreateModel.IR_RANGE, 0.0, self._variance("wall")),
            self.pub_virtual_wall: self._detector("virtual_wall_ir", 0.0, 2 * math.pi),
            **{
                pub: _stamped(Illuminance, self.frame(f"cliff_{name}"), variance=self._variance("cliff"))
                for pub, name in zip(self.pub_cliff, CLIFF_NAMES, strict=True)
            },
        }

    def _range_templates(self) -> dict[Publisher, Callable[[], Any]]:
        """The sonars and the LIDAR."""
        m = CreateModel
        lo, hi = m.LIDAR_RANGE
        scan_rate = self.rates["scan"] or 1.0
        templates: dict[Publisher, Callable[[], Any]] = {
            pub: _stamped(
                Range,
                self.frame(f"sonar_{name}"),
                radiation_type=Range.ULTRASOUND,
                field_of_view=SONAR_FIELD_OF_VIEW,
                variance=self._variance("sonar"),
                min_range=m.SONAR_RANGE[0],
                max_range=m.SONAR_RANGE[1],
            )
            for pub, name in zip(self.pub_sonar, SONAR_NAMES, strict=True)
        }
        templates[self.pub_scan] = _stamped(
            LaserScan,
            self.frame("laser"),
            angle_min=-m.LIDAR_FOV / 2,
            angle_max=m.LIDAR_FOV / 2,
            angle_increment=m.LIDAR_FOV / (m.LIDAR_BEAMS - 1),
            time_increment=0.0,
            scan_time=1.0 / scan_rate,
            range_min=lo,
            range_max=hi,
        )
        return templates

    def _state_templates(self) -> dict[Publisher, Callable[[], Any]]:
        """Odometry, the ground-truth pose, the buttons and the battery."""
        m = CreateModel
        return {
            self.pub_odom: _stamped(Odometry, self.frame("odom"), child_frame_id=self.frame("base_link")),
            self.pub_overhead: _stamped(PoseStamped, "map"),
            self.pub_buttons: _stamped(Joy, self.frame("base_link")),
            self.pub_joints: _stamped(
                JointState, self.frame("base_link"), name=[self.prefix + joint for joint in WHEEL_JOINTS]
            ),
            self.pub_battery: _stamped(
                BatteryState,
                self.frame("base_link"),  # the original's battery readings are constants
                voltage=m.BATTERY_VOLTAGE,
                current=m.BATTERY_CURRENT,
                temperature=m.TEMPERATURE,
                charge=m.BATTERY_CHARGE,
                capacity=m.BATTERY_CAPACITY,
                design_capacity=m.BATTERY_CAPACITY,
                percentage=1.0,
                present=True,
                power_supply_status=BatteryState.POWER_SUPPLY_STATUS_DISCHARGING,
                power_supply_health=BatteryState.POWER_SUPPLY_HEALTH_GOOD,
                power_supply_technology=BatteryState.POWER_SUPPLY_TECHNOLOGY_NIMH,
            ),
        }

    def _publish_detections(self, publishers: list[Publisher], detected: Sequence[bool] | np.ndarray) -> None:
        stamp = self.stamp()
        for publisher, hit in zip(publishers, detected, strict=True):
            msg = self._message(publisher)
            msg.header.stamp = stamp
            msg.range = -math.inf if hit else math.inf
            self._send(publisher, msg)

    def _publish_bumps(self, bumps: tuple[bool, bool]) -> None:
        self._publish_detections(self.pub_bump, bumps)

    def _publish_wall(self, detected: bool) -> None:
        self._publish_detections([self.pub_wall], [detected])

    def _publish_virtual_wall(self, detected: bool) -> None:
        self._publish_detections([self.pub_virtual_wall], [detected])

    def _publish_cliffs(self, signals: np.ndarray) -> None:
        stamp = self.stamp()
        for publisher, value in zip(self.pub_cliff, signals.tolist(), strict=True):
            msg = self._message(publisher)
            msg.header.stamp = stamp
            msg.illuminance = value
            self._send(publisher, msg)

    def _publish_sonar(self, ranges: np.ndarray) -> None:
        stamp = self.stamp()
        for publisher, value in zip(self.pub_sonar, ranges.tolist(), strict=True):
            msg = self._message(publisher)
            msg.header.stamp = stamp
            msg.range = value
            self._send(publisher, msg)

    def _publish_scan(self, ranges: np.ndarray) -> None:
        msg = self._message(self.pub_scan)
        msg.header.stamp = self.stamp()
        msg.ranges = float32_array(ranges)
        self._send(self.pub_scan, msg)

    def _publish_camera(self, sightings: list[BeaconSighting]) -> None:
        stamp = self.stamp()
        frame = self.frame("camera")
        lifetime = _duration(2.0 / self.rates["camera"])  # sightings vanish in RViz once they stop coming
        markers = []
        for i, sighting in enumerate(sightings):
            m = Marker(
                ns=BEACONS_NS,
                id=i,
                type=Marker.SPHERE,
                action=Marker.ADD,
                text=sighting.id,
                lifetime=lifetime,
                scale=Vector3(x=0.1, y=0.1, z=0.1),
                color=color_msg(*sighting.rgb),
                pose=pose_msg(
                    sighting.distance * math.cos(sighting.angle), sighting.distance * math.sin(sighting.angle), 0.0
                ),
            )
            m.header.stamp = stamp
            m.header.frame_id = frame
            markers.append(m)
        self._send(self.pub_camera, MarkerArray(markers=markers))

    def _publish_odom(self) -> None:
        """Odometry (with covariances from the config noise) and ``odom → base_link`` on /tf."""
        x, y, theta = self.model.odometry_pose.tolist()
        stamp = self.stamp()
        if self.pub_odom.get_subscription_count():
            v, w = self.model.velocity
            msg = self._message(self.pub_odom)
            msg.header.stamp = stamp
            set_planar_pose(msg.pose.pose, x, y, theta)
            msg.twist.twist.linear.x = float(v)
            msg.twist.twist.angular.z = float(w)
            msg.pose.covariance, msg.twist.covariance = self._odometry_covariances(v, w)
            self._send(self.pub_odom, msg)
        if self.pub_joints.get_subscription_count():
            self._publish_wheels(stamp)
        tf_pub = self.tf.publisher
        if tf_pub is not None and self.tf.heard():
            msg = self._message(tf_pub)
            odom_to_base = msg.transforms[0]
            odom_to_base.header.stamp = stamp
            set_planar(odom_to_base, x, y, theta)
            if self.publish_map_tf:
                map_to_odom = msg.transforms[1]
                map_to_odom.header.stamp = stamp
                set_planar(map_to_odom, *self._map_to_odom(x, y, theta))
            for wheel, angle in zip(msg.transforms[-2:], self._wheel_angles(), strict=True):
                wheel.header.stamp = stamp
                wheel.transform.rotation.y, wheel.transform.rotation.w = math.sin(0.5 * angle), math.cos(0.5 * angle)
            self._send(tf_pub, msg)

    def _odometry_covariances(self, v: float, w: float) -> tuple[np.ndarray, np.ndarray]:
        """Row-major 6x6 pose and twist covariances (x, y, z, roll, pitch, yaw) of the odometry.

        The config noise: distance and turn errors are proportional to each step's motion; a heading
        error also moves the position sideways by about the distance driven. Added to it, never
        absent (an EKF cannot fuse a zero variance), the rounding variance (step²/12) of what the
        Create resolves (:data:`create_sim.spec.ODOMETRY_RESOLUTION`: 1 mm, 1 degree, 1 mm/s per
        wheel). z, roll and pitch are exact (a planar robot): zero."""
        std = self.noise.noise["odometry"][1]
        var_dist, var_turn = self.model.odometry_variance
        distance = abs(self.model.odometry_totals[0])
        pose = np.zeros(36)
        pose[0] = pose[7] = var_dist + distance * distance * var_turn + POSE_RESOLUTION_VARIANCE[0]
        pose[35] = var_turn + POSE_RESOLUTION_VARIANCE[1]
        twist = np.zeros(36)
        twist[0] = (std * v) ** 2 + TWIST_RESOLUTION_VARIANCE[0]
        twist[35] = (std * w) ** 2 + TWIST_RESOLUTION_VARIANCE[1]
        return pose, twist

    def _wheel_angles(self) -> tuple[float, float]:
        """Left and right wheel angles (rad) from the odometry, as encoders give them: each wheel
        travels the distance driven minus / plus half the wheel base per radian turned."""
        distance, turn = self.model.odometry_totals
        half = 0.5 * WHEEL_BASE_M
        return (distance - half * turn) / WHEEL_RADIUS_M, (distance + half * turn) / WHEEL_RADIUS_M

    def _publish_wheels(self, stamp: Time) -> None:
        """``joint_states`` of the two wheels: angles (:meth:`_wheel_angles`) and speeds (rad/s)."""
        v, w = (float(c) for c in self.model.velocity)
        half = 0.5 * WHEEL_BASE_M
        msg = self._message(self.pub_joints)
        msg.header.stamp = stamp
        msg.position = list(self._wheel_angles())
        msg.velocity = [(v - half * w) / WHEEL_RADIUS_M, (v + half * w) / WHEEL_RADIUS_M]
        self._send(self.pub_joints, msg)

    def _map_to_odom(self, odom_x: float, odom_y: float, odom_theta: float) -> tuple[float, float, float]:
        """Ground truth ``map → odom`` (x, y, yaw): where the odometry frame's origin really is."""
        x, y, theta = self.model.pose.tolist()
        return odometry_origin((x, y, theta), (odom_x, odom_y, odom_theta))

    def _publish_static_transforms(self) -> None:
        self.tf.send_static(static_transforms(self.prefix), self.stamp())

    def _publish_overhead(self) -> None:
        msg = self._message(self.pub_overhead)
        msg.header.stamp = self.stamp()
        set_planar_pose(msg.pose, *self.model.pose.tolist())
        self._send(self.pub_overhead, msg)

    def _publish_buttons(self) -> None:
        msg = self._message(self.pub_buttons)
        msg.header.stamp = self.stamp()
        msg.buttons = list(self.buttons_state)
        self._send(self.pub_buttons, msg)

    def _publish_battery(self) -> None:
        msg = self._message(self.pub_battery)
        msg.header.stamp = self.stamp()
        self._send(self.pub_battery, msg)

    # ---------------------------------------------------------------- the map
    def _publish_map(self) -> None:
        """The latched ``map_markers`` and the occupancy grid of the walls on ``map``.

        A map without walls has no grid (map_server, too, publishes only a map it loaded): no
        ``map`` message, and switching to such a map withdraws the latched one, so nobody joining
        later gets the old walls."""
        stamp = self.stamp()
        if max(len(self.map.walls), len(self.map.lines)) > MAX_MARKER_SEGMENTS:
            self.get_logger().warning(
                f"map_markers: more than {MAX_MARKER_SEGMENTS:,} walls or lines; showing the first "
                f"{MAX_MARKER_SEGMENTS:,} of each (the map grid has them all)"
            )
        with self.starting("drawing map_markers"):
            self.pub_map_markers.publish(map_markers(self.map, stamp))
        if len(self.map.walls) == 0:
            if self._map_published:
                self.destroy_publisher(self.pub_map)  # its latched grid goes with it
                self.pub_map = self.create_publisher(OccupancyGrid, "map", LATCHED_QOS)
                self._map_published = False
            return
        self._map_published = True
        with self.starting(f"rasterising {len(self.map.walls):,} walls for the map grid") as phase:
            raster = rasterise_walls(self.map.walls, self.map_resolution, progress=phase.progress)
        if raster.resolution_m != self.map_resolution:
            self.get_logger().warning(
                f"map: {self.map_resolution:g} m cells would be more than {MAX_MAP_CELLS:,} over this map's "
                f"walls; published with {raster.resolution_m:g} m cells"
            )
        origin = (raster.origin_x_m, raster.origin_y_m)
        self.pub_map.publish(occupancy_grid_msg(raster.occupied, raster.resolution_m, origin, stamp))


#: A map file larger than this (bytes) is announced before it is read.
BIG_FILE_BYTES = 8_000_000

#: Most walls (and floor lines) drawn on ``map_markers``: beyond, the first ones (``map`` has all).
MAX_MARKER_SEGMENTS = 100_000


def static_transforms(prefix: str) -> list[TransformStamped]:
    """Everything on ``/tf_static``: the sensors' mounts and ``base_link → base_footprint``
    (REP-120, identity: ``base_link`` is on the floor)."""
    footprint = transform_msg(prefix + "base_link", prefix + FOOTPRINT_FRAME, 0.0, 0.0)
    return [*sensor_transforms(prefix), footprint]


def sensor_transforms(prefix: str) -> list[TransformStamped]:
    """What ``/tf_static`` carries: ``<prefix>base_link → <prefix><sensor>`` at every sensor's
    mount (stamps left zero)."""
    base = prefix + "base_link"
    return [
        transform_msg(base, prefix + name, mount.x_m, mount.y_m, mount.z_m, mount.yaw_rad)
        for name, mount in SENSOR_MOUNTS.items()
    ]


def _stamped(msg_type: Callable[..., Any], frame: str, **fields: Any) -> Callable[[], Any]:
    """A factory of ``msg_type(**fields)`` with ``header.frame_id = frame``."""

    def make() -> Any:
        msg = msg_type(**fields)
        msg.header.frame_id = frame
        return msg

    return make


def _duration(seconds: float) -> Duration:
    nanoseconds = round(seconds * 1e9)
    return Duration(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def _segment_points(segments: np.ndarray, z: float = 0.0) -> list[Point]:
    return [Point(x=float(x), y=float(y), z=z) for x, y in segments.reshape(-1, 2)]


def _line_list(ns: str, segments: np.ndarray, rgb: tuple[float, float, float], width: float, stamp: Time) -> Marker:
    m = Marker(ns=ns, id=0, type=Marker.LINE_LIST, action=Marker.ADD, points=_segment_points(segments))
    m.header.frame_id = "map"
    m.header.stamp = stamp
    m.pose.orientation.w = 1.0
    m.scale.x = width
    m.color = color_msg(*rgb)
    return m


def map_markers(create_map: CreateMap, stamp: Time) -> MarkerArray:
    """RViz markers of a map: walls, floor lines, beacons with their ids, virtual-wall halos and fields.

    Namespaces (named in :mod:`create_sim.spec`): ``walls`` and ``lines`` (one LINE_LIST each),
    ``beacons`` (a SPHERE per beacon) and ``beacon_ids`` (a TEXT_VIEW_FACING per beacon, text = id),
    ``virtual_wall_halos`` and ``virtual_wall_fields`` (a LINE_STRIP per virtual wall); marker ids
    are the row index.
    """
    markers = [  # RViz draws a million segments no better than these; building them took a minute
        _line_list(WALLS_NS, create_map.walls[:MAX_MARKER_SEGMENTS], WALL_RGB, WALL_THICKNESS_M, stamp),
        _line_list(LINES_NS, create_map.lines[:MAX_MARKER_SEGMENTS], LINE_RGB, 0.02, stamp),
    ]
    beacons = zip(create_map.beacon_xy, create_map.beacon_rgb, create_map.beacon_ids, strict=True)
    for i, ((bx, by), rgb, beacon_id) in enumerate(beacons):
        ball = Marker(ns=BEACONS_NS, id=i, type=Marker.SPHERE, action=Marker.ADD, text=beacon_id)
        ball.pose = pose_msg(float(bx), float(by), 0.0)
        ball.scale = Vector3(x=0.1, y=0.1, z=0.1)
        ball.color = color_msg(*(float(c) for c in rgb))
        label = Marker(ns=BEACON_IDS_NS, id=i, type=Marker.TEXT_VIEW_FACING, action=Marker.ADD, text=beacon_id)
        label.pose = pose_msg(float(bx), float(by), 0.2)
        label.scale.z = 0.15
        label.color = color_msg(0.0, 0.0, 0.0)
        markers += [ball, label]
    circle = np.linspace(0.0, 2 * math.pi, 33)
    for i, (vx, vy, vtheta, setting) in enumerate(create_map.virtwalls):
        halo = np.column_stack([vx + VWALL_HALO_M * np.cos(circle), vy + VWALL_HALO_M * np.sin(circle)])
        field = virtual_wall_field(vx, vy, vtheta, setting)
        for ns, points in ((VIRTUAL_WALL_HALOS_NS, halo), (VIRTUAL_WALL_FIELDS_NS, np.vstack([field, field[:1]]))):
            m = Marker(ns=ns, id=i, type=Marker.LINE_STRIP, action=Marker.ADD, points=_segment_points(points))
            m.pose.orientation.w = 1.0
            m.scale.x = 0.02
            m.color = color_msg(*VIRTUAL_WALL_RGBA)
            markers.append(m)
    for m in markers:
        m.header.frame_id = "map"
        m.header.stamp = stamp
    return MarkerArray(markers=markers)


def main(args: list[str] | None = None) -> int:
    """Entry point ``create_world``."""
    return run_nodes(lambda: [CreateWorldNode()], args)
