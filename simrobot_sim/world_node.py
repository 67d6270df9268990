"""``simrobot_world``: a SIMROBOT world (many robots on a bitmap map) on ROS 2.

A thin mapping of :class:`simrobot_sim.model.SimrobotWorld` onto topics, services and TF, all
relative to the node's namespace; the interface is in ``docs/executables.md``. What the code below
has to keep true:

- one physics step is the world file's ``dt``; after each step every robot's sensors, odometry,
  pose and ``/tf`` are published, stamped with the step's sim time;
- a command holds until the next one (the original's setvel); NaN/inf or absurd commands are
  rejected with a throttled warning;
- lockstep (``lockstep: true``): after publishing step k the world waits until every powered,
  non-crashed robot has answered step k (unstamped commands count on arrival, stamped ones when
  stamped with step k's time; older stamps are stale), re-publishing the step's data every 0.5 s
  while it waits, and steps on with a warning after ``lockstep_timeout`` wall seconds: a run is
  then identical whatever the machine's load;
- robots naming a ``controller`` (``avoid``: the original's alg2) get that node in this process;
  robots naming an ``algorithm`` m-file run it in one Octave session of this process, called
  before each step (they count as answered in lockstep; see ``simrobot_sim.matlab_alg``).
"""

from __future__ import annotations

import array
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import rclpy.logging
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped, TransformStamped, Twist, TwistStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.service import Service
from rclpy.subscription import Subscription
from sensor_msgs.msg import JointState, LaserScan, Range
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension, UInt8
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import Marker, MarkerArray

from sim_runtime.errors import InputError
from sim_runtime.inputfile import shown
from sim_runtime.kernels import announce_compiling
from sim_runtime.msgs import (
    ABSURD_COMMAND,
    color_msg,
    command_ok,
    float32_array,
    occupancy_grid_msg,
    quaternion_from_yaw,
    set_planar_pose,
    time_from_msg,
)
from sim_runtime.paths import resolve_input_file
from sim_runtime.qos import COMMAND_SUBSCRIBER_QOS, LATCHED_QOS, SENSOR_PUBLISHER_QOS
from sim_runtime.run import run_nodes
from sim_runtime.tf import TfBroadcaster, set_planar, transform_msg
from sim_runtime.world_node import SimWorldNode, namespace_prefix, startup_phase
from simrobot_sim.matlab_alg import OctaveAlgorithms
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.spec import (
    CLEAR_CRASH_SERVICE,
    CMD_VEL_TOPIC,
    CRASHED_TOPIC,
    FOOTPRINT_FRAME,
    MAP_TOPIC,
    OBSTACLE_SUFFIX,
    ODOM_TOPIC,
    POSE_TOPIC,
    POWER_TOPIC,
    ROBOT_STATE_FIELDS,
    ROBOT_STATES_TOPIC,
    ROBOTS_NS,
    ROBOTS_TOPIC,
    SET_POWER_SERVICE,
    WHEEL_CMD_TOPIC,
    frame_name,
    robot_topic,
    sensor_mount,
)
from simrobot_sim.world_file import WorldSpec, load_world

#: Wall seconds between re-publications of a step's data while lockstep waits.
REPUBLISH_PERIOD = 0.5


class _RobotIO:
    """Pre-built messages and endpoints of one robot (reused every step: no per-step allocation)."""

    __slots__ = ("crashed_pub", "msgs", "odom", "odom_pub", "pose", "pose_pub", "power_pub", "pubs", "services", "subs")

    #: Per sensor: (sensor index, "laser" or "ultrasonic", its publisher, the obstacle-value
    #: publisher of an ultrasonic sensor or None) ...
    pubs: list[tuple[int, str, Publisher, Publisher | None]]
    #: ... and its message with the obstacle-value message (None for a laser).
    msgs: list[tuple[LaserScan | Range, UInt8 | None]]
    odom_pub: Publisher
    odom: Odometry
    pose_pub: Publisher
    pose: PoseStamped
    crashed_pub: Publisher
    power_pub: Publisher
    subs: list[Subscription]
    services: list[Service]


class SimrobotWorldNode(SimWorldNode):
    """A SIMROBOT world on ROS 2: see the module docstring for the interface."""

    def __init__(self, spec: WorldSpec | None = None, node_name: str = "simrobot_world", **node_kwargs: Any) -> None:
        """Load ``spec`` or, when None, the world file named by parameter ``world_file``."""
        if spec is None:
            # parameters exist only once the node does: peek at world_file through a short-lived node
            spec = _spec_from_parameter(node_name, node_kwargs)
        self.spec = spec
        super().__init__(node_name, physics_rate=1.0 / spec.dt, **node_kwargs)
        self.declare_checked(
            "world_file",
            spec.source,
            None,
            "world file (YAML): a path, or relative to the current directory or to the shipped config/",
        )
        self.cmd_vel_stamped = self.declare_checked(
            "cmd_vel_stamped",
            False,
            None,
            "subscribe geometry_msgs/TwistStamped on cmd_vel (its stamp then counts like wheel_cmd's in lockstep)",
        )
        prefix = self.declare_checked(
            "frame_prefix", "", None, "prefix of every robot's frames ('' = from the namespace: /sim1 -> sim1/)"
        )
        self.prefix = prefix or namespace_prefix(self.get_namespace())
        outline_bodies = self.declare_checked(
            "outline_bodies",
            False,
            None,
            "robots occupy only the cells of their outline, as the original paints them (sensors see and "
            "robots collide with the outline alone); off: every cell a robot overlaps",
        )
        see_own_robot = self.declare_checked(
            "see_own_robot",
            False,
            lambda v: not v or spec.sensor_model == "original",
            "with the world file's sensor_model: original, a sensor sees its own robot too (reading 0 where "
            "it lies on its outline), as the original's",
        )
        self.parameters_declared()
        with announce_compiling(self.get_logger().info), self.starting("building the world model"):
            self.model = SimrobotWorld(spec, outline_bodies=outline_bodies, see_own_robot=see_own_robot)
            self.model.compile_kernels()  # now: not at the first step after "ready"
        self.lockstep = bool(spec.lockstep)
        self.lockstep_timeout = float(spec.lockstep_timeout)
        n = len(self.model.names)
        self._answered = np.zeros(n, dtype=bool)
        self._algorithms = self._start_algorithms()
        self._published_wall = time.monotonic()
        self._republished_wall = self._published_wall
        self._io = [self._make_robot_io(i) for i in range(n)]
        self._map_pub = self.create_publisher(OccupancyGrid, MAP_TOPIC, LATCHED_QOS)
        self._map_pub.publish(self._map_msg())
        self._robots_pub = self.create_publisher(MarkerArray, ROBOTS_TOPIC, SENSOR_PUBLISHER_QOS)
        self._markers = self._marker_msgs()
        self._states_pub = self.create_publisher(Float64MultiArray, ROBOT_STATES_TOPIC, SENSOR_PUBLISHER_QOS)
        self._states = self._states_msg()
        for i in range(n):
            self._io[i].crashed_pub.publish(Bool(data=False))
            self._io[i].power_pub.publish(Bool(data=bool(self.model.power[i])))
        self.tf = TfBroadcaster(self)
        # /tf messages reused every step: rclpy serialises on publish
        self._odom_tf = [
            transform_msg(self.robot_frame(i, ODOM_TOPIC), self.robot_frame(i, "base_link"), 0.0, 0.0) for i in range(n)
        ]
        self.tf.send_static(static_transforms(self.spec, self.prefix), self.stamp())
        self.every(self.physics_rate, self._publish_step)
        self._publish_step()
        nx, ny = self.model.grid.shape
        self.get_logger().info(
            f"world {spec.source}: {n} robots on a {nx}x{ny} map at {spec.resolution:g} m/cell, "
            f"dt {spec.dt:g} s{', lockstep' if self.lockstep else ''}; {self.pace_text()}"
        )

    # -- construction -----------------------------------------------------------------------
    def _start_algorithms(self) -> OctaveAlgorithms | None:
        # robots driven by m-files: their algorithms set their commands right before each step
        files = {i: Path(r.algorithm) for i, r in enumerate(self.spec.robots) if r.algorithm}
        self._hosted = np.zeros(len(self.spec.robots), dtype=bool)
        self._hosted[list(files)] = True
        if not files:
            return None
        algorithms = OctaveAlgorithms(
            self.model,
            files,
            report=self.get_logger().error,
            timeout=self.spec.lockstep_timeout,
            output=self.get_logger().info,  # what the algorithms print
        )
        self.get_logger().info(f"{len(files)} robots run algorithm m-files in Octave")
        return algorithms

    def destroy_node(self) -> None:
        """Also end the Octave session of the algorithm m-files."""
        if self._algorithms is not None:
            self._algorithms.close()
        super().destroy_node()  # type: ignore[no-untyped-call]  # rclpy leaves Node.destroy_node unannotated

    def _make_robot_io(self, i: int) -> _RobotIO:
        model = self.model
        name = model.names[i]
        io = _RobotIO()
        io.pubs = []
        io.msgs = []
        for k, s in enumerate(model.sensors):
            if s.robot != i:
                continue
            frame = frame_name(self.prefix, name, s.name)
            if s.kind == "laser":
                msg = LaserScan()
                msg.header.frame_id = frame
                msg.angle_min = s.angle_min
                msg.angle_max = s.angle_max
                msg.angle_increment = s.angle_increment
                msg.range_min = 0.0
                msg.range_max = float(s.range)
                msg.scan_time = float(self.spec.dt)
                pub = self.create_publisher(LaserScan, robot_topic(name, s.name), SENSOR_PUBLISHER_QOS)
                io.pubs.append((k, "laser", pub, None))
                io.msgs.append((msg, None))
            else:
                msg = Range()
                msg.header.frame_id = frame
                msg.radiation_type = Range.ULTRASOUND
                msg.field_of_view = float(s.beamwidth)
                msg.min_range = 0.0
                msg.max_range = float(s.range)
                pub = self.create_publisher(Range, robot_topic(name, s.name), SENSOR_PUBLISHER_QOS)
                obst_pub = self.create_publisher(
                    UInt8, robot_topic(name, f"{s.name}/{OBSTACLE_SUFFIX}"), SENSOR_PUBLISHER_QOS
                )
                io.pubs.append((k, "ultrasonic", pub, obst_pub))
                io.msgs.append((msg, UInt8()))
        io.odom_pub = self.create_publisher(Odometry, robot_topic(name, ODOM_TOPIC), SENSOR_PUBLISHER_QOS)
        io.odom = Odometry()
        io.odom.header.frame_id = frame_name(self.prefix, name, ODOM_TOPIC)
        io.odom.child_frame_id = frame_name(self.prefix, name, "base_link")
        io.odom.pose.covariance, io.odom.twist.covariance = odometry_covariances(self.spec)
        io.pose_pub = self.create_publisher(PoseStamped, robot_topic(name, POSE_TOPIC), SENSOR_PUBLISHER_QOS)
        io.pose = PoseStamped()
        io.pose.header.frame_id = "map"
        io.crashed_pub = self.create_publisher(Bool, robot_topic(name, CRASHED_TOPIC), LATCHED_QOS)
        io.power_pub = self.create_publisher(Bool, robot_topic(name, POWER_TOPIC), LATCHED_QOS)
        io.subs = [
            self.create_subscription(
                TwistStamped if self.cmd_vel_stamped else Twist,
                robot_topic(name, CMD_VEL_TOPIC),
                partial(self._on_cmd_vel, i),
                COMMAND_SUBSCRIBER_QOS,
            ),
            self.create_subscription(
                JointState, robot_topic(name, WHEEL_CMD_TOPIC), partial(self._on_wheel_cmd, i), COMMAND_SUBSCRIBER_QOS
            ),
        ]
        io.services = [
            self.create_service(SetBool, robot_topic(name, SET_POWER_SERVICE), partial(self._on_set_power, i)),
            self.create_service(Trigger, robot_topic(name, CLEAR_CRASH_SERVICE), partial(self._on_clear_crash, i)),
        ]
        return io

    def robot_frame(self, i: int, name: str) -> str:
        """Frame ``name`` of robot ``i``, e.g. ``r1/base_link`` (with the world's prefix in front)."""
        return frame_name(self.prefix, self.model.names[i], name)

    def _map_msg(self) -> OccupancyGrid:
        # OccupancyGrid rows run along y: the transpose of grid[x, y]
        x, y = self.model.origin
        return occupancy_grid_msg(self.spec.walls.T, self.model.resolution, (float(x), float(y)), self.stamp())

    def _marker_msgs(self) -> MarkerArray:
        model = self.model
        out = MarkerArray()
        for i in range(len(model.names)):
            m = Marker()
            m.header.frame_id = "map"
            m.ns = ROBOTS_NS
            m.id = i
            m.type = Marker.LINE_STRIP
            m.action = Marker.ADD
            m.scale.x = max(model.resolution, 0.002)
            m.color = color_msg(*model.colors[i])
            verts = model.shape(i)
            m.points = [Point(x=float(x), y=float(y)) for x, y in np.vstack([verts, verts[:1]])]
            out.markers.append(m)
        return out

    def _states_msg(self) -> Float64MultiArray:
        """``robot_states``: the whole world in one flat message a viewer decodes with one numpy
        call, however many robots: [sim time, robots n, sensors k, then per robot x, y, heading,
        crashed, power (n x 5), then per sensor its nearest hit in metres (k, inf = none)]."""
        n, k = len(self.model.names), len(self.model.sensors)
        msg = Float64MultiArray()
        msg.layout.dim = [
            MultiArrayDimension(label="header", size=3, stride=3),
            MultiArrayDimension(label="robots", size=n, stride=ROBOT_STATE_FIELDS),
            MultiArrayDimension(label="sensors", size=k, stride=1),
        ]
        self._states_data = np.zeros(3 + ROBOT_STATE_FIELDS * n + k)
        self._states_data[1:3] = n, k
        return msg

    # -- commands ---------------------------------------------------------------------------
    def _counts_for_step(self, stamp: Time) -> bool:
        if stamp.sec == 0 and stamp.nanosec == 0:
            return True  # unstamped: counts by arrival
        return time_from_msg(stamp) >= self.sim_time - 0.5 * self.physics_dt

    def _on_cmd_vel(self, i: int, msg: Twist | TwistStamped) -> None:
        if isinstance(msg, TwistStamped):
            if not self._counts_for_step(msg.header.stamp):
                return  # stale: an answer to an older step
            msg = msg.twist
        v, w = msg.linear.x, msg.angular.z
        if not command_ok(v, w):
            self.warn_throttled(
                f"cmd_vel{i}",
                f"/{self.model.names[i]}/cmd_vel ignored: v={v!r} w={w!r} is not "
                f"finite or absurdly large (|value| > {ABSURD_COMMAND:g})",
            )
            return
        try:
            self.model.set_cmd_vel(i, v, w)
        except InputError as err:
            self.warn_throttled(f"cmd_vel{i}", f"cmd_vel ignored: {err}")
            return
        self._answered[i] = True

    def _on_wheel_cmd(self, i: int, msg: JointState) -> None:
        name = self.model.names[i]
        if not self._counts_for_step(msg.header.stamp):
            # an answer to an older step (e.g. to a re-publication) must not override this one
            return
        if len(msg.velocity) != 2:
            self.warn_throttled(
                f"wheel{i}", f"{name}/wheel_cmd ignored: velocity must be [left, right], got {list(msg.velocity)}"
            )
            return
        if not command_ok(*msg.velocity):
            self.warn_throttled(
                f"wheel{i}",
                f"{name}/wheel_cmd ignored: {list(msg.velocity)} is not finite or "
                f"absurdly large (|value| > {ABSURD_COMMAND:g} rad/s)",
            )
            return
        try:
            self.model.set_wheel_speeds(i, float(msg.velocity[0]), float(msg.velocity[1]))
        except InputError as err:
            self.warn_throttled(f"wheel{i}", f"{name}/wheel_cmd ignored: {err}")
            return
        self._answered[i] = True

    def _on_set_power(self, i: int, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.model.set_power(i, request.data)
        self._io[i].power_pub.publish(Bool(data=bool(request.data)))
        response.success = True
        response.message = f"{self.model.names[i]} power {'on' if request.data else 'off'}"
        return response

    def _on_clear_crash(self, i: int, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        was = bool(self.model.crashed[i])
        self.model.clear_crash(i)
        if was:
            self._io[i].crashed_pub.publish(Bool(data=False))
        response.success = True
        name = self.model.names[i]
        response.message = f"{name} crash flag cleared" if was else f"{name} was not crashed"
        return response

    # -- time -------------------------------------------------------------------------------
    def ready_to_step(self) -> bool:
        """False once ``steps_limit`` is reached; in lockstep, also until every powered,
        non-crashed robot answered the current step or ``lockstep_timeout`` passed."""
        if not super().ready_to_step():
            return False
        if not self.lockstep:
            return True
        model = self.model
        waiting = model.power & ~model.crashed & ~self._answered
        waiting &= ~self._hosted  # the algorithm m-files answer in physics_step
        if not waiting.any():
            return True
        now = time.monotonic()
        if now - self._published_wall > self.lockstep_timeout:
            names = ", ".join(model.names[i] for i in np.flatnonzero(waiting)[:10])
            self.warn_throttled(
                "lockstep",
                f"lockstep: no command for step {self.step_count} from {names} after "
                f"{self.lockstep_timeout} s; stepping on",
            )
            return True
        if now - self._republished_wall > REPUBLISH_PERIOD:
            self._republished_wall = now
            self._publish_step()
        return False

    def physics_step(self) -> None:
        """Run the algorithm m-files, move every robot one ``dt``; announce new crashes."""
        if self._algorithms is not None:
            self._run_algorithms(self._algorithms)
        for i in self.model.step():
            self._io[i].crashed_pub.publish(Bool(data=True))
        self._answered[:] = False
        if self.model.step_count >= self.spec.steps_limit and not self.finished:
            self.finished = True
            self.get_logger().info(f"steps_limit {int(self.model.step_count)} reached: the world stops")

    def _run_algorithms(self, algorithms: OctaveAlgorithms) -> None:
        # an algorithm may switch its robot's power or clear its crash: say so as the services do
        model = self.model
        power, crashed = model.power.copy(), model.crashed.copy()
        algorithms.run()
        for i in np.flatnonzero(power != model.power):
            self._io[i].power_pub.publish(Bool(data=bool(model.power[i])))
        for i in np.flatnonzero(crashed != model.crashed):
            self._io[i].crashed_pub.publish(Bool(data=bool(model.crashed[i])))

    def _publish_step(self) -> None:
        model = self.model
        model.sense()
        stamp = self.stamp()
        poses = model.poses()
        odom_poses = model.odometry()
        n = len(self._io)
        states = self._states_data
        nearest = states[3 + ROBOT_STATE_FIELDS * n :]
        for i, io in enumerate(self._io):
            for (k, kind, pub, obst_pub), (msg, obst) in zip(io.pubs, io.msgs, strict=True):
                msg.header.stamp = stamp
                if kind == "laser":
                    ranges, values = model.ranges(k)
                    nearest[k] = ranges.min() if len(ranges) else np.inf
                    msg.ranges = float32_array(ranges)
                    msg.intensities = float32_array(values)
                    pub.publish(msg)
                else:
                    assert obst_pub is not None and obst is not None  # every ultrasonic sensor has both
                    dist, value = model.nearest(k)
                    nearest[k] = dist
                    msg.range = dist
                    pub.publish(msg)
                    obst.data = value
                    obst_pub.publish(obst)
            x, y, h = poses[i]
            io.pose.header.stamp = stamp
            set_planar_pose(io.pose.pose, x, y, h)
            io.pose_pub.publish(io.pose)
            # odometry: the pose in the frame of the start pose (exact wheel odometry)
            ox, oy, oh = odom_poses[i]
            odom = io.odom
            odom.header.stamp = stamp
            set_planar_pose(odom.pose.pose, ox, oy, oh)
            v, v_lat, w = model.body_velocity(i)
            odom.twist.twist.linear.x = v
            odom.twist.twist.linear.y = v_lat
            odom.twist.twist.angular.z = w
            io.odom_pub.publish(odom)
        for i, m in enumerate(self._markers.markers):
            m.header.stamp = stamp
            m.pose.position.x = float(poses[i, 0])
            m.pose.position.y = float(poses[i, 1])
            m.pose.orientation = quaternion_from_yaw(poses[i, 2])
        self._robots_pub.publish(self._markers)
        states[0] = self.sim_time
        per_robot = states[3 : 3 + ROBOT_STATE_FIELDS * n].reshape(n, ROBOT_STATE_FIELDS)
        per_robot[:, :3] = poses
        per_robot[:, 3] = model.crashed
        per_robot[:, 4] = model.power
        self._states.data = array.array("d", states.tobytes())
        self._states_pub.publish(self._states)
        if self.tf.heard():
            for t, (ox, oy, oh) in zip(self._odom_tf, odom_poses.tolist(), strict=True):
                t.header.stamp = stamp
                set_planar(t, ox, oy, oh)
            self.tf.send(self._odom_tf)
        self._published_wall = self._republished_wall = time.monotonic()


def _spec_from_parameter(node_name: str, node_kwargs: dict[str, Any]) -> WorldSpec:
    try:
        probe = Node(node_name, **node_kwargs)
    except ParameterException as err:  # rclpy's own parameters, e.g. use_sim_time:=abc
        raise InputError(f"parameter of node {node_name!r}: {err}") from None
    try:
        path = probe.declare_parameter("world_file", "").value
    except ParameterException:  # given, but not as a string
        given = probe._parameter_overrides["world_file"].value
        raise InputError(f"parameter 'world_file' = {given!r} is invalid: a file name is expected") from None
    finally:
        probe.destroy_node()
    if not path:
        raise InputError("parameter 'world_file' is required: --ros-args -p world_file:=<world.yaml>")
    if not isinstance(path, str):
        raise InputError(f"parameter 'world_file' = {path!r} is invalid: a file name is expected")
    with startup_phase(rclpy.logging.get_logger(node_name).info, f"reading world {shown(path)}"):
        return load_world(resolve_input_file(path, "world_file"))


def make_nodes() -> list[Node]:
    """The world plus a controller node for every robot whose world-file entry names one."""
    from simrobot_sim.avoid import AvoidNode

    world = SimrobotWorldNode()
    nodes: list[Node] = [world]
    for robot in world.spec.robots:
        if robot.controller == "avoid":
            sonar = next((s.name for s in robot.sensors if s.kind == "ultrasonic"), None)
            if sonar is None:
                raise InputError(
                    f"{world.spec.source}: robot {robot.name!r}: controller 'avoid' needs an ultrasonic sensor"
                )
            nodes.append(AvoidNode(robot=robot.name, sensor=sonar))
    return nodes


def odometry_covariances(spec: WorldSpec) -> tuple[np.ndarray, np.ndarray]:
    """Row-major 6x6 pose and twist covariances of a robot's odometry (x, y, z, roll, pitch, yaw).

    The model's odometry is exact, but it places robots against walls known to one cell of the
    world's grid, one ``dt`` at a time: the rounding variance (step²/12) of a cell for x and y, of
    a cell per ``dt`` for the speeds, and of the angle a cell makes 1 m away (cell m → rad) for
    heading and turn rate. Never zero: an EKF cannot fuse a zero variance. z, roll and pitch are
    exact (a planar robot): zero."""
    cell, dt = float(spec.resolution), float(spec.dt)
    pose, twist = np.zeros(36), np.zeros(36)
    pose[0] = pose[7] = pose[35] = cell * cell / 12.0
    twist[0] = twist[7] = twist[35] = (cell / dt) ** 2 / 12.0
    return pose, twist


def static_transforms(spec: WorldSpec, prefix: str) -> list[TransformStamped]:
    """What ``/tf_static`` carries: ``map → <robot>/odom`` (odometry starts at the start pose),
    ``<robot>/base_link → <robot>/base_footprint`` (REP-120; identity, a planar robot's base_link is
    on the floor) and ``<robot>/base_link → <robot>/<sensor>`` at each sensor's mount (stamps left
    zero)."""
    transforms = []
    for robot in spec.robots:
        x, y = robot.position
        transforms.append(transform_msg("map", frame_name(prefix, robot.name, ODOM_TOPIC), x, y, yaw=robot.heading))
        base = frame_name(prefix, robot.name, "base_link")
        transforms.append(transform_msg(base, frame_name(prefix, robot.name, FOOTPRINT_FRAME), 0.0, 0.0))
        for sensor in robot.sensors:
            sx, sy, axis = sensor_mount(robot, sensor)
            transforms.append(transform_msg(base, frame_name(prefix, robot.name, sensor.name), sx, sy, yaw=axis))
    return transforms


def main(args: list[str] | None = None) -> int:
    """``simrobot_world --ros-args -p world_file:=<world.yaml>``."""
    return run_nodes(make_nodes, args)
