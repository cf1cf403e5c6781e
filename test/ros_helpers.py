"""Helpers for tests with real rclpy: an isolated context, a harness node, bounded waits.

* :func:`ros_session`: a dedicated :class:`rclpy.context.Context` initialised on a domain
  (the test run's ``ros_domain_id`` from conftest, where ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is
  set to ``LOCALHOST``) and a :class:`SingleThreadedExecutor` on it; both shut down on exit,
  whatever happened.
* :class:`Harness`: a node in that context that publishes inputs and records outputs, with
  :meth:`Harness.spin_until` (every wait has a deadline; nothing can hang).
* :func:`unique_namespace`: a namespace per test so no test sees another's topics.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
import os
from pathlib import Path
import re
import time
from typing import Any

from builtin_interfaces.msg import Time
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

#: Reliable, keep last 5000: nothing is dropped between nodes of one process.
DEEP_RELIABLE_QOS = QoSProfile(depth=5000, history=HistoryPolicy.KEEP_LAST,
                               reliability=ReliabilityPolicy.RELIABLE)


@dataclass
class RosContext:
    """A context of the test's own and the executor spinning its nodes."""

    context: Context
    executor: SingleThreadedExecutor
    domain_id: int


@contextmanager
def ros_session(domain_id: int) -> Iterator[RosContext]:
    """An initialised rclpy context and executor on ``domain_id``; shut down on exit.

    Test modules wrap it in a fixture (``yield from``-style) with conftest's ``ros_domain_id``.
    """
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    executor = SingleThreadedExecutor(context=context)
    try:
        yield RosContext(context, executor, domain_id)
    finally:
        for node in list(executor.get_nodes()):
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown(timeout_sec=1.0)
        rclpy.try_shutdown(context=context)


def unique_namespace(request: pytest.FixtureRequest) -> str:
    """``/test_<test name>`` with characters ROS names do not allow replaced."""
    return '/t_' + re.sub(r'[^A-Za-z0-9_]', '_', request.node.name)


class Harness:
    """A node that publishes the test's inputs and records what the node under test sends."""

    def __init__(self, ros: RosContext, namespace: str) -> None:
        """Create the harness node in ``namespace`` and add it to the executor."""
        self.ros = ros
        self.node = Node('harness', namespace=namespace, context=ros.context)
        ros.executor.add_node(self.node)
        self.received: dict[str, list[Any]] = {}
        self.publishers: dict[str, Any] = {}
        self.subscriptions: dict[str, Any] = {}

    def add_node(self, node: Node) -> Node:
        """Spin ``node`` (the node under test) with the harness; return it."""
        self.ros.executor.add_node(node)
        return node

    def publisher(self, message_type: Any, topic: str,
                  qos: QoSProfile = DEEP_RELIABLE_QOS) -> Any:
        """A publisher on ``topic`` (relative to the namespace); one per topic."""
        if topic not in self.publishers:
            self.publishers[topic] = self.node.create_publisher(message_type, topic, qos)
        return self.publishers[topic]

    def record(self, message_type: Any, topic: str,
               qos: QoSProfile = DEEP_RELIABLE_QOS) -> list[Any]:
        """Record every message on ``topic`` into the returned list."""
        messages = self.received.setdefault(topic, [])
        self.subscriptions[topic] = self.node.create_subscription(
            message_type, topic, messages.append, qos)
        return messages

    def spin_until(self, condition: Callable[[], bool], timeout: float = 10.0) -> bool:
        """Spin until ``condition()`` holds or ``timeout`` seconds pass; return whether it held."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                return False
            self.ros.executor.spin_once(timeout_sec=0.01)
        return True

    def spin_for(self, seconds: float) -> None:
        """Spin for ``seconds`` (lets late messages arrive before asserting on their absence)."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.ros.executor.spin_once(timeout_sec=0.01)

    def wait_for_connections(self, timeout: float = 10.0) -> None:
        """Wait until every harness publisher and subscription is matched with a peer."""
        def connected() -> bool:
            return (all(p.get_subscription_count() > 0 for p in self.publishers.values())
                    and all(s.get_publisher_count() > 0 for s in self.subscriptions.values()))
        assert self.spin_until(connected, timeout), (
            'harness topics not connected: '
            + ', '.join(f'{topic}: {p.get_subscription_count()} subscribers'
                        for topic, p in self.publishers.items())
            + '; ' + ', '.join(f'{topic}: {s.get_publisher_count()} publishers'
                               for topic, s in self.subscriptions.items()))

    def call(self, service_type: Any, name: str, request: Any, timeout: float = 10.0) -> Any:
        """Call a service and wait for the response (None on timeout)."""
        client = self.node.create_client(service_type, name)
        assert self.spin_until(client.service_is_ready, timeout), f'service {name} not ready'
        future = client.call_async(request)
        self.spin_until(future.done, timeout)
        return future.result()


def stamp(nanoseconds: int) -> Time:
    """A builtin_interfaces/Time of integer nanoseconds."""
    sec, nanosec = divmod(nanoseconds, 10**9)
    return Time(sec=sec, nanosec=nanosec)


def remove_stale_fastdds_shm(shm: Path = Path('/dev/shm')) -> int:
    """Remove the Fast DDS shared-memory files that no live process has open or mapped; the
    count removed.

    A participant killed without its clean-up (a test that kills a process) leaves its
    segments and port files behind, and a later participant that reuses such a port starts
    from the stale listener state: its shared-memory listener then misses the wake-up period
    of the packaged profile. Files a live process holds are kept.
    """
    held: set[str] = set()
    for proc in Path('/proc').iterdir():
        if not proc.name.isdigit():
            continue
        try:
            held.update(target for target in (os.readlink(fd) for fd in (proc / 'fd').iterdir())
                        if target.startswith(str(shm)))
            held.update(line[line.index(str(shm)):].split(' (deleted)')[0]
                        for line in (proc / 'maps').read_text().splitlines() if str(shm) in line)
        except OSError:  # the process ended meanwhile, or is not ours to read
            continue
    stale = [path for path in shm.glob('*fastrtps*') if str(path) not in held]
    for path in stale:
        path.unlink(missing_ok=True)
    return len(stale)
