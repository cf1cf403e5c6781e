"""The installed ``managed_propagation_node`` over the standard ``lifecycle_msgs`` services.

Each test starts the executable (as ``ros2 run`` finds it) in a namespace of its own on the
test run's domain, drives its state machine from an in-process harness node with
``<node>/change_state`` and ``<node>/get_state``, and stops it with SIGINT: exit 0, no
traceback.
"""

from __future__ import annotations

import os
from pathlib import Path
import signal
import subprocess
import time

from ament_index_python.packages import get_package_prefix
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import Imu

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.ros.serve import SERVING_LINE

PACKAGE = 'rigid_body_attitude'
NODE = 'attitude_propagator'
START_TIMEOUT = 30.0  # seconds for the process to start and discover the harness
BASE_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10**7  # 100 Hz stamps


def start(*arguments: str) -> subprocess.Popen:
    """The installed managed node with ``arguments``; stdout and stderr captured."""
    path = Path(get_package_prefix(PACKAGE)) / 'lib' / PACKAGE / 'managed_propagation_node'
    assert path.is_file() and os.access(path, os.X_OK), f'{path} is not an executable file'
    process = subprocess.Popen([str(path), *arguments], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + START_TIMEOUT
    lines = []
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line:
            break
        lines.append(line)
        if f']: {SERVING_LINE}' in line:
            return process
    process.kill()
    pytest.fail(f'the managed node did not start:\n{"".join(lines)}')


def stop_with_sigint(process: subprocess.Popen, timeout: float = 15.0) -> str:
    """SIGINT; stderr after asserting exit code 0 and no traceback."""
    process.send_signal(signal.SIGINT)
    try:
        _, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        _, stderr = process.communicate()
        pytest.fail(f'managed_propagation_node ignored SIGINT; stderr:\n{stderr}')
    assert process.returncode == 0, stderr
    assert 'Traceback' not in stderr, stderr
    return stderr


class Lifecycle:
    """The node's lifecycle services, called from the harness."""

    def __init__(self, harness: Harness) -> None:
        """Clients of ``attitude_propagator/change_state`` and ``get_state``."""
        self.harness = harness

    def change(self, transition_id: int) -> bool:
        """``ChangeState`` with a transition id; its ``success``."""
        response = self.harness.call(ChangeState, f'{NODE}/change_state', ChangeState.Request(
            transition=Transition(id=transition_id)))
        assert response is not None, f'no answer to transition {transition_id}'
        return bool(response.success)

    def state(self) -> int:
        """The current state's id (``lifecycle_msgs/msg/State``)."""
        response = self.harness.call(GetState, f'{NODE}/get_state', GetState.Request())
        assert response is not None
        return int(response.current_state.id)


class GyroFeed:
    """Imu messages at 100 Hz stamps with a rate that can change."""

    def __init__(self, harness: Harness) -> None:
        """An ``imu`` publisher of ``harness``."""
        self.harness = harness
        self.publisher = harness.publisher(Imu, 'imu')
        self.sent = 0

    def send(self, omega: np.ndarray, count: int | None = None,
             until=None) -> None:
        """Send ``count`` samples, or until ``until()`` (at most 500), at a pace the node's
        queue keeps up with."""
        for _ in range(count if count is not None else 500):
            imu = Imu()
            imu.header.stamp.sec, imu.header.stamp.nanosec = divmod(
                BASE_NS + self.sent * PERIOD_NS, 10**9)
            imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = omega
            self.publisher.publish(imu)
            self.sent += 1
            if self.harness.spin_until(until or (lambda: False), 0.02) and until is not None:
                return
        assert until is None, 'the condition did not hold within 500 samples'


def wxyz(message: QuaternionStamped) -> np.ndarray:
    """The message's quaternion as (w, x, y, z)."""
    q = message.quaternion
    return np.array([q.w, q.x, q.y, q.z])


def seconds(message: QuaternionStamped) -> float:
    """The message's stamp [s] since the first sample's."""
    stamp = message.header.stamp
    return (stamp.sec * 10**9 + stamp.nanosec - BASE_NS) * 1e-9


def status_values(diagnostics: list[DiagnosticArray]) -> tuple[str, dict[str, str]]:
    """Message and values of the node's latest status."""
    status = [s for m in diagnostics for s in m.status if s.name.endswith(NODE)][-1]
    return status.message, {v.key: v.value for v in status.values}


def check_constant_rate(messages: list[QuaternionStamped], omega: np.ndarray) -> None:
    """Each attitude is the first's turned by ``omega`` over the stamp difference: exact for a
    constant rate (delta_single; round-off only over a few hundred steps, 1e-12)."""
    first = messages[0]
    for message in messages[1:]:
        expected = quaternion.multiply(
            wxyz(first), quaternion.exp((seconds(message) - seconds(first)) * omega))
        assert np.max(np.abs(wxyz(message) - expected)) <= 1e-12


def test_configure_activate_deactivate_reactivate_cleanup_shutdown(ros, request, processes):
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-r', f'__ns:={namespace}')
    processes.append(process)
    harness = Harness(ros, namespace)
    lifecycle = Lifecycle(harness)
    assert lifecycle.state() == State.PRIMARY_STATE_UNCONFIGURED
    assert lifecycle.change(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == State.PRIMARY_STATE_INACTIVE
    feed = GyroFeed(harness)
    orientations = harness.record(QuaternionStamped, 'orientation')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections(START_TIMEOUT)
    omega = np.array([0.4, -0.1, 0.9])

    # Configured, not active: nothing integrated, nothing published, counted and said so.
    feed.send(omega, until=lambda: bool(diagnostics) and int(
        status_values(diagnostics)[1]['rejected inactive']) > 0)
    assert not orientations
    message, values = status_values(diagnostics)
    assert message.startswith('inactive') and values['lifecycle_state'] == 'inactive'

    assert lifecycle.change(Transition.TRANSITION_ACTIVATE)
    assert lifecycle.state() == State.PRIMARY_STATE_ACTIVE
    feed.send(omega, until=lambda: len(orientations) >= 20)
    check_constant_rate(orientations, omega)
    before_pause = list(orientations)

    # Deactivated: samples with another rate are neither integrated nor published.
    assert lifecycle.change(Transition.TRANSITION_DEACTIVATE)
    assert lifecycle.state() == State.PRIMARY_STATE_INACTIVE
    inactive_before = int(status_values(diagnostics)[1]['rejected inactive'])
    diagnostics.clear()
    feed.send(np.array([3.0, 0.0, 0.0]), 50)
    harness.spin_until(lambda: bool(diagnostics) and int(
        status_values(diagnostics)[1]['rejected inactive']) >= inactive_before + 50, 5.0)
    message, values = status_values(diagnostics)
    assert message.startswith('inactive')
    assert int(values['rejected inactive']) >= inactive_before + 50
    assert len(orientations) == len(before_pause)

    # Reactivated: goes on from the same attitude, the pause not integrated across.
    assert lifecycle.change(Transition.TRANSITION_ACTIVATE)
    feed.send(omega, until=lambda: len(orientations) >= len(before_pause) + 20)
    after_pause = orientations[len(before_pause):]
    assert np.max(np.abs(wxyz(after_pause[0]) - wxyz(before_pause[-1]))) <= 1e-12
    assert seconds(after_pause[0]) - seconds(before_pause[-1]) >= 50 * PERIOD_NS * 1e-9
    check_constant_rate(after_pause, omega)
    diagnostics.clear()
    assert harness.spin_until(lambda: bool(diagnostics), 5.0)
    message, values = status_values(diagnostics)
    assert not message.startswith('inactive') and 'lifecycle_state' not in values
    assert values['rejected gap'] == '0' and values['rejected outlier_stamp'] == '0'

    # Cleanup releases the subscriptions and publishers; shutdown finalizes.
    assert lifecycle.change(Transition.TRANSITION_DEACTIVATE)
    assert lifecycle.change(Transition.TRANSITION_CLEANUP)
    assert lifecycle.state() == State.PRIMARY_STATE_UNCONFIGURED
    assert harness.spin_until(lambda: feed.publisher.get_subscription_count() == 0
                              and harness.subscriptions['orientation'].get_publisher_count()
                              == 0, 10.0)
    assert lifecycle.change(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN)
    assert lifecycle.state() == State.PRIMARY_STATE_FINALIZED
    stderr = stop_with_sigint(process)
    assert 'cleaned up' in stderr and 'shut down (finalized)' in stderr


def test_transitions_in_wrong_orders_are_refused(ros, request, processes):
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-r', f'__ns:={namespace}')
    processes.append(process)
    lifecycle = Lifecycle(Harness(ros, namespace))
    assert not lifecycle.change(Transition.TRANSITION_ACTIVATE)
    assert not lifecycle.change(Transition.TRANSITION_DEACTIVATE)
    assert not lifecycle.change(Transition.TRANSITION_CLEANUP)
    assert lifecycle.state() == State.PRIMARY_STATE_UNCONFIGURED
    assert lifecycle.change(Transition.TRANSITION_CONFIGURE)
    assert not lifecycle.change(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == State.PRIMARY_STATE_INACTIVE
    assert lifecycle.change(Transition.TRANSITION_ACTIVATE)
    assert not lifecycle.change(Transition.TRANSITION_ACTIVATE)
    assert not lifecycle.change(Transition.TRANSITION_CLEANUP)  # active: deactivate first
    assert lifecycle.state() == State.PRIMARY_STATE_ACTIVE
    assert process.poll() is None
    stderr = stop_with_sigint(process)
    assert stderr.count('refused: Failed to trigger lifecycle state machine transition') == 6


def test_a_bad_parameter_makes_configure_fail_until_it_is_set_again(ros, request, processes):
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-p', 'max_dt:=-1.0',
                    '-r', f'__ns:={namespace}')
    processes.append(process)
    harness = Harness(ros, namespace)
    lifecycle = Lifecycle(harness)
    assert not lifecycle.change(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == State.PRIMARY_STATE_UNCONFIGURED
    assert not lifecycle.change(Transition.TRANSITION_ACTIVATE)
    response = harness.call(SetParameters, f'{NODE}/set_parameters', SetParameters.Request(
        parameters=[Parameter(name='max_dt', value=ParameterValue(
            type=ParameterType.PARAMETER_DOUBLE, double_value=0.05))]))
    assert response is not None and response.results[0].successful
    assert lifecycle.change(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == State.PRIMARY_STATE_INACTIVE
    stderr = stop_with_sigint(process)
    assert stderr.count('configure refused:') == 1
    assert 'configure refused: Bad parameter `max_dt`' in stderr


def test_a_bad_scene_makes_configure_fail_and_builds_nothing(ros, request, processes):
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=no_such_scene', '-r', f'__ns:={namespace}')
    processes.append(process)
    harness = Harness(ros, namespace)
    lifecycle = Lifecycle(harness)
    assert not lifecycle.change(Transition.TRANSITION_CONFIGURE)
    assert not lifecycle.change(Transition.TRANSITION_CONFIGURE)  # again: the same reason
    assert lifecycle.state() == State.PRIMARY_STATE_UNCONFIGURED
    topics = {name for name, _ in harness.node.get_topic_names_and_types()}
    assert f'{namespace}/orientation' not in topics
    stderr = stop_with_sigint(process)
    assert stderr.count("configure refused: ") == 2 and 'no_such_scene' in stderr
