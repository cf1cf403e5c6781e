"""The launch files' nodes started as launch_ros starts them, over real topics.

``ros2 launch`` is not in the venv (launch_ros has no PyPI wheel), so each test reads a file
(``launch_files``), renders its nodes of this package as the command launch_ros runs
(``launch_checks.command_line``: the installed executable, ``__node``, ``__ns``, the parameters
files, the file's parameters written as launch_ros writes them, the remaps) and starts those
processes in a namespace of the test's own. What the file promises is then checked from an
in-process harness: the closed loop runs in lockstep, the dynamics scene publishes in the
frames given, the IMU's mount from the file's static transform reaches ``imu/data``, and the
managed node goes active through the transitions the file requests. tf2_ros is not in the venv
either: the harness publishes the transform the file's static_transform_publisher arguments
describe.
"""

from __future__ import annotations

import math
from pathlib import Path
import subprocess

from ament_index_python.packages import get_package_prefix, get_package_share_directory
from geometry_msgs.msg import QuaternionStamped, TransformStamped, TwistStamped, WrenchStamped
from launch_checks import command_line, problems, static_transform
from launch_files import LaunchedNode, LaunchFile, read_launch_file
from lifecycle_msgs.msg import State, Transition
import numpy as np
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_helpers import Harness, unique_namespace
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64
from test_managed_node import GyroFeed, Lifecycle
from test_node_subprocess import read_until, SERVING, stop_with_sigint
from tf2_msgs.msg import TFMessage

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.scene import load_scene

PACKAGE = 'rigid_body_attitude'
PREFIX = Path(get_package_prefix(PACKAGE))
LAUNCH_DIR = Path(__file__).resolve().parents[2] / 'launch'
SHARE_DIRS = {PACKAGE: Path(get_package_share_directory(PACKAGE))}
TF_STATIC_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)
BASE_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10**7  # 100 Hz stamps


def read(name: str, given: dict[str, str]) -> LaunchFile:
    """The launch file ``name`` with its arguments ``given``; it passes the checks."""
    launch = read_launch_file(LAUNCH_DIR / name, SHARE_DIRS, given)
    assert problems(launch) == []
    return launch


def start(node: LaunchedNode, tmp_path: Path, processes: list) -> subprocess.Popen:
    """``node`` started as launch_ros starts it; returns once it serves."""
    executable = PREFIX / 'lib' / node.package / node.executable
    arguments = command_line(node, executable, tmp_path / f'{node.executable}.params.yaml')
    process = subprocess.Popen(arguments, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               text=True)
    processes.append(process)
    read_until(process, SERVING)
    return process


def stopped(process: subprocess.Popen) -> str:
    """SIGINT; its stderr, after checking exit code 0 and no traceback."""
    code, stderr = stop_with_sigint(process)
    assert code == 0 and 'Traceback' not in stderr, stderr
    return stderr


def seconds(stamp) -> float:
    """A ``builtin_interfaces/Time`` in seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def test_closed_loop_runs_in_lockstep_on_the_sim_clock(ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    launch = read('closed_loop.launch.xml', {'namespace': namespace})
    harness = Harness(ros, namespace)
    clock = harness.record(Clock, '/clock', QoSProfile(
        depth=10, reliability=ReliabilityPolicy.RELIABLE))
    # The controller's torque writer is transient local: its whole history reaches a reader
    # that matches late (the loop runs as fast as the two processes allow).
    torques = harness.record(WrenchStamped, 'torque', QoSProfile(
        depth=5000, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL))
    plant, controller = launch.nodes
    node_process = start(plant, tmp_path, processes)
    controller_process = start(controller, tmp_path, processes)
    try:
        # 2 s of sim time: 200 ticks, each answered by the controller before the next.
        assert harness.spin_until(
            lambda: bool(clock) and seconds(clock[-1].clock) >= 2.0, timeout=60.0), (
            f'sim time {seconds(clock[-1].clock) if clock else None}')
        assert harness.spin_until(lambda: len(torques) >= 200, timeout=30.0), len(torques)
    finally:
        node_stderr = stopped(node_process)
        stopped(controller_process)
    assert 'lockstep: no command' not in node_stderr, node_stderr
    stamps = [round(seconds(t.header.stamp) * 100) for t in torques]
    assert all(abs(seconds(t.header.stamp) * 100 - k) < 1e-6 for t, k in zip(torques, stamps))
    # The controller's limit (torque_limit 0.5 N m) on the slew's first, large error.
    assert max(abs(t.wrench.torque.x) for t in torques) == 0.5


def test_dynamics_publishes_each_tick_in_the_frames_given(ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    launch = read('dynamics.launch.xml', {'namespace': namespace, 'scene': 'dzhanibekov',
                                          'world_frame': 'launch_world',
                                          'body_frame': 'launch_body'})
    harness = Harness(ros, namespace)
    orientations = harness.record(QuaternionStamped, 'orientation')
    twists = harness.record(TwistStamped, 'twist')
    energies = harness.record(Float64, 'energy')
    process = start(launch.nodes[0], tmp_path, processes)
    try:
        assert harness.spin_until(lambda: len(orientations) >= 10 and len(twists) >= 10
                                  and len(energies) >= 10, timeout=30.0)
    finally:
        stopped(process)
    assert {m.header.frame_id for m in orientations} == {'launch_world'}
    assert {m.header.frame_id for m in twists} == {'launch_body'}
    # The scene given: torque free, its kinetic energy that of its initial rate.
    scene = load_scene('dzhanibekov')
    omega = scene.initial_omega_body
    energy = 0.5 * omega @ scene.inertia.tensor @ omega
    assert np.allclose([m.data for m in energies], energy, rtol=1e-9, atol=0.0)


def rpy_xyzw(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """tf2's ``Quaternion::setRPY`` (fixed axes x, y, z), as (x, y, z, w)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy])


def mount_message(arguments: list[str]) -> TFMessage:
    """The /tf_static message static_transform_publisher sends for ``arguments``."""
    flags, found = static_transform(arguments)
    assert found == []
    transform = TransformStamped()
    transform.header.frame_id = flags['--frame-id']
    transform.child_frame_id = flags['--child-frame-id']
    translation = transform.transform.translation
    translation.x, translation.y, translation.z = (flags[f] for f in ('--x', '--y', '--z'))
    rotation = transform.transform.rotation
    rotation.x, rotation.y, rotation.z, rotation.w = rpy_xyzw(
        *(flags[f] for f in ('--roll', '--pitch', '--yaw')))
    return TFMessage(transforms=[transform])


def test_imu_mount_from_the_file_reaches_imu_data(ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    params = tmp_path / 'params.yaml'  # the parameters file argument: no levelling
    params.write_text('/**:\n  ros__parameters:\n    align_seconds: 0.0\n')
    launch = read('imu.launch.xml', {
        'namespace': namespace, 'imu_topic': f'{namespace}/camera/imu',
        'body_frame': 'launch_body', 'imu_frame': 'launch_imu', 'mount_roll': '0.5',
        'mount_yaw': '-1.0', 'mount_z': '0.2', 'params_file': str(params)})
    node, mount = launch.nodes
    harness = Harness(ros, namespace)
    harness.node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS).publish(
        mount_message(mount.arguments))
    imu_publisher = harness.publisher(Imu, 'camera/imu')
    orientations = harness.record(QuaternionStamped, 'orientation')
    sensor = harness.record(Imu, 'imu/data')
    process = start(node, tmp_path, processes)
    try:
        harness.wait_for_connections()
        for k in range(500):
            imu = Imu()
            imu.header.frame_id = 'launch_imu'
            imu.header.stamp.sec, imu.header.stamp.nanosec = divmod(BASE_NS + k * PERIOD_NS,
                                                                    10**9)
            imu.angular_velocity.x, imu.angular_velocity.z = 0.3, -0.2
            imu_publisher.publish(imu)
            if harness.spin_until(lambda: len(sensor) >= 20 and len(orientations) >= 20, 0.02):
                break
    finally:
        stopped(process)
    q_mount = rpy_xyzw(0.5, 0.0, -1.0)
    q_body_sensor = np.array([q_mount[3], *q_mount[:3]])  # (w, x, y, z)
    body = {(m.header.stamp.sec, m.header.stamp.nanosec): m.quaternion for m in orientations}
    pairs = [(body[(m.header.stamp.sec, m.header.stamp.nanosec)], m.orientation)
             for m in sensor if (m.header.stamp.sec, m.header.stamp.nanosec) in body]
    assert len(pairs) >= 10
    assert {m.header.frame_id for m in sensor} == {'launch_imu'}
    for q_body, q_sensor in pairs:  # REP-145: the sensor frame's attitude, body ⊗ mount
        expected = quaternion.multiply([q_body.w, q_body.x, q_body.y, q_body.z], q_body_sensor)
        got = np.array([q_sensor.w, q_sensor.x, q_sensor.y, q_sensor.z])
        assert min(np.max(np.abs(got - expected)), np.max(np.abs(got + expected))) < 1e-9


def test_managed_goes_active_through_the_transitions_of_the_file(
        ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    launch = read('managed.launch.py', {'namespace': namespace})
    harness = Harness(ros, namespace)
    lifecycle = Lifecycle(harness)
    orientations = harness.record(QuaternionStamped, 'orientation')
    feed = GyroFeed(harness)
    process = start(launch.nodes[0], tmp_path, processes)
    try:
        assert lifecycle.state() == State.PRIMARY_STATE_UNCONFIGURED
        at_start = [r for r in launch.transitions if r.after is None]
        on_inactive = [r for r in launch.transitions if r.after == ('configuring', 'inactive')]
        assert len(at_start) == len(on_inactive) == 1
        assert lifecycle.change(getattr(Transition, at_start[0].transition))
        assert lifecycle.state() == State.PRIMARY_STATE_INACTIVE
        assert lifecycle.change(getattr(Transition, on_inactive[0].transition))
        assert lifecycle.state() == State.PRIMARY_STATE_ACTIVE
        harness.wait_for_connections()
        feed.send(np.array([0.1, 0.2, 0.3]), until=lambda: len(orientations) >= 5)
    finally:
        stopped(process)
