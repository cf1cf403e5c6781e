"""The installed ``attitude_controller`` executable over real topics, in processes of its own.

* Closed loop: ``propagation_node`` (scene ``commanded_torque`` started 60° off the target,
  100 Hz ticks) and the controller, each in its own process, the harness only listening. The
  same loop in the core (tests below: the propagator with the torque of each 10 ms tick held
  over it) stays below 1° from 3.63 s after the first torque on; over ROS without lockstep the
  torque acts late by the delivery delay (one or two ticks late: 3.61 s and 3.58 s in the
  core), and on a loaded machine the plant's timer ticks stretch and a torque may be held for
  several ticks: runs beside a load average of 16 settled after 3.56 s and after more than
  5.6 s. The bound is therefore 3.63 s plus two seconds; the free-running loop is not
  reproducible (lockstep is what makes it so).
* The controller alone: an ``odom`` message (and, with ``state_input`` ``orientation_twist``,
  a pair of inputs) is answered with one torque of the same stamp, equal to the law; hostile
  inputs are rejected and counted in ``/diagnostics``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
import signal
import subprocess

from ament_index_python.packages import get_package_prefix
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import (
    QuaternionStamped, TransformStamped, TwistStamped, Vector3Stamped, WrenchStamped)
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import JointState, MagneticField
from tf2_msgs.msg import TFMessage
import yaml

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.attitude.quaternion import rotate_floats
from rigid_body_attitude.core.control import pd_torque_floats
from rigid_body_attitude.core.control.allocation import wheel_torques
from rigid_body_attitude.core.control.magnetic import bdot_dipole, dumping_dipole
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.cdr import encode_quaternion_stamped
from rigid_body_attitude.msgs.odometry import encode_odometry
from rigid_body_attitude.ros.controller import AttitudeControllerNode
from rigid_body_attitude.session.settings import load_node_scene
from rigid_body_attitude.session.wheel_drive import WheelDrive

PACKAGE = 'rigid_body_attitude'
#: A reader of the controller's transient-local torque writer that gets its whole history.
LATCHED_QOS = QoSProfile(depth=5000, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
START_TIMEOUT = 30.0
SETTLING_BOUND = 3.63 + 2.0  # s of plant time after the first torque (module docstring)


def start(name: str, *arguments: str) -> subprocess.Popen:
    path = Path(get_package_prefix(PACKAGE)) / 'lib' / PACKAGE / name
    assert path.is_file() and os.access(path, os.X_OK), f'{path} is not an executable file'
    return subprocess.Popen([str(path), *arguments], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def stop(process: subprocess.Popen) -> tuple[int, str]:
    process.send_signal(signal.SIGINT)
    try:
        _, stderr = process.communicate(timeout=15.0)
    except subprocess.TimeoutExpired:
        process.kill()
        _, stderr = process.communicate()
        pytest.fail(f'process ignored SIGINT; stderr:\n{stderr}')
    return process.returncode, stderr


def stamp_ns(message) -> int:
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec


def scene_file(tmp_path: Path) -> Path:
    """The commanded_torque scene, at rest 60° about (1, 2, −2)/3 from the identity."""
    scene = yaml.safe_load((Path(get_package_prefix(PACKAGE)) / 'share' / PACKAGE / 'config'
                            / 'scenes' / 'commanded_torque.yaml').read_text())
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    scene['initial_state']['attitude'] = quat.exp(math.radians(60.0) * axis).tolist()
    path = tmp_path / 'slew.yaml'
    path.write_text(yaml.safe_dump(scene))
    return path


def test_closed_loop_with_the_propagation_node_settles(ros, request, processes, tmp_path):
    namespace = unique_namespace(request)
    plant = start('propagation_node', '--ros-args', '-p', f'scene:={scene_file(tmp_path)}',
                  '-p', 'publish_rate:=100.0', '-r', f'__ns:={namespace}')
    processes.append(plant)
    harness = Harness(ros, namespace)
    orientations = harness.record(QuaternionStamped, 'orientation')
    harness.wait_for_connections(START_TIMEOUT)  # every tick the controller sees recorded
    # the controller's writer is transient local: every torque from the first, however late
    # this reader matches it
    torques = harness.record(WrenchStamped, 'torque', LATCHED_QOS)
    controller = start('attitude_controller', '--ros-args', '-r', f'__ns:={namespace}')
    processes.append(controller)
    harness.wait_for_connections(START_TIMEOUT)
    assert harness.spin_until(lambda: len(torques) > 0, START_TIMEOUT), 'no torque'
    first_ns = stamp_ns(torques[0])
    end_ns = first_ns + int((SETTLING_BOUND + 2.0) * 1e9)
    assert harness.spin_until(lambda: orientations and stamp_ns(orientations[-1]) >= end_ns,
                              60.0), 'the plant did not reach the end of the run'
    assert stop(controller)[0] == 0
    code, stderr = stop(plant)
    assert code == 0 and 'Traceback' not in stderr, stderr
    # every torque carries the stamp of a tick the plant published, each tick at most once
    tick_stamps = {stamp_ns(m) for m in orientations}
    torque_stamps = [stamp_ns(m) for m in torques]
    assert set(torque_stamps) <= tick_stamps and len(set(torque_stamps)) == len(torque_stamps)
    assert {m.header.frame_id for m in torques} == {'base_link'}
    errors = [(stamp_ns(m), math.degrees(quat.attitude_error(
        [m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z], [1.0, 0, 0, 0])))
        for m in orientations if stamp_ns(m) >= first_ns]
    assert errors[0][1] == pytest.approx(60.0, abs=0.5)
    above = [t for t, error in errors if error >= 1.0]
    settled_after = (max(above) - first_ns) * 1e-9
    assert settled_after <= SETTLING_BOUND, settled_after
    print(f'settled below 1 deg {settled_after:.3f} s after the first torque')


def test_controller_answers_a_pair_and_counts_hostile_inputs(ros, request, processes):
    namespace = unique_namespace(request)
    controller = start('attitude_controller', '--ros-args', '-p', 'kp:=0.5', '-p',
                       'torque_limit:=1.0', '-p', 'state_input:=orientation_twist',
                       '-r', f'__ns:={namespace}')
    processes.append(controller)
    harness = Harness(ros, namespace)
    orientation = harness.publisher(QuaternionStamped, 'orientation')
    twist = harness.publisher(TwistStamped, 'twist')
    torques = harness.record(WrenchStamped, 'torque')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections(START_TIMEOUT)
    attitude = quat.exp([0.2, -0.4, 0.3]).tolist()
    rate = (0.5, -0.2, 0.1)
    good = QuaternionStamped()
    good.header.stamp.sec, good.header.stamp.nanosec = 12, 340_000_000
    good.header.frame_id = 'world'
    q = good.quaternion
    q.w, q.x, q.y, q.z = attitude
    twist_message = TwistStamped()
    twist_message.header.stamp.sec, twist_message.header.stamp.nanosec = 12, 340_000_000
    twist_message.header.frame_id = 'base_link'
    angular = twist_message.twist.angular
    angular.x, angular.y, angular.z = rate
    # hostile inputs: wrong frame, non-unit, non-finite, bytes that are no message
    wrong_frame = encode_quaternion_stamped(1, 'map', attitude)
    non_unit = encode_quaternion_stamped(2, 'world', [1.1, 0.0, 0.0, 0.0])
    non_finite = encode_quaternion_stamped(3, 'world', [math.nan, 0.0, 0.0, 1.0])
    for data in (wrong_frame, non_unit, non_finite, b'\x00\x01\x00\x00\x07'):
        orientation.publish(data)
    orientation.publish(good)
    twist.publish(twist_message)
    assert harness.spin_until(lambda: len(torques) == 1, 10.0)
    torque = torques[0]
    assert stamp_ns(torque) == 12_340_000_000 and torque.header.frame_id == 'base_link'
    expected = pd_torque_floats(attitude, rate, (1.0, 0.0, 0.0, 0.0), (0.5,) * 3, (0.04,) * 3,
                                (1.0,) * 3)
    assert (torque.wrench.torque.x, torque.wrench.torque.y, torque.wrench.torque.z) == expected
    assert (torque.wrench.force.x, torque.wrench.force.y, torque.wrench.force.z) == (0, 0, 0)

    def counted() -> dict[str, str]:
        for message in reversed(diagnostics):
            for status in message.status:
                if status.name.endswith('attitude_controller'):
                    return {value.key: value.value for value in status.values}
        return {}
    keys = ('rejected wrong_frame', 'rejected non_unit', 'rejected non_finite',
            'rejected malformed')
    assert harness.spin_until(lambda: all(counted().get(key) == '1' for key in keys), 10.0), (
        counted())
    assert counted()['ticks answered'] == '1'
    code, stderr = stop(controller)
    assert code == 0 and 'Traceback' not in stderr, stderr


def counted_values(diagnostics) -> dict[str, str]:
    """The controller's last ``/diagnostics`` values."""
    for message in reversed(diagnostics):
        for status in message.status:
            if status.name.endswith('attitude_controller'):
                return {value.key: value.value for value in status.values}
    return {}


def test_controller_answers_odom_and_counts_hostile_odom(ros, request, processes):
    namespace = unique_namespace(request)
    controller = start('attitude_controller', '--ros-args', '-p', 'kp:=0.5', '-p',
                       'torque_limit:=1.0', '-r', f'__ns:={namespace}')
    processes.append(controller)
    harness = Harness(ros, namespace)
    odom = harness.publisher(Odometry, 'odom')
    torques = harness.record(WrenchStamped, 'torque')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections(START_TIMEOUT)
    attitude = quat.exp([0.2, -0.4, 0.3]).tolist()
    rate = (0.5, -0.2, 0.1)
    good = Odometry()
    good.header.stamp.sec, good.header.stamp.nanosec = 12, 340_000_000
    good.header.frame_id, good.child_frame_id = 'world', 'base_link'
    q = good.pose.pose.orientation
    q.w, q.x, q.y, q.z = attitude
    angular = good.twist.twist.angular
    angular.x, angular.y, angular.z = rate
    zero = (0.0, 0.0, 0.0)
    hostile = [encode_odometry(1, 'map', 'base_link', zero, attitude, zero, rate),
               encode_odometry(2, 'world', 'imu_link', zero, attitude, zero, rate),
               encode_odometry(3, 'world', 'base_link', zero, [1.1, 0.0, 0.0, 0.0], zero, rate),
               encode_odometry(4, 'world', 'base_link', zero, attitude, zero,
                               (math.nan, 0.0, 0.0)),
               encode_odometry(5, 'world', 'base_link', zero, attitude, zero, rate)[:60]]
    for data in hostile:
        odom.publish(data)
    odom.publish(good)
    assert harness.spin_until(lambda: len(torques) == 1, 10.0)
    torque = torques[0]
    assert stamp_ns(torque) == 12_340_000_000 and torque.header.frame_id == 'base_link'
    expected = pd_torque_floats(attitude, rate, (1.0, 0.0, 0.0, 0.0), (0.5,) * 3, (0.04,) * 3,
                                (1.0,) * 3)
    assert (torque.wrench.torque.x, torque.wrench.torque.y, torque.wrench.torque.z) == expected
    expected_counts = {'rejected wrong_frame': '2', 'rejected non_unit': '1',
                       'rejected non_finite': '1', 'rejected malformed': '1'}
    assert harness.spin_until(lambda: all(
        counted_values(diagnostics).get(key) == value
        for key, value in expected_counts.items()), 10.0), counted_values(diagnostics)
    assert counted_values(diagnostics)['ticks answered'] == '1'
    code, stderr = stop(controller)
    assert code == 0 and 'Traceback' not in stderr, stderr


@pytest.mark.parametrize('arguments, expected', [
    (('-p', 'kd:=-1.0'), 'error: Bad parameter `kd`'),
    (('-p', 'kp:=1'), 'error: Expected parameter `kp` to be a double'),
    (('-p', 'target_quaternion_xyzw:=[0.0, 0.0, 0.0, 2.0]'),
     'error: Expected parameter `target_quaternion_xyzw` to have norm 1'),
    (('-p', 'target_rpy:=[0.1, 0.0, 0.0]', '-p', 'target_quaternion_xyzw:=[0.0, 0.0, 0.0, 1.0]'),
     'error: Expected at most one of `target_rpy` and `target_quaternion_xyzw`'),
    (('-p', 'target_quaternion:=[0.0, 0.0, 0.0, 1.0]'),
     'error: Parameter `target_quaternion` is named `target_quaternion_xyzw`'),
])
def test_bad_parameters_exit_2_with_one_error_line(arguments, expected, processes):
    process = start('attitude_controller', '--ros-args', *arguments)
    processes.append(process)
    _, stderr = process.communicate(timeout=30.0)
    assert process.returncode == 2
    assert stderr.startswith(expected) and stderr.count('\n') == 1, stderr
    assert 'Traceback' not in stderr


def test_a_former_parameter_name_is_refused_naming_the_present_one(ros, request):
    """``target_quaternion`` (renamed ``target_quaternion_xyzw``): refused at start and at run
    time with a message naming the present name."""
    namespace = unique_namespace(request)
    with pytest.raises(InputError, match='`target_quaternion` is named `target_quaternion_xyzw`'):
        AttitudeControllerNode(context=ros.context, namespace=namespace, parameter_overrides=[
            Parameter('target_quaternion', value=[0.0, 0.0, 0.0, 1.0])])
    node = AttitudeControllerNode(context=ros.context, namespace=namespace)
    try:
        result = node.set_parameters([Parameter('target_quaternion',
                                                value=[0.0, 0.0, 0.0, 1.0])])[0]
        assert not result.successful and 'target_quaternion_xyzw' in result.reason
        good = node.set_parameters([Parameter('target_quaternion_xyzw',
                                              value=[0.0, 0.0, 1.0, 0.0])])[0]
        assert good.successful and node.session.target == (0.0, 0.0, 0.0, 1.0)
    finally:
        node.destroy_node()


# -- the torque rods' inputs, hostile ---------------------------------------------------------

#: The publishers of the static transforms: as tf2_ros's static broadcaster (transient local).
STATIC_QOS = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
NOT_A_MESSAGE = b'\x00\x01\x00\x00\x07'
ATTITUDE = quat.exp([0.2, -0.4, 0.3]).tolist()
RATE = (0.5, -0.2, 0.1)


def odometry(stamp: int) -> Odometry:
    """A good ``odom`` tick stamped ``stamp`` [ns]: ATTITUDE and RATE."""
    message = Odometry()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
    message.header.frame_id, message.child_frame_id = 'world', 'base_link'
    q = message.pose.pose.orientation
    q.w, q.x, q.y, q.z = ATTITUDE
    angular = message.twist.twist.angular
    angular.x, angular.y, angular.z = RATE
    return message


def magnetic_field(stamp: int, frame: str, field, covariance=(0.0,) * 9,
                   nanosec: int | None = None) -> MagneticField:
    """An ``imu/mag`` sample [T] stamped ``stamp`` [ns] (or with ``nanosec`` as given)."""
    message = MagneticField()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
    if nanosec is not None:
        message.header.stamp.nanosec = nanosec
    message.header.frame_id = frame
    vector = message.magnetic_field
    vector.x, vector.y, vector.z = field
    message.magnetic_field_covariance = list(covariance)
    return message


def joint_state(stamp: int, names, velocity, nanosec: int | None = None) -> JointState:
    """A ``wheels/state`` stamped ``stamp`` [ns] (or with ``nanosec`` as given)."""
    message = JointState()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
    if nanosec is not None:
        message.header.stamp.nanosec = nanosec
    message.name, message.velocity = list(names), list(velocity)
    return message


def static_transform(parent: str, child: str, wxyz) -> TransformStamped:
    transform = TransformStamped()
    transform.header.frame_id, transform.child_frame_id = parent, child
    r = transform.transform.rotation
    r.w, r.x, r.y, r.z = wxyz
    return transform


def vector_of(message) -> tuple[float, float, float]:
    vector = message.vector
    return vector.x, vector.y, vector.z


def last_status(diagnostics) -> str:
    """The controller's last ``/diagnostics`` message and values (a failure's message)."""
    for message in reversed(diagnostics):
        for status in message.status:
            if status.name.endswith('attitude_controller'):
                return f'{status.message}: {counted_values(diagnostics)}'
    return 'no diagnostics'


def reader_matched(harness, diagnostics, mag) -> int:
    """Send ``imu/mag`` (a best-effort input: the first messages after the match can be
    lost) a sample of 2 T until the controller counts one, then the count once it settled."""
    def probes() -> int:
        return int(counted_values(diagnostics).get('rejected out_of_range', '0'))
    for _ in range(50):
        mag.publish(magnetic_field(1_000_000_000, 'base_link', (2.0, 0.0, 0.0)))
        if harness.spin_until(lambda: probes() > 0, 0.2):
            break
    harness.spin_for(0.5)  # probes in flight arrive
    reports = len(diagnostics)
    assert harness.spin_until(lambda: len(diagnostics) > reports, 5.0)
    assert probes() > 0
    return probes()


def assert_counted_and_stopped(harness, diagnostics, controller, expected: dict[str, str]):
    """Each reason counted as ``expected`` (and no other), never OK while no tick was
    answered; the controller ends with exit 0 and no traceback on SIGINT."""
    def rejected() -> dict[str, str]:
        return {key: value for key, value in counted_values(diagnostics).items()
                if key.startswith('rejected ')}
    assert harness.spin_until(lambda: rejected() == expected, 10.0), rejected()
    for message in diagnostics:
        for status in message.status:
            values = {value.key: value.value for value in status.values}
            if status.name.endswith('attitude_controller') and values['ticks answered'] == '0':
                assert status.level != DiagnosticStatus.OK, status.message
    code, stderr = stop(controller)
    assert code == 0 and 'Traceback' not in stderr, stderr
    return stderr


def test_bdot_controller_counts_hostile_fields_and_transforms(ros, request, processes):
    """B-dot (``actuator`` magnetorquers), the magnetometer's mount on ``/tf_static``: every
    hostile sample and transform counted by its reason; the good ticks answered with the law."""
    namespace = unique_namespace(request)
    gain = 4e5
    controller = start('attitude_controller', '--ros-args', '-p', 'actuator:=magnetorquers',
                       '-p', f'bdot_gain:={gain}', '-p', 'magnetometer_period:=0.1',
                       '-r', f'__ns:={namespace}')
    processes.append(controller)
    harness = Harness(ros, namespace)
    odom = harness.publisher(Odometry, 'odom')
    mag = harness.publisher(MagneticField, 'imu/mag')
    tf_static = harness.publisher(TFMessage, '/tf_static', STATIC_QOS)
    dipoles = harness.record(Vector3Stamped, 'dipole')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections(START_TIMEOUT)
    mount = (0.0, 0.0, 0.0, 1.0)  # mag_link yawed 180° in base_link
    hostile_mounts = [static_transform('mag_link', 'mag_link', mount),       # tf_bad_frames
                      static_transform('base_link', 'mag_link', (math.nan, 0.0, 0.0, 1.0)),
                      static_transform('base_link', 'mag_link', (2.0, 0.0, 0.0, 0.0)),
                      static_transform('base_link', 'mag_link', (0.0, 0.0, 0.0, 0.0)),
                      static_transform('base_link', 'other_link', mount)]  # another frame
    tf_static.publish(TFMessage(transforms=hostile_mounts))
    tf_static.publish(NOT_A_MESSAGE)
    tf_static.publish(TFMessage(transforms=[static_transform('base_link', 'mag_link', mount)]))
    probes = reader_matched(harness, diagnostics, mag)
    t1, t2, t3, t4 = 1_000_000_000, 1_100_000_000, 1_200_000_000, 1_300_000_000
    fields = {t1: (2e-5, -1e-5, 3e-5), t2: (2.2e-5, -0.7e-5, 2.9e-5), t4: (2.5e-5, 0.1e-5, 2.6e-5)}
    for message in (magnetic_field(t1, 'mag_link', (math.nan, 0.0, 0.0)),     # non_finite
                    magnetic_field(t1, 'mag_link', (2.0, 0.0, 0.0)),          # out_of_range
                    magnetic_field(t1, 'mag_link', (0.0, 0.0, 0.0)),          # out_of_range
                    magnetic_field(t1, 'mag_link', (1e-160, 0.0, 0.0)),       # out_of_range
                    magnetic_field(t1, 'mag_link', fields[t1], nanosec=2_000_000_000),
                    magnetic_field(t1, 'mag_link', (9e-5, 9e-5, 9e-5)),  # replaced: repeated
                    magnetic_field(t1, 'mag_link', fields[t1])):
        mag.publish(message)
    mag.publish(NOT_A_MESSAGE)
    # the good sample replaced the first of its stamp before the tick comes (another topic)
    assert harness.spin_until(lambda: counted_values(diagnostics).get(
        'rejected repeated_stamp') == '1', 10.0), last_status(diagnostics)
    odom.publish(odometry(t1))
    assert harness.spin_until(lambda: len(dipoles) == 1, 10.0), last_status(diagnostics)
    mag.publish(magnetic_field(500_000_000, 'mag_link', fields[t1]))  # stale
    mag.publish(magnetic_field((2**31 - 1) * 1_000_000_000, 'mag_link', fields[t1]))  # kept
    garbage_covariance = (math.nan, -1.0, math.inf, 1e308, 0.0, -5.0, 1.0, 2.0, math.nan)
    mag.publish(magnetic_field(t2, 'mag_link', fields[t2], garbage_covariance))
    odom.publish(odometry(t2))
    mag.publish(magnetic_field(t3, 'map', fields[t4]))  # no mount for map: the tick waits
    odom.publish(odometry(t3))
    for _ in range(2):  # the same sample twice: nothing lost, nothing counted
        mag.publish(magnetic_field(t4, 'mag_link', fields[t4]))
    odom.publish(odometry(t4))
    assert harness.spin_until(lambda: len(dipoles) == 3, 10.0)
    harness.spin_for(0.3)
    body = {stamp: rotate_floats((0.0, 0.0, 0.0, 1.0), field) for stamp, field in fields.items()}
    assert [(stamp_ns(m), vector_of(m)) for m in dipoles] == [
        (t1, (0.0, 0.0, 0.0)),
        (t2, bdot_dipole(body[t2], body[t1], (t2 - t1) / 1_000_000_000, gain)),
        (t4, bdot_dipole(body[t4], body[t2], (t4 - t2) / 1_000_000_000, gain))]
    assert {m.header.frame_id for m in dipoles} == {'base_link'}
    assert_counted_and_stopped(harness, diagnostics, controller, {
        'rejected tf_bad_frames': '1', 'rejected tf_non_finite': '1',
        'rejected tf_denormalized': '2', 'rejected malformed': '2',
        'rejected non_finite': '1', 'rejected out_of_range': str(3 + probes),
        'rejected invalid_stamp': '1', 'rejected repeated_stamp': '1',
        'rejected stale_stamp': '1', 'rejected no_mount': '1'})


def test_dumping_controller_counts_hostile_wheel_states_and_fields(ros, request, processes):
    """Momentum dumping (``reaction_wheels``, ``dumping_gain``): every hostile wheel state and
    sample counted by its reason; the good ticks answered with the laws."""
    namespace = unique_namespace(request)
    gain = 0.001
    controller = start('attitude_controller', '--ros-args', '-p', 'actuator:=reaction_wheels',
                       '-p', 'scene:=wheel_slew_commanded', '-p', f'dumping_gain:={gain}',
                       '-p', 'kp:=0.5', '-p', 'torque_limit:=1.0', '-r', f'__ns:={namespace}')
    processes.append(controller)
    harness = Harness(ros, namespace)
    odom = harness.publisher(Odometry, 'odom')
    mag = harness.publisher(MagneticField, 'imu/mag')
    wheels = harness.publisher(JointState, 'wheels/state')
    dipoles = harness.record(Vector3Stamped, 'dipole')
    commands = harness.record(JointState, 'wheels/command')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections(START_TIMEOUT)
    drive = WheelDrive(load_node_scene('wheel_slew_commanded'))
    names = drive.names  # wheel_a .. wheel_d
    speeds = {1_000_000_000: (150.0, -100.0, 120.0, -60.0),
              1_050_000_000: (149.0, -99.0, 121.0, -61.0)}
    t1, t2 = speeds
    field = (2e-5, -1e-5, 3e-5)  # in base_link: no mount needed
    probes = reader_matched(harness, diagnostics, mag)
    for message in (joint_state(t1, (*names[:3], 'wheel_x'), speeds[t1]),  # unknown_wheel
                    joint_state(t1, names[:2], speeds[t1][:2]),             # missing_wheel
                    joint_state(t1, names, speeds[t1][:3]),                 # wheel_lengths
                    joint_state(t1, names, (math.nan, 0.0, 0.0, 0.0)),      # non_finite
                    joint_state(t1, names, speeds[t1], nanosec=1_000_000_000),  # invalid
                    joint_state(t1, names[::-1], speeds[t1][::-1])):  # good, names reversed
        wheels.publish(message)
    wheels.publish(NOT_A_MESSAGE)
    for message in (magnetic_field(t1, 'base_link', (0.0, 0.0, 0.0)),       # out_of_range
                    magnetic_field(t1, 'base_link', (1e-160, 0.0, 1e-160)),  # out_of_range
                    magnetic_field(t1, 'base_link', (0.0, math.inf, 0.0)),  # non_finite
                    magnetic_field(t1, 'base_link', field)):
        mag.publish(message)
    mag.publish(NOT_A_MESSAGE)
    odom.publish(odometry(t1))
    assert harness.spin_until(lambda: len(dipoles) == 1 and len(commands) == 1, 10.0)
    mag.publish(magnetic_field(t1, 'base_link', (5e-5, 0.0, 0.0)))  # the used sample: refused
    wheels.publish(joint_state(500_000_000, names, speeds[t1]))     # stale
    wheels.publish(joint_state(t2, names, (1.0, 2.0, 3.0, 4.0)))    # replaced: repeated
    wheels.publish(joint_state(t2, names, speeds[t2]))
    # the good wheel state replaced the first of its stamp before the tick comes
    assert harness.spin_until(lambda: counted_values(diagnostics).get(
        'rejected repeated_stamp') == '2', 10.0), last_status(diagnostics)
    odom.publish(odometry(t2))  # its sample is t1's (10 Hz)
    assert harness.spin_until(lambda: len(dipoles) == 2 and len(commands) == 2, 10.0)
    harness.spin_for(0.3)
    torque = pd_torque_floats(ATTITUDE, RATE, (1.0, 0.0, 0.0, 0.0), (0.5,) * 3, (0.04,) * 3,
                              (1.0,) * 3)
    assert [(stamp_ns(m), vector_of(m)) for m in dipoles] == [
        (t, dumping_dipole(drive.stored_momentum(speeds[t]), field, gain)) for t in (t1, t2)]
    assert [(stamp_ns(m), tuple(m.name), tuple(m.effort)) for m in commands] == [
        (t, names, tuple(wheel_torques(drive.allocation, torque))) for t in (t1, t2)]
    assert_counted_and_stopped(harness, diagnostics, controller, {
        'rejected unknown_wheel': '1', 'rejected missing_wheel': '1',
        'rejected wheel_lengths': '1', 'rejected non_finite': '2',
        'rejected invalid_stamp': '1', 'rejected malformed': '2',
        'rejected out_of_range': str(2 + probes), 'rejected repeated_stamp': '2',
        'rejected stale_stamp': '1'})
