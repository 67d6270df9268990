"""The studio's SIMROBOT side: following ``simrobot_world`` nodes on the ROS domain, and the worlds
the studio starts.

A world is found by its ``robot_states`` topic (any namespace). Its robots' names, shapes and
sensors come from its own world file (the node's ``world_file`` parameter, read with the same
loader); every step's poses, crash and power flags and each sensor's nearest hit come in that one
flat ``robot_states`` message, decoded with one numpy call however many robots (the ``robots``
MarkerArray of 200 robots takes ~50 ms to deserialise in Python, more than the step lasts); a
laser's rays come from its own topic.

It is the SIMROBOT family's client (:class:`studio.simrobot.family.SimrobotFamily`), on the
studio's one node: its subscriptions, clients and discovery timer are the node's, its callbacks
run in the studio's executor thread (one at a time: the node's default callback group) and only
store arrays on a :class:`WorldState`, replacing them whole; the pages read them from NiceGUI's
loop and call services from there (:meth:`StudioRos.call`).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rcl_interfaces.srv import GetParameters, SetParameters
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from sim_runtime.errors import InputError
from sim_runtime.qos import ANY_PUBLISHER_QOS
from simrobot_sim.spec import (
    CLEAR_CRASH_SERVICE,
    ROBOT_STATE_FIELDS,
    ROBOT_STATES_TOPIC,
    SET_POWER_SERVICE,
    robot_topic,
)
from simrobot_sim.world_file import SensorSpec, WorldSpec, load_world
from studio.shell.ros import StudioRos, new_worlds, node_full_name, parameter

STATES_TYPE = "std_msgs/msg/Float64MultiArray"
TRACK_POINTS = 1000
TRACK_MIN_STEP_M = 0.005
REPLAY_VALUES = 3_000_000
"""Most pose numbers kept for the replay (24 MB): 5000 steps of 200 robots, the world's
``history_steps`` of a few robots."""


@dataclass
class WorldState:
    """Latest state of one SIMROBOT world (namespace ``ns``, '' for the root)."""

    ns: str
    node_name: str
    spec: WorldSpec | None = None
    problem: str = ""  # why the world's file could not be read (then only poses are known)
    names: list[str] = field(default_factory=list)
    sensors: list[tuple[int, SensorSpec]] = field(default_factory=list)  # (robot index, sensor), topic order
    poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    crashed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    power: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    nearest: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per sensor: nearest hit (m), inf = none
    scans: dict[int, np.ndarray] = field(default_factory=dict)  # laser sensor index → ranges (m)
    tracks: list[deque] = field(default_factory=list)
    # every step seen, for the original's Run replay: (sim time, poses n x 3), oldest dropped
    history: deque = field(default_factory=lambda: deque(maxlen=1))
    seq: int = 0  # bumped by every robots message: the view redraws when it changes
    sim_time: float = 0.0
    last_heard: float = 0.0

    def topic(self, name: str) -> str:
        return f"{self.ns}/{name}"

    def clear_tracks(self) -> None:
        for track in self.tracks:
            track.clear()


class _World:
    """A WorldState plus the ROS entities feeding and commanding it."""

    def __init__(self, node, ns: str, node_name: str) -> None:
        self.node = node
        self.state = WorldState(ns=ns, node_name=node_name, last_heard=time.monotonic())
        s = self.state
        self.subs = [
            node.create_subscription(Float64MultiArray, s.topic(ROBOT_STATES_TOPIC), self._on_states, ANY_PUBLISHER_QOS)
        ]
        self.step = node.create_client(Trigger, s.topic("step"))
        self.set_params = node.create_client(SetParameters, f"{node_name}/set_parameters")
        self.get_params = node.create_client(GetParameters, f"{node_name}/get_parameters")
        self.power_clients: list = []
        self.clear_clients: list = []
        self._asked = False

    def ask_world_file(self) -> None:
        """Ask the node for its world file (once its parameter service is up); the answer arrives
        in the executor thread, which then subscribes to every robot's topics."""
        if self._asked or not self.get_params.service_is_ready():
            return
        self._asked = True
        future = self.get_params.call_async(GetParameters.Request(names=["world_file"]))
        future.add_done_callback(self._on_world_file)

    def _on_world_file(self, future) -> None:
        s = self.state
        try:
            values = future.result().values
            path = values[0].string_value if values else ""
            spec = load_world(Path(path))
        except (InputError, OSError, IndexError) as err:
            s.problem = f"cannot read the world's file: {err}"
            return
        n = len(spec.robots)
        s.names = [r.name for r in spec.robots]
        s.sensors = [(i, sensor) for i, r in enumerate(spec.robots) for sensor in r.sensors]
        s.crashed = np.zeros(n, dtype=bool)
        s.power = np.array([r.power for r in spec.robots], dtype=bool)
        s.nearest = np.full(len(s.sensors), np.inf)
        s.tracks = [deque(maxlen=TRACK_POINTS) for _ in range(n)]
        s.history = deque(maxlen=min(spec.history_steps, max(100, REPLAY_VALUES // (3 * max(n, 1)))))
        sub = self.node.create_subscription
        for name in s.names:
            self.power_clients.append(self.node.create_client(SetBool, s.topic(robot_topic(name, SET_POWER_SERVICE))))
            self.clear_clients.append(self.node.create_client(Trigger, s.topic(robot_topic(name, CLEAR_CRASH_SERVICE))))
        for k, (i, sensor) in enumerate(s.sensors):
            topic = s.topic(robot_topic(s.names[i], sensor.name))
            if sensor.kind == "laser":
                self.subs.append(sub(LaserScan, topic, lambda m, k=k: self._on_scan(k, m), ANY_PUBLISHER_QOS))
        s.spec = spec  # last: the page draws once everything above is in place

    def _on_scan(self, k: int, msg: LaserScan) -> None:
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        self.state.scans[k] = ranges

    def _on_states(self, msg: Float64MultiArray) -> None:
        s = self.state
        data = np.frombuffer(msg.data, dtype=np.float64) if len(msg.data) else np.zeros(3)
        n, k = int(data[1]), int(data[2])
        if len(data) != 3 + ROBOT_STATE_FIELDS * n + k:
            return  # not the layout this studio knows
        robots = data[3 : 3 + ROBOT_STATE_FIELDS * n].reshape(n, ROBOT_STATE_FIELDS)
        poses = robots[:, :3].copy()
        if len(s.tracks) == n:
            for track, (x, y) in zip(s.tracks, poses[:, :2].tolist(), strict=True):
                if not track or abs(x - track[-1][0]) + abs(y - track[-1][1]) >= TRACK_MIN_STEP_M:
                    track.append((x, y))
        s.crashed = robots[:, 3] != 0
        s.power = robots[:, 4] != 0
        s.nearest = data[3 + ROBOT_STATE_FIELDS * n :].copy()
        s.poses = poses
        s.sim_time = float(data[0])
        if s.spec is not None and len(poses) == len(s.names):
            s.history.append((s.sim_time, poses))
        s.last_heard = time.monotonic()
        s.seq += 1

    def destroy(self) -> None:
        for sub in self.subs:
            self.node.destroy_subscription(sub)
        for client in (self.step, self.set_params, self.get_params, *self.power_clients, *self.clear_clients):
            self.node.destroy_client(client)


class SimrobotRos:
    """The studio's ROS client for SIMROBOT worlds, on the studio's node ``ros``: ``worlds`` maps
    namespace → :class:`WorldState`."""

    def __init__(self, ros: StudioRos) -> None:
        self.ros = ros
        self.node = ros.node
        self._worlds: dict[str, _World] = {}
        self.worlds: dict[str, WorldState] = {}
        self._forget: set[str] = set()  # swapped whole by the executor thread, added to by the pages
        self._rounds = 0
        self.timer = ros.every(0.5, self._discover)

    def forget(self, ns: str) -> None:
        """Drop what is known of the world in ``ns`` (restarted with another file): the next
        discovery round follows it afresh, reading its file again."""
        self._forget.add(ns)

    def _discover(self) -> None:
        """Follow every namespace with a SIMROBOT world (a ``robot_states`` topic); forget a
        world whose publisher has gone."""
        # Listing the graph costs with hundreds of robots (~10 topics each): while following
        # worlds, look for new ones every 4th round (2 s) only.
        self._rounds += 1
        if self._worlds and not self._forget and self._rounds % 4:
            for world in self._worlds.values():
                world.ask_world_file()
            return
        now = time.monotonic()
        forget, self._forget = self._forget, set()
        for ns, world in list(self._worlds.items()):
            world.ask_world_file()
            gone = (
                self.node.count_publishers(world.state.topic(ROBOT_STATES_TOPIC)) == 0
                and now - world.state.last_heard > 2.0
            )
            if gone or ns in forget:
                print(f"studio: the SIMROBOT world in {ns or '/'} has gone", flush=True)
                world.destroy()
                del self._worlds[ns]
                self.worlds = {k: v for k, v in self.worlds.items() if k != ns}
        for ns, info in new_worlds(self.node, ROBOT_STATES_TOPIC, STATES_TYPE, self._worlds):
            node_name = node_full_name(info)
            world = _World(self.node, ns, node_name)
            print(f"studio: following the SIMROBOT world in {ns or '/'} (node {node_name})", flush=True)
            self._worlds[ns] = world
            self.worlds = {**self.worlds, ns: world.state}
            world.ask_world_file()

    def namespaces(self) -> list[str]:
        return sorted(self.worlds)

    async def set_world_parameters(self, ns: str, values: dict[str, bool | float]) -> list[str]:
        """Set the world's live parameters (``paused``, ``real_time_factor``); reasons of refusals."""
        request = SetParameters.Request(parameters=[parameter(k, v) for k, v in values.items()])
        response = await self.ros.call(self._worlds[ns].set_params, request)
        return [
            f"{k}: {r.reason or 'refused'}" for k, r in zip(values, response.results, strict=True) if not r.successful
        ]

    async def step_world(self, ns: str) -> tuple[bool, str]:
        response = await self.ros.call(self._worlds[ns].step, Trigger.Request())
        return response.success, response.message

    async def set_power(self, ns: str, robot: int, on: bool) -> str:
        response = await self.ros.call(self._worlds[ns].power_clients[robot], SetBool.Request(data=on))
        return response.message

    async def clear_crash(self, ns: str, robot: int) -> str:
        response = await self.ros.call(self._worlds[ns].clear_clients[robot], Trigger.Request())
        return response.message
