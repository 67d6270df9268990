"""The studio's ROS node: one rclpy node in its own context, spun by an executor in a daemon thread.

Like RViz it is only a client. Every family's client (:class:`studio.shell.family.Family`) is
made on this one node and follows its own kind of world with a discovery timer
(:meth:`StudioRos.every`); what is common lives here: the graph queries the recorder and the
clock checks need, service calls awaited from NiceGUI's event loop, and finding the worlds of a
kind by a topic each publishes. Callbacks run in the executor thread and only store what they
read; the pages read it from NiceGUI's event loop, publish and call services.
"""

from __future__ import annotations

import asyncio
import itertools
import os
import threading
import time
import traceback
from collections.abc import Callable, Container, Iterator
from typing import Any

import rclpy
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rclpy.client import Client
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future
from rclpy.timer import Timer
from rclpy.topic_endpoint_info import TopicEndpointInfo

from sim_runtime.run import make_executor

CLOCK_TYPE = "rosgraph_msgs/msg/Clock"
#: The node name rmw reports for an endpoint whose participant is not fully discovered yet.
UNKNOWN_NODE_NAME = "_NODE_NAME_UNKNOWN_"


def parameter(name: str, value: bool | float | str | list[float]) -> Parameter:
    """An rcl_interfaces Parameter of a bool, double, string or double array."""
    if isinstance(value, bool):
        pv = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
    elif isinstance(value, str):
        pv = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
    elif isinstance(value, list):
        pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[float(v) for v in value])
    else:
        pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
    return Parameter(name=name, value=pv)


def _settle(done: asyncio.Future, future: Future) -> None:
    """Hand a service response to the awaiting page, unless it has stopped waiting."""
    if not done.done():
        done.set_result(future.result())


def new_worlds(
    node: Node, suffix: str, type_name: str, known: Container[str]
) -> Iterator[tuple[str, TopicEndpointInfo]]:
    """``(prefix, publisher)`` of every topic ``<prefix>/<suffix>`` of ``type_name`` whose prefix is
    not in ``known``, once DDS knows the name of the node publishing it: a topic can be seen before
    its node's name, and parameter clients made for ``_NODE_NAME_UNKNOWN_`` never reach the world."""
    tail = "/" + suffix
    for topic, types in node.get_topic_names_and_types():
        if not topic.endswith(tail) or type_name not in types:
            continue
        prefix = topic[: -len(tail)]
        if prefix in known:
            continue
        publishers = node.get_publishers_info_by_topic(topic)
        if publishers and publishers[0].node_name != UNKNOWN_NODE_NAME:
            yield prefix, publishers[0]


def node_full_name(info: TopicEndpointInfo) -> str:
    """``/ns/name`` of a topic's publishing node (its parameter services live under it)."""
    return info.node_namespace.rstrip("/") + "/" + info.node_name


class StudioRos:
    """The studio's node and the executor spinning it in a thread of its own (from :meth:`spin`).

    The families' clients add their entities before :meth:`spin` (the app's start-up); later ones
    (a world found) are made by their discovery timers, in the executor thread."""

    _ids = itertools.count()

    def __init__(self) -> None:
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(f"studio_{os.getpid()}_{next(self._ids)}", context=self.context)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name="studio-ros", daemon=True)

    def spin(self) -> None:
        """Start the executor thread: from now on callbacks run."""
        self._thread.start()

    def _spin(self) -> None:
        """Spin until the context is shut down. Every family's callbacks run here: one that raises
        is reported with its traceback and the others go on (the thread must not end with it);
        one cut short by the studio shutting down is no error."""
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.1)
            except Exception:
                if not self.context.ok():
                    return
                print("studio: a ROS callback failed (the studio goes on):", flush=True)
                traceback.print_exc()

    def every(self, period_s: float, round_: Callable[[], None]) -> Timer:
        """A timer on the studio's node running ``round_`` (a family's discovery round) in the
        executor thread."""
        return self.node.create_timer(period_s, round_)

    def clock_publishers(self) -> list[tuple[str, str]]:
        """``(clock topic, publishing node's namespace, '' for the root)`` of every world on the domain."""
        found = []
        for topic, types in self.node.get_topic_names_and_types():
            if CLOCK_TYPE in types and topic.endswith("/clock"):
                found += [(topic, p.node_namespace.rstrip("/")) for p in self.node.get_publishers_info_by_topic(topic)]
        return found

    def published_topics(self) -> list[str]:
        """Every topic with a publisher now, but hidden ones (a part starting with ``_``): what a
        recorder of everything must subscribe to."""
        node = self.node
        return [
            topic
            for topic, _types in node.get_topic_names_and_types()
            if node.count_publishers(topic) and not any(part.startswith("_") for part in topic.split("/"))
        ]

    def not_subscribed(self, topics: list[str], node_name: str) -> list[str]:
        """Of ``topics``, those that still have a publisher (other than ``node_name``) but no
        subscription of node ``node_name``: a recorder started a moment ago is not recording them yet."""
        node, waiting = self.node, []
        for topic in topics:
            if not any(p.node_name != node_name for p in node.get_publishers_info_by_topic(topic)):
                continue
            if not any(s.node_name == node_name for s in node.get_subscriptions_info_by_topic(topic)):
                waiting.append(topic)
        return waiting

    async def call(self, client: Client, request: Any, timeout: float = 15.0) -> Any:
        """The response of ``client`` to ``request`` (any service type, hence ``Any``), awaited from
        NiceGUI's loop; TimeoutError when the service is missing or silent for ``timeout`` s."""
        if not client.wait_for_service(timeout_sec=0.0):
            deadline = time.monotonic() + timeout
            while not client.service_is_ready():
                if time.monotonic() > deadline:
                    raise TimeoutError(f"service {client.srv_name} is not available")
                await asyncio.sleep(0.05)
        loop = asyncio.get_running_loop()
        done: asyncio.Future = loop.create_future()
        future = client.call_async(request)
        future.add_done_callback(lambda f: loop.call_soon_threadsafe(_settle, done, f))
        try:
            return await asyncio.wait_for(done, timeout)
        except TimeoutError:
            client.remove_pending_request(future)
            message = f"service {client.srv_name} did not answer within {timeout:g} s"
            print(f"studio: {message}", flush=True)
            raise TimeoutError(message) from None

    def shutdown(self) -> None:
        if self.context.ok():
            rclpy.shutdown(context=self.context)
        if self._thread.ident is not None:
            self._thread.join(timeout=10.0)
        if self._thread.is_alive():  # still inside the executor: destroying under it would crash the process
            return
        self.executor.shutdown()
        self.node.destroy_node()
