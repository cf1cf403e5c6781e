"""The installed ``propagation_node`` executable as ``ros2 run`` starts it, over real topics.

The executable is ``<prefix>/lib/rigid_body_attitude/propagation_node`` with the prefix from
``ament_index_python``'s ``get_package_prefix`` (what ros2run does). Each test starts it in a
namespace of its own on the test run's domain (conftest's environment is inherited), talks to
it from an in-process harness node and stops it with SIGINT: exit code 0, no traceback. The
topic tests run on both serving paths: the fast one, and rclpy's stock executor that the node
falls back to when rclpy's private parts are missing (forced here with the environment variable
``RIGID_BODY_ATTITUDE_STOCK_EXECUTOR``, see ``ros/rclpy_internals.py``).
"""

from __future__ import annotations

from collections.abc import Iterator
import os
from pathlib import Path
import signal
import subprocess
import time

from ament_index_python.packages import get_package_prefix
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, QuaternionStamped
import numpy as np
import pytest
from ros_helpers import Harness, ros_session, RosContext, unique_namespace
from sensor_msgs.msg import Imu
from std_srvs.srv import Trigger

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.ros.rclpy_internals import STOCK_EXECUTOR_VARIABLE
from rigid_body_attitude.ros.serve import SERVING_LINE
from rigid_body_attitude.session.parameters import defaults

PACKAGE = 'rigid_body_attitude'
START_TIMEOUT = 30.0  # seconds for the process to start and discover the harness
SERVING = f']: {SERVING_LINE}'  # the node's last start-up log line, as logged
STOCK_LINE = "serving with rclpy's stock executor"


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    """A context and executor of the test's own on the test run's domain."""
    with ros_session(ros_domain_id) as session:
        yield session


def executable() -> Path:
    """``<prefix>/lib/rigid_body_attitude/propagation_node``, found as ros2run finds it."""
    path = Path(get_package_prefix(PACKAGE)) / 'lib' / PACKAGE / 'propagation_node'
    assert path.is_file() and os.access(path, os.X_OK), f'{path} is not an executable file'
    return path


@pytest.fixture(params=['fast', 'stock'])
def serving_path(request) -> str:
    """The node's serving path: its own raw-take loop, or rclpy's stock executor."""
    return request.param


def start(*arguments: str, path: str = 'fast') -> subprocess.Popen:
    """Start the installed node with ``arguments`` on the serving ``path``; stdout and stderr
    are captured."""
    env = dict(os.environ)
    env.pop(STOCK_EXECUTOR_VARIABLE, None)
    if path == 'stock':
        env[STOCK_EXECUTOR_VARIABLE] = '1'
    return subprocess.Popen([str(executable()), *arguments], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


def check_serving_path(stderr: str, path: str) -> None:
    """One line says the stock executor serves (and only on that path)."""
    assert stderr.count(STOCK_LINE) == (path == 'stock'), stderr


def read_until(process: subprocess.Popen, text: str, timeout: float = 30.0) -> list[str]:
    """Read ``process``'s stderr until a line contains ``text``; the lines read."""
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line:
            break
        lines.append(line)
        if text in line:
            return lines
    pytest.fail(f'no line with {text!r} within {timeout} s; stderr so far:\n{"".join(lines)}')


def stop_with_sigint(process: subprocess.Popen, timeout: float = 15.0) -> tuple[int, str]:
    """SIGINT, then the exit code and stderr (killed and failed if it does not stop)."""
    process.send_signal(signal.SIGINT)
    try:
        _, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        _, stderr = process.communicate()
        pytest.fail(f'propagation_node ignored SIGINT for {timeout} s; stderr:\n{stderr}')
    return process.returncode, stderr


def test_strapdown_over_topics_then_sigint_exits_0(ros, request, processes, serving_path):
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-r', f'__ns:={namespace}',
                    path=serving_path)
    processes.append(process)
    harness = Harness(ros, namespace)
    imu_publisher = harness.publisher(Imu, 'imu')
    orientations = harness.record(QuaternionStamped, 'orientation')
    harness.wait_for_connections(START_TIMEOUT)
    omega = np.array([0.4, -0.1, 0.9])
    base_ns = 1_700_000_000 * 10**9
    # 100 Hz stamps, sent at a pace a best-effort queue of 5 keeps up with, until 20 outputs
    # came back (discovery may still be completing for the first few).
    for k in range(500):
        imu = Imu()
        imu.header.stamp.sec, imu.header.stamp.nanosec = divmod(base_ns + k * 10**7, 10**9)
        imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = omega
        imu_publisher.publish(imu)
        if harness.spin_until(lambda: len(orientations) >= 20, 0.02):
            break
    assert len(orientations) >= 20
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    assert 'Traceback' not in stderr
    check_serving_path(stderr, serving_path)

    def seconds(message: QuaternionStamped) -> float:
        return (message.header.stamp.sec * 10**9 + message.header.stamp.nanosec - base_ns) * 1e-9

    first = orientations[0]
    first_attitude = [first.quaternion.w, first.quaternion.x, first.quaternion.y,
                      first.quaternion.z]
    for message in orientations[1:]:
        q = message.quaternion
        # Exact for a constant rate (delta_single; a lost sample only lengthens one step, all
        # steps commute): round-off only over < 500 steps, 1e-12.
        expected = quaternion.multiply(
            first_attitude, quaternion.exp((seconds(message) - seconds(first)) * omega))
        assert np.max(np.abs(np.array([q.w, q.x, q.y, q.z]) - expected)) <= 1e-12


def test_services_set_pose_and_timers_work_beside_the_raw_take_loop(
        ros, request, processes, serving_path):
    """The executable serves gyro topics and timers in its raw-take loop and the rest with an
    executor thread (or all with the stock executor): reset, set_pose and /diagnostics all
    answer while it runs."""
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', 'scene:=strapdown', '-p', 'publish_rate:=100.0',
                    '-r', f'__ns:={namespace}', path=serving_path)
    processes.append(process)
    harness = Harness(ros, namespace)
    imu_publisher = harness.publisher(Imu, 'imu')
    harness.publisher(PoseStamped, 'set_pose')
    orientations = harness.record(QuaternionStamped, 'orientation')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections(START_TIMEOUT)
    omega = np.array([0.0, 0.0, 1.0])
    base_ns = 1_700_000_000 * 10**9
    sent = 0

    def send_until(condition) -> bool:
        """100 Hz stamps at a pace a best-effort queue of 5 keeps up with."""
        nonlocal sent
        for _ in range(300):
            imu = Imu()
            imu.header.stamp.sec, imu.header.stamp.nanosec = divmod(base_ns + sent * 10**7,
                                                                    10**9)
            imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = omega
            imu_publisher.publish(imu)
            sent += 1
            if harness.spin_until(condition, 0.02):
                return True
        return False

    assert send_until(lambda: len(orientations) >= 5 and any(
        s.name.endswith('attitude_propagator') for m in diagnostics for s in m.status))
    response = harness.call(Trigger, 'attitude_propagator/reset', Trigger.Request())
    assert response is not None and response.success
    pose = PoseStamped()
    pose.header.frame_id = 'world'
    pose.pose.orientation.x, pose.pose.orientation.w = 1.0, 0.0  # 180° about x
    harness.publishers['set_pose'].publish(pose)
    harness.spin_for(0.5)  # the pose reaches the node before the next gyro samples
    after = len(orientations)
    assert send_until(lambda: len(orientations) >= after + 3)
    q = orientations[-1].quaternion
    # Before set_pose the attitude was exp(θ z): x = y = 0. After it, turning about z at
    # 1 rad/s from (0, 1, 0, 0): (0, 1, 0, 0) ⊗ exp(θ z) = (0, cos θ/2, −sin θ/2, 0), so
    # w = z = 0 whatever θ (round-off of a few steps: 1e-12), with θ a few 10 ms steps.
    assert abs(q.w) <= 1e-12 and abs(q.z) <= 1e-12
    assert q.x >= 0.99 and -0.05 <= q.y < 0.0
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    assert 'Traceback' not in stderr and 'set_pose: attitude' in stderr
    check_serving_path(stderr, serving_path)


def test_default_scene_with_the_params_file_publishes_pose_alone(
        ros, request, processes, serving_path):
    namespace = unique_namespace(request)
    params_file = Path(get_package_prefix(PACKAGE)) / 'share' / PACKAGE / 'config' / 'params.yaml'
    assert params_file.is_file()
    process = start('--ros-args', '--params-file', str(params_file), '-r', f'__ns:={namespace}',
                    path=serving_path)
    processes.append(process)
    harness = Harness(ros, namespace)
    poses = harness.record(PoseStamped, 'pose')
    harness.wait_for_connections(START_TIMEOUT)
    assert harness.spin_until(lambda: len(poses) >= 25, 10.0), len(poses)
    code, stderr = stop_with_sigint(process)
    assert code == 0, stderr
    assert 'Traceback' not in stderr
    assert "scene 'torque_free_box'" in stderr  # the start-up INFO line names the scene
    check_serving_path(stderr, serving_path)
    stamps = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in poses])
    assert np.all(np.diff(stamps) > 0.0)
    # Timer ticks at publish_rate = 50 Hz on the node clock: a median spacing of 20 ms, with
    # room for scheduling jitter on a loaded machine.
    assert 0.015 <= float(np.median(np.diff(stamps))) <= 0.025
    norms = [np.linalg.norm([m.pose.orientation.w, m.pose.orientation.x, m.pose.orientation.y,
                             m.pose.orientation.z]) for m in poses]
    assert max(abs(norm - 1.0) for norm in norms) <= 1e-12
    assert {m.header.frame_id for m in poses} == {'world'}


@pytest.mark.parametrize('arguments, expected', [
    (('-p', 'scene:=no_such_scene'), "error: Unknown scene 'no_such_scene'"),
    (('-p', 'publish_rate:=50'), 'error: Expected parameter `publish_rate` to be a double'),
    (('-p', 'max_dt:=0.0'),
     'error: Expected parameter `max_dt` to be a finite number in (0, 3600], got 0.0'),
])
def test_bad_parameters_give_one_error_line_and_exit_2(processes, arguments, expected):
    process = start('--ros-args', *arguments)
    processes.append(process)
    _, stderr = process.communicate(timeout=START_TIMEOUT)
    assert process.returncode == 2
    assert stderr.startswith(expected)
    assert stderr.count('\n') == 1 and 'Traceback' not in stderr


@pytest.mark.parametrize('scene', ['strapdown', 'torque_free_box'])
def test_sigint_right_as_serving_starts_exits_0_without_a_traceback(processes, scene):
    """Ctrl-C as soon as the node logs that it serves (the last start-up line): half-built
    rclpy objects (an executor still being built) would print ``Exception ignored in:
    Executor.__del__`` tracebacks at exit. Three starts per scene."""
    for _ in range(3):
        process = start('--ros-args', '-p', f'scene:={scene}')
        processes.append(process)
        head = read_until(process, SERVING)
        code, stderr = stop_with_sigint(process)
        stderr = ''.join(head) + stderr
        assert code == 0, stderr
        assert 'Traceback' not in stderr and 'Exception ignored' not in stderr, stderr


@pytest.mark.parametrize('flag', ['--help', '-h'])
def test_help_lists_every_parameter_and_exits_0_without_starting_ros(flag):
    """``--help`` prints name, type, default, range, description and whether each parameter
    changes at run time, then exits 0. The ROS arguments are ones rcl refuses (``-p`` without
    ``:=value``: an rcl error and exit 2 when ROS starts, the next test), so exit
    0 with an empty stderr means ROS was never started."""
    result = subprocess.run([str(executable()), flag, '--ros-args', '-p', 'scene'],
                            capture_output=True, text=True, timeout=START_TIMEOUT)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ''
    lines = result.stdout.splitlines()
    assert lines[0].startswith('usage: propagation_node [-h]')
    for name in defaults():
        assert sum(line.startswith(f'  {name}: ') for line in lines) == 1, name
    assert ('  publish_rate: double, default 50.0, range (0, 1000], fixed at start'
            in lines)
    assert '  max_dt: double, default 0.1, range (0, 3600], changeable at run time' in lines
    assert "  scene: string, default 'torque_free_box', fixed at start" in lines
    assert '  use_header_stamps: bool, default true, changeable at run time' in lines
    description = lines[lines.index("  scene: string, default 'torque_free_box', "
                                    'fixed at start') + 1]
    assert description == '      built-in scene name or path to a scene YAML file'


@pytest.mark.parametrize('arguments', [('--ros-args', '-p', 'scene'), ('--ros-args', '-h')])
def test_without_help_rcl_refuses_bad_ros_arguments(processes, arguments):
    """Without ``--help`` those ROS arguments reach rcl, which refuses them: exit 2. ``-h``
    inside ``--ros-args`` is a ROS argument, not a request for the node's help."""
    process = start(*arguments)
    processes.append(process)
    stdout, stderr = process.communicate(timeout=START_TIMEOUT)
    assert 'usage: propagation_node' not in stdout
    assert process.returncode == 2, stderr
    assert 'error: ' in stderr and 'Traceback' not in stderr
