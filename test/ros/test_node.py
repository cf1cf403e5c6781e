"""The attitude_propagator node in-process, with real rclpy and real topics (no mocks).

Each test builds the node with ``parameter_overrides`` in a context of its own (domain of the
test run, localhost discovery, a namespace per test) and talks to it through a harness node
on the same executor. Numbers are checked against closed forms and against the core fed the
same floats (the node must add nothing of its own).
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import (
    PoseWithCovarianceStamped,
    PoseStamped, QuaternionStamped, TwistStamped, Vector3Stamped, WrenchStamped)
import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from ros_helpers import Harness, stamp, unique_namespace
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from rigid_body_attitude.msgs.decoders import decode_pose_stamped
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import (
    CalibrationError, InputError, IntegratorError, SceneError)
from rigid_body_attitude.session.reports import body_frame_velocity
from rigid_body_attitude.session.uncertainty import BATCH_SIZE
from rigid_body_attitude.session.times import TimeBase
from rigid_body_attitude.ros.node import AttitudePropagatorNode, LOG_EVERY_PERIODS
from rigid_body_attitude.ros.serve import main
from rigid_body_attitude.session.outputs import OutputTracker
from rigid_body_attitude.core.propagator import build_propagator
from rigid_body_attitude.core.dynamics.scene import load_scene
from rigid_body_attitude.session.stream import ClockDriver, CommandStream, GyroStream

#: Input stamps start at a realistic epoch with a fractional second: as float seconds these
#: would have a spacing of 2.4e-7 s; the node must keep them exact.
BASE_NS = 1_700_000_000 * 10**9 + 123_456_789
MS = 1_000_000

#: 1 kHz gyro, |ω| = 7 rad/s: the attitude passes w = 0 at t = π/7 s, so a sign flip of the
#: published quaternion would show against the (continuous) closed form.
OMEGA = (2.0, -3.0, 6.0)


def nanoseconds(time_message: Time) -> int:
    """Integer nanoseconds of a builtin_interfaces/Time."""
    return time_message.sec * 10**9 + time_message.nanosec


def imu_message(at_ns: int, omega: tuple[float, float, float]) -> Imu:
    """An Imu with only the gyro filled in (orientation marked absent, as IMUs do)."""
    imu = Imu()
    imu.header.stamp = stamp(at_ns)
    imu.header.frame_id = 'base_link'  # mounted in the body frame: no mount to look up
    imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = omega
    imu.orientation_covariance[0] = -1.0
    return imu


def scalar_first(messages: list[Any]) -> np.ndarray:
    """(w, x, y, z) rows of QuaternionStamped or PoseStamped messages."""
    rows = []
    for message in messages:
        q = message.quaternion if hasattr(message, 'quaternion') else message.pose.orientation
        rows.append((q.x, q.y, q.z, q.w))
    return quaternion.from_ros(np.array(rows))


def start_node(harness: Harness, **parameters: Any) -> AttitudePropagatorNode:
    """The node under test in the harness's namespace with ``parameters``."""
    node = AttitudePropagatorNode(
        context=harness.ros.context, namespace=harness.node.get_namespace(),
        parameter_overrides=[Parameter(name, value=value) for name, value in parameters.items()])
    return harness.add_node(node)


def deep_qos(namespace: str, topics: dict[str, str]) -> dict[str, Any]:
    """qos_overrides parameters making ``topics`` (name → publisher/subscription) reliable and
    5000 deep, so a burst of 1001 messages in one process loses none."""
    overrides = {}
    for topic, kind in topics.items():
        prefix = f'qos_overrides.{namespace}/{topic}.{kind}'
        overrides[f'{prefix}.reliability'] = 'reliable'
        overrides[f'{prefix}.depth'] = 5000
    return overrides


def publish_and_wait(harness: Harness, node: AttitudePropagatorNode, topic: str,
                     message: Any) -> None:
    """Publish one input and spin until the node has taken it (outputs get 50 ms to arrive)."""
    expected = node.built.session.received_count() + 1
    harness.publishers[topic].publish(message)
    assert harness.spin_until(lambda: node.built.session.received_count() >= expected, 5.0)
    harness.spin_for(0.05)


def status_values(array: DiagnosticArray) -> dict[str, str]:
    """Key → value of the first status."""
    return {pair.key: pair.value for pair in array.status[0].values}


def own_statuses(messages: list[DiagnosticArray], node: AttitudePropagatorNode
                 ) -> list[DiagnosticArray]:
    """The /diagnostics messages of ``node`` (others may share the domain's /diagnostics)."""
    name = node.get_fully_qualified_name()
    return [m for m in messages if m.status and m.status[0].name == name]


# -- parameters ----------------------------------------------------------------------------

@pytest.mark.parametrize('name, value, error, match', [
    ('scene', 'no_such_scene', SceneError, "Unknown scene 'no_such_scene'; built-in scenes"),
    ('publish_rate', 50, InputError, 'Expected parameter `publish_rate` to be a double'),
    ('max_dt', -1.0, InputError, 'Bad parameter `max_dt`: .*out of range'),
    ('max_dt', 0.0, InputError, '`max_dt` to be a finite number in \\(0, 3600\\], got 0.0'),
    ('integrator', 'no_such_method', IntegratorError, "Unknown strapdown method"),
    ('mount_rpy', [0, 0, 1], InputError, 'Expected parameter `mount_rpy` to be a double array'),
    ('mount_rpy', [0.0, 1.0], InputError, '`mount_rpy` to be a double array of 3 numbers'),
    ('mount_rpy', [math.nan, 0.0, 1.0], InputError, '`mount_rpy` to hold finite numbers'),
    ('world_axes', 'xyz', InputError, "`world_axes` to be one of 'enu', 'ned', 'nwu'"),
    ('calibration_file', '/no/such/imu.yaml', CalibrationError,
     "Calibration file '/no/such/imu.yaml' does not exist"),
])
def test_node_refuses_bad_parameters_at_start(ros, request, name, value, error, match):
    overrides = {'scene': 'strapdown', name: value}
    with pytest.raises(error, match=match):
        AttitudePropagatorNode(
            context=ros.context, namespace=unique_namespace(request),
            parameter_overrides=[Parameter(key, value=item) for key, item in overrides.items()])


def test_main_prints_one_error_line_and_returns_2_for_a_bad_scene(capsys):
    code = main(['propagation_node', '--ros-args', '-p', 'scene:=no_such_scene'])
    stderr = capsys.readouterr().err
    assert code == 2
    assert stderr.startswith("error: Unknown scene 'no_such_scene'")
    assert stderr.count('\n') == 1 and 'Traceback' not in stderr


def test_main_prints_one_error_line_for_a_bad_calibration_file(capsys, tmp_path):
    path = tmp_path / 'imu.yaml'
    path.write_text('bias: [0.1, 0.0]\n')
    code = main(['propagation_node', '--ros-args', '-p', 'scene:=strapdown', '-p',
                 f'calibration_file:={path}'])
    stderr = capsys.readouterr().err
    assert code == 2
    assert stderr.startswith(f"error: Calibration file '{path}': Expected bias to be")
    assert stderr.count('\n') == 1 and 'Traceback' not in stderr


def test_runtime_parameter_changes_are_checked_and_applied(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    assert node.set_parameters([Parameter('max_dt', value=0.5)])[0].successful
    assert node.built.session.stream.max_dt == 0.5
    assert node.set_parameters([Parameter('constant_dt', value=0.002)])[0].successful
    assert node.built.session.stream.constant_dt == 0.002
    refused = node.set_parameters([Parameter('max_dt', value=0.0)])[0]
    assert not refused.successful
    assert '`max_dt` to be a finite number in (0, 3600]' in refused.reason
    assert node.built.session.stream.max_dt == 0.5
    assert not node.set_parameters([Parameter('body_frame', value='world')])[0].successful
    assert not node.set_parameters([Parameter('scene', value='dzhanibekov')])[0].successful
    assert node.set_parameters([Parameter('world_frame', value='map')])[0].successful
    assert node.built.outputs.world_frame == 'map'
    pose = node.built.outputs.encode_pose(1, 2, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    assert decode_pose_stamped(pose)[2] == 'map'


SET_POSE = ('set_pose', 'set_pose_with_covariance')


@pytest.mark.parametrize('scene, inputs, outputs', [
    ('strapdown', {'imu', 'angular_velocity', *SET_POSE}, {'imu/data', 'pose_with_covariance'}),
    ('torque_free_box', {*SET_POSE}, {'twist', 'odom', 'energy', 'angular_momentum'}),
    ('commanded_torque', {'torque', *SET_POSE}, {'twist', 'odom', 'energy', 'angular_momentum'}),
    ('free_flyer', {'torque', *SET_POSE}, {'twist', 'odom', 'energy', 'angular_momentum'}),
    ('gyrostat', {'rotor_torque', *SET_POSE}, {'twist', 'odom', 'energy', 'angular_momentum'}),
])
def test_subscriptions_exist_only_for_the_inputs_the_scene_uses(ros, request, scene, inputs,
                                                                outputs):
    namespace = unique_namespace(request)
    node = AttitudePropagatorNode(context=ros.context, namespace=namespace,
                                  parameter_overrides=[Parameter('scene', value=scene)])
    assert set(node.built.subscriptions_by_topic) == inputs
    published = {name.removeprefix(namespace + '/')
                 for name, _ in node.get_publisher_names_and_types_by_node(
                     node.get_name(), namespace)}
    common = {'orientation', 'pose', '/diagnostics', '/rosout', '/parameter_events'}
    assert published == common | outputs
    node.destroy_node()


# -- gyro scenes ---------------------------------------------------------------------------

def test_constant_rate_at_1khz_matches_closed_form_and_core(ros, request):
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    node = start_node(harness, scene='strapdown', world_frame='map', **deep_qos(
        namespace, {'imu': 'subscription', 'orientation': 'publisher', 'pose': 'publisher',
                    'imu/data': 'publisher'}))
    assert node.built.subscriptions_by_topic['imu'].qos_profile.reliability == \
        ReliabilityPolicy.RELIABLE
    imu_publisher = harness.publisher(Imu, 'imu')
    orientations = harness.record(QuaternionStamped, 'orientation')
    poses = harness.record(PoseStamped, 'pose')
    imu_outputs = harness.record(Imu, 'imu/data')
    harness.wait_for_connections()
    count = 1001
    stamps_ns = [BASE_NS + k * MS for k in range(count)]
    for at_ns in stamps_ns:
        imu_publisher.publish(imu_message(at_ns, OMEGA))
    assert harness.spin_until(lambda: min(len(orientations), len(poses), len(imu_outputs))
                              >= count, 30.0), (len(orientations), len(poses), len(imu_outputs))

    published = scalar_first(orientations)
    # delta_single (as exp_map) is exact for a constant rate (all factors exp(dt ω) commute),
    # so only round-off remains: ~1000 steps x a few ulp ~ 1e-13, inside the 1e-9.
    times = np.arange(count) * 1e-3
    closed_form = quaternion.exp(times[:, None] * np.array(OMEGA))
    assert np.max(np.abs(published - closed_form)) <= 1e-9
    # The stream rules fed the same stamps and floats give the same bits.
    propagator = build_propagator(load_scene('strapdown'))
    stream, tracker = GyroStream(propagator, 0.1, 1.0), OutputTracker()
    core = []
    for at_ns in stamps_ns:
        stream.add(at_ns, OMEGA)
        core.append(tracker.attitude(propagator))
    assert np.max(np.abs(published - np.array(core))) <= 1e-15
    assert np.max(np.abs(np.linalg.norm(published, axis=1) - 1.0)) <= 1e-12
    assert np.all(np.sum(published[1:] * published[:-1], axis=1) > 0.0)  # no sign flip
    assert [nanoseconds(m.header.stamp) for m in orientations] == stamps_ns
    assert {m.header.frame_id for m in orientations + poses} == {'map'}
    assert np.array_equal(scalar_first(poses), published)
    assert all(m.pose.position.x == m.pose.position.y == m.pose.position.z == 0.0
               for m in poses)
    last = imu_outputs[-1]
    assert nanoseconds(last.header.stamp) == stamps_ns[-1]
    assert last.header.frame_id == 'base_link'
    assert (last.orientation.w, last.orientation.x, last.orientation.y,
            last.orientation.z) == tuple(published[-1])
    assert (last.angular_velocity.x, last.angular_velocity.y, last.angular_velocity.z) == OMEGA
    # The attitude covariance about world axes (REP-145), as the session holds it after the
    # last fold (1000 steps: 3 folds of 256, 232 steps pending).
    assert tuple(last.orientation_covariance) == node.built.session.uncertainty.published
    covariance = np.reshape(last.orientation_covariance, (3, 3))
    assert np.array_equal(covariance, covariance.T) and np.linalg.eigvalsh(covariance)[0] > 0.0
    assert node.built.session.stream.accepted == count and not node.built.session.stream.rejected


def test_the_raw_take_loop_serves_gyro_topics_and_timers_beside_an_executor(ros, request):
    """main()'s structure in-process: the node's RawTakeLoop in a thread of its own takes every
    queued gyro message and runs the timers; the harness executor serves the rest (set_pose,
    the reset service) and never the claimed gyro subscriptions."""
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    node = start_node(harness, scene='strapdown', publish_rate=100.0, **deep_qos(
        namespace, {'imu': 'subscription', 'angular_velocity': 'subscription',
                    'orientation': 'publisher', 'pose': 'publisher', 'imu/data': 'publisher'}))
    imu_publisher = harness.publisher(Imu, 'imu')
    rate_publisher = harness.publisher(Vector3Stamped, 'angular_velocity')
    harness.publisher(PoseStamped, 'set_pose')
    orientations = harness.record(QuaternionStamped, 'orientation')
    poses = harness.record(PoseStamped, 'pose')
    imu_outputs = harness.record(Imu, 'imu/data')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    loop = node.serving_loop()
    thread = threading.Thread(target=loop.run, daemon=True)
    thread.start()
    try:
        count = 1001
        stamps_ns = [BASE_NS + k * MS for k in range(count)]
        for at_ns in stamps_ns:  # one burst: the loop takes many per wake-up
            imu_publisher.publish(imu_message(at_ns, OMEGA))
        assert harness.spin_until(lambda: min(len(orientations), len(poses),
                                              len(imu_outputs)) >= count, 30.0)
        # Exact for a constant rate up to round-off over 1000 steps (as the test above).
        closed_form = quaternion.exp(np.arange(count)[:, None] * 1e-3 * np.array(OMEGA))
        assert np.max(np.abs(scalar_first(orientations) - closed_form)) <= 1e-9
        assert np.array_equal(scalar_first(poses), scalar_first(orientations))
        assert [nanoseconds(m.header.stamp) for m in imu_outputs] == stamps_ns
        assert loop.handled == count
        # The diagnostics timer runs in the loop (a gyro scene has no output timer).
        assert node.built.output_timer is None and loop.timers == [
            (node.built.diagnostics_timer.handle, node.diagnostics_callback)]
        assert harness.spin_until(lambda: any(
            status_values(m)['accepted'] == str(count) for m in own_statuses(diagnostics,
                                                                             node)), 5.0)
        # set_pose goes through the executor, the next gyro sample through the loop.
        pose = PoseStamped()
        pose.header.frame_id = 'world'
        pose.pose.orientation.x, pose.pose.orientation.w = 1.0, 0.0  # 180° about x
        publish_and_wait(harness, node, 'set_pose', pose)
        rate = Vector3Stamped()
        rate.header.stamp = stamp(stamps_ns[-1] + MS)
        rate.vector.x, rate.vector.y, rate.vector.z = OMEGA
        rate_publisher.publish(rate)
        assert harness.spin_until(lambda: len(orientations) > count, 5.0)
        expected = quaternion.multiply([0.0, 1.0, 0.0, 0.0],
                                       quaternion.exp(1e-3 * np.array(OMEGA)))
        expected = quaternion.continuous(expected, scalar_first(orientations[count - 1:count])[0])
        # One exp step in another operation order than the reference: 1e-14 (as above).
        assert np.max(np.abs(scalar_first(orientations[-1:])[0] - expected)) <= 1e-14
        assert len(imu_outputs) == count  # Vector3Stamped input: no imu/data
    finally:
        loop.stop()
        thread.join(5.0)
    assert not thread.is_alive()
    # Claimed: with the loop stopped nothing serves the gyro topics, although the harness
    # executor spins the node.
    imu_publisher.publish(imu_message(stamps_ns[-1] + 2 * MS, OMEGA))
    harness.spin_for(0.3)
    assert len(orientations) == count + 1
    loop.close()


def test_angular_velocity_topic_drives_gyro_scenes(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(Vector3Stamped, 'angular_velocity')
    orientations = harness.record(QuaternionStamped, 'orientation')
    imu_outputs = harness.record(Imu, 'imu/data')
    harness.wait_for_connections()
    omega = (0.0, 0.0, 1.5)
    for k in range(11):
        rate = Vector3Stamped()
        rate.header.stamp = stamp(BASE_NS + 10 * k * MS)
        rate.vector.x, rate.vector.y, rate.vector.z = omega
        publish_and_wait(harness, node, 'angular_velocity', rate)
    assert len(orientations) == 11 and not imu_outputs
    # Exact for a constant rate up to round-off (10 steps): 1e-12.
    expected = quaternion.exp(np.arange(11)[:, None] * 0.01 * np.array(omega))
    assert np.max(np.abs(scalar_first(orientations) - expected)) <= 1e-12


def test_receive_time_replaces_header_stamps_when_asked(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown', use_header_stamps=False)
    harness.publisher(Imu, 'imu')
    orientations = harness.record(QuaternionStamped, 'orientation')
    harness.wait_for_connections()
    before_ns = node.get_clock().now().nanoseconds
    for _ in range(3):  # unstamped (zero) headers, as from a driver that does not stamp
        publish_and_wait(harness, node, 'imu', imu_message(0, OMEGA))
    after_ns = node.get_clock().now().nanoseconds
    stamps_ns = [nanoseconds(m.header.stamp) for m in orientations]
    assert len(stamps_ns) == 3 and not node.built.session.stream.rejected
    assert before_ns <= stamps_ns[0] < stamps_ns[1] < stamps_ns[2] <= after_ns
    # Integrated over the receive-time differences (exact for a constant rate; the float
    # seconds of the time base carry ~1e-16 s relative error): 1e-12.
    elapsed = (stamps_ns[2] - stamps_ns[0]) * 1e-9
    expected = quaternion.exp(elapsed * np.array(OMEGA))
    assert np.max(np.abs(scalar_first(orientations[-1:])[0] - expected)) <= 1e-12


def test_timing_faults_are_rejected_counted_and_reported(ros, request, capfd):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown', max_dt=0.1, time_jump_threshold=1.0)
    harness.publisher(Imu, 'imu')
    orientations = harness.record(QuaternionStamped, 'orientation')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    step = quaternion.exp(1e-3 * np.array(OMEGA))
    identity = quaternion.identity()
    step2 = quaternion.multiply(step, step)
    # (stamp offset [ms], outputs so far, last output's attitude and stamp offset, rejections).
    # A jump waits for two confirming samples (stream.JUMP_CONFIRMATIONS): nothing is
    # published meanwhile; a sample on the old time line makes the candidate an outlier.
    script = [
        (0.0, 1, identity, 0.0, {}),                                           # baseline
        (1.0, 2, step, 1.0, {}),                                               # integrated
        (1.0, 2, step, 1.0, {'stale_stamp': 1}),                               # duplicate
        (0.5, 2, step, 1.0, {'stale_stamp': 2}),                               # out of order
        (501.0, 2, step, 1.0, {'stale_stamp': 2}),                             # jump? pending
        (2.0, 3, step2, 2.0, {'stale_stamp': 2, 'outlier_stamp': 1}),          # no: outlier
        (601.0, 3, step2, 2.0, {'stale_stamp': 2, 'outlier_stamp': 1}),        # jump? pending
        (602.0, 3, step2, 2.0, {'stale_stamp': 2, 'outlier_stamp': 1}),        # pending
        (603.0, 4, quaternion.multiply(step2, step2), 603.0,                   # confirmed gap:
         {'stale_stamp': 2, 'outlier_stamp': 1, 'gap': 1}),                    # held, then 2
        (-4397.0, 4, quaternion.multiply(step2, step2), 603.0,                 # loop? pending
         {'stale_stamp': 2, 'outlier_stamp': 1, 'gap': 1}),
        (-4396.0, 4, quaternion.multiply(step2, step2), 603.0,
         {'stale_stamp': 2, 'outlier_stamp': 1, 'gap': 1}),
        (-4395.0, 5, step2, -4395.0,                                           # confirmed:
         {'stale_stamp': 2, 'outlier_stamp': 1, 'gap': 1, 'time_jump': 1}),    # reset, 2 steps
    ]
    for offset_ms, outputs, attitude, output_offset_ms, rejected in script:
        publish_and_wait(harness, node, 'imu',
                         imu_message(BASE_NS + round(offset_ms * MS), OMEGA))
        assert len(orientations) == outputs, offset_ms
        assert nanoseconds(orientations[-1].header.stamp) == \
            BASE_NS + round(output_offset_ms * MS)
        # At most two exp steps computed in another operation order than the reference
        # (scalar_exp_step with renormalisation): ~10 roundings of 1.1e-16 each, so 1e-14.
        assert np.max(np.abs(scalar_first(orientations[-1:])[0] - attitude)) <= 1e-14
        assert dict(node.built.session.stream.rejected) == rejected, offset_ms
    assert harness.spin_until(lambda: any(
        status_values(m)['rejected time_jump'] == '1' for m in own_statuses(diagnostics, node)),
        3.0)
    statuses = [m.status[0] for m in own_statuses(diagnostics, node)]
    warned = ' '.join(s.message for s in statuses if s.level == DiagnosticStatus.WARN)
    assert '1 gap in the last period' in warned and '1 time_jump in the last period' in warned
    final = status_values(own_statuses(diagnostics, node)[-1])
    assert (final['rejected stale_stamp'], final['rejected gap'], final['accepted']) == \
        ('2', '1', '7')  # baseline, 3 integrated steps, 2 after the gap, 2 after the jump
    assert final['scene'] == 'strapdown' and final['integrator'] == 'delta_single'
    assert capfd.readouterr().err.count('stamps jumped back') == 1  # logged once


def test_a_gyro_scene_reports_what_a_strapdown_user_needs_and_no_energy(ros, request, capfd):
    """/diagnostics of a gyro scene: accepted rate, missed samples, rotation from the initial
    attitude, gyro bias, alignment; no rigid-body energy or momentum, in the status or in the
    INFO line logged every LOG_EVERY_PERIODS periods."""
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(Imu, 'imu')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    rate = (0.0, 0.0, math.pi / 2)  # 90°/s: 10 steps of 1 ms turn the body by 0.9°
    for k in range(11):
        publish_and_wait(harness, node, 'imu', imu_message(BASE_NS + k * MS, rate))
    capfd.readouterr()
    for _ in range(LOG_EVERY_PERIODS):
        node.diagnostics_callback()
    assert harness.spin_until(lambda: len(own_statuses(diagnostics, node)) >= 1, 5.0)
    values = status_values(own_statuses(diagnostics, node)[-1])
    assert [key for key in values if not key.startswith(('rejected ', 'malformed '))
            and '.' not in key] == [
        'scene', 'rate_source', 'integrator', 'step [s]', 'time [s]',
        'rotation_from_initial [deg]', 'gyro_bias [rad/s]', 'alignment',
        'quaternion_norm_error', 'input_rate [Hz]', 'received_rate [Hz]', 'received',
        'accepted', 'missed_samples', 'calibration', 'tilt_stddev [deg]',
        'yaw_stddev [deg]']
    assert values['calibration'] == 'none'
    assert float(values['rotation_from_initial [deg]']) == pytest.approx(0.9, abs=1e-9)
    assert values['gyro_bias [rad/s]'] == 'none'
    assert values['alignment'].startswith('not levelled: no accelerometer data')
    assert (values['accepted'], values['missed_samples']) == ('11', '0')
    err, deadline = '', time.monotonic() + 5.0  # the log thread writes it
    while ' t=' not in err and time.monotonic() < deadline:
        time.sleep(0.05)
        err += capfd.readouterr().err
    time.sleep(0.2)
    err += capfd.readouterr().err
    info = [line for line in err.splitlines() if ' t=' in line]
    assert len(info) == 1
    text = info[0].split(']: ', 1)[1]  # the namespace holds the test's name
    assert text.startswith('t=1700000000.133 s: rotation 0.900 deg from the initial attitude')
    assert 'energy' not in text and ' J' not in text and text.endswith('missed 0')


def test_the_published_covariance_is_about_fixed_world_axes_on_a_rotating_body(ros, request):
    """REP-145: ``imu/data``'s orientation_covariance and ``pose_with_covariance``'s
    orientation block are about the world's axes. An uncertainty about world x only (set with
    set_pose_with_covariance), a gyro with no error, a quarter turn about the vertical: the
    uncertainty stays about world x (in body axes it would now be about y)."""
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    node = start_node(harness, scene='strapdown', gyroscope_noise_density=0.0,
                      gyroscope_random_walk=0.0, gyroscope_turn_on_bias=0.0,
                      gyroscope_scale_stddev=0.0, gyroscope_misalignment_stddev=0.0,
                      **deep_qos(namespace, {'imu': 'subscription', 'imu/data': 'publisher',
                                             'pose_with_covariance': 'publisher'}))
    harness.publisher(Imu, 'imu')
    harness.publisher(PoseWithCovarianceStamped, 'set_pose_with_covariance')
    imu_outputs = harness.record(Imu, 'imu/data')
    poses = harness.record(PoseWithCovarianceStamped, 'pose_with_covariance')
    harness.wait_for_connections()
    start = PoseWithCovarianceStamped()
    start.header.frame_id = 'world'
    start.pose.pose.orientation.w = 1.0
    covariance = np.zeros((6, 6))
    covariance[3:, 3:] = np.diag([1e-2, 1e-6, 1e-6])  # about world x (east)
    start.pose.covariance = covariance.reshape(36).tolist()
    publish_and_wait(harness, node, 'set_pose_with_covariance', start)
    count = 1 + 2 * BATCH_SIZE  # whole batches: the last output carries every step
    rate = (0.0, 0.0, math.pi / 2 / ((count - 1) * 1e-3))
    for k in range(count):
        harness.publishers['imu'].publish(imu_message(BASE_NS + k * MS, rate))
    assert harness.spin_until(lambda: min(len(imu_outputs), len(poses)) >= count, 30.0)
    assert quaternion.attitude_error(scalar_first([poses[-1].pose])[0],
                                     quaternion.exp(np.array([0.0, 0.0, math.pi / 2]))) < 1e-9
    published = np.reshape(imu_outputs[-1].orientation_covariance, (3, 3))
    assert published[0, 0] == pytest.approx(1e-2, rel=1e-9)
    assert published[1, 1] == pytest.approx(1e-6, rel=1e-6)
    assert np.max(np.abs(published - np.diag(np.diag(published)))) < 1e-12
    full = np.reshape(poses[-1].pose.covariance, (6, 6))
    assert np.array_equal(full[3:, 3:], published) and np.array_equal(full, full.T)
    assert np.linalg.eigvalsh(full)[0] > 0.0 and np.all(np.diag(full)[:3] == 1e9)
    assert {m.header.frame_id for m in poses} == {'world'}


def test_non_finite_inputs_are_rejected_and_outputs_stay_finite(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(Imu, 'imu')
    harness.publisher(PoseStamped, 'set_pose')
    orientations = harness.record(QuaternionStamped, 'orientation')
    harness.wait_for_connections()
    publish_and_wait(harness, node, 'imu', imu_message(BASE_NS, OMEGA))
    publish_and_wait(harness, node, 'imu', imu_message(BASE_NS + MS, (math.nan, 0.0, 0.0)))
    publish_and_wait(harness, node, 'imu', imu_message(BASE_NS + MS, (0.0, 0.0, -math.inf)))
    bad_pose = PoseStamped()
    bad_pose.header.frame_id = 'world'
    bad_pose.pose.orientation.w = math.nan
    publish_and_wait(harness, node, 'set_pose', bad_pose)
    zero_pose = PoseStamped()
    zero_pose.header.frame_id = 'world'
    zero_pose.pose.orientation.w = 0.0  # (0, 0, 0, 0): not a rotation
    publish_and_wait(harness, node, 'set_pose', zero_pose)
    assert len(orientations) == 1
    assert dict(node.built.session.stream.rejected) == {'non_finite': 2}
    assert dict(node.built.session.rejections) == {'non_finite': 1, 'invalid_pose': 1}
    pose = PoseStamped()
    pose.header.frame_id = 'world'
    pose.pose.orientation.x, pose.pose.orientation.w = 1.0, 0.0  # 180° about x
    publish_and_wait(harness, node, 'set_pose', pose)
    publish_and_wait(harness, node, 'imu', imu_message(BASE_NS + MS, OMEGA))
    assert len(orientations) == 2
    published = scalar_first(orientations)
    assert np.all(np.isfinite(published))
    expected = quaternion.multiply([0.0, 1.0, 0.0, 0.0], quaternion.exp(1e-3 * np.array(OMEGA)))
    # Published on the side of the previous output (the identity); one exp step computed in
    # another operation order than the reference: ~10 roundings of 1.1e-16, so 1e-14.
    expected = quaternion.continuous(expected, published[0])
    assert np.max(np.abs(published[1] - expected)) <= 1e-14

    response = harness.call(Trigger, 'attitude_propagator/reset', Trigger.Request())
    assert response.success and 'strapdown' in response.message
    publish_and_wait(harness, node, 'imu', imu_message(BASE_NS + 2 * MS, OMEGA))
    assert np.array_equal(scalar_first(orientations[-1:])[0],
                          quaternion.continuous(quaternion.identity(), published[1]))


# -- dynamics scenes -----------------------------------------------------------------------

def advance_clock(harness: Harness, clock_ns: int, outputs: list[Any], count: int) -> None:
    """Publish /clock = ``clock_ns`` and spin until ``count`` outputs arrived."""
    clock = Clock()
    clock.clock = stamp(clock_ns)
    harness.publishers['/clock'].publish(clock)
    assert harness.spin_until(lambda: len(outputs) >= count, 5.0), (clock_ns, len(outputs))


def test_commanded_torque_on_sim_time_gives_the_core_rates_and_energy(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='commanded_torque', use_sim_time=True, publish_rate=50.0)
    harness.publisher(Clock, '/clock')
    harness.publisher(WrenchStamped, 'torque')
    twists = harness.record(TwistStamped, 'twist')
    poses = harness.record(PoseStamped, 'pose')
    energies = harness.record(Float64, 'energy')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    start_ns = 1000 * 10**9
    advance_clock(harness, start_ns, twists, 1)
    first_ns = nanoseconds(twists[0].header.stamp)
    torque_body = (0.0, 0.01, 0.0)  # about the box's y axis, a principal axis
    wrench = WrenchStamped()
    wrench.header.stamp = stamp(first_ns)
    wrench.wrench.torque.y = math.nan
    publish_and_wait(harness, node, 'torque', wrench)
    wrench.wrench.torque.x, wrench.wrench.torque.y, wrench.wrench.torque.z = torque_body
    publish_and_wait(harness, node, 'torque', wrench)
    assert node.built.session.commands_accepted == 1
    assert dict(node.built.session.commands.rejected) == {'non_finite': 1}
    ticks = 50  # 1 s of sim time; the scene holds a command 0.5 s
    for k in range(1, ticks + 1):
        advance_clock(harness, first_ns + k * 20 * MS, twists, k + 1)
    harness.spin_until(lambda: len(energies) >= ticks + 1, 2.0)
    assert len(twists) == len(poses) == len(energies) == ticks + 1

    # The core driven through the same stream classes and time base, tick by tick.
    propagator = build_propagator(load_scene('commanded_torque'))
    driver, commands, time_base = ClockDriver(propagator, 1.0), CommandStream(propagator), \
        TimeBase()
    time_base.start(first_ns)  # scene time 0 at the first tick
    driver.tick(time_base.seconds(first_ns))
    commands.add('torque', first_ns, time_base.seconds(first_ns), torque_body)
    j2 = propagator.scene.inertia.tensor[1, 1]
    rate = torque_body[1] / j2
    for twist, pose, energy in zip(twists[1:], poses[1:], energies[1:]):
        at_ns = nanoseconds(twist.header.stamp)
        driver.tick(time_base.seconds(at_ns))
        omega = (twist.twist.angular.x, twist.twist.angular.y, twist.twist.angular.z)
        assert omega == tuple(propagator.state.omega_body.tolist())  # same bits as the core
        assert energy.data == propagator.energy()
        elapsed = (at_ns - first_ns) * 1e-9
        if elapsed < 0.5:
            # ω̇ = M/J₂ is constant, so RK4 is exact for ω (round-off only, 1e-12) and ω stays
            # on the principal axis (ω × Jω = 0 exactly).
            assert omega[0] == omega[2] == 0.0
            assert omega[1] == pytest.approx(rate * elapsed, rel=1e-12, abs=1e-15)
            assert energy.data == pytest.approx(0.5 * j2 * omega[1] ** 2, rel=1e-12, abs=1e-18)
            # Attitude about y by θ = ½ (M/J₂) t²: RK4's global error C h⁴ (h = 1 ms,
            # derivatives of order (M/J₂ t)ⁿ ≤ 1) is ~1e-12; 1e-10 bounds it.
            angle = 0.5 * rate * elapsed ** 2
            q = pose.pose.orientation
            assert np.max(np.abs(np.array([q.w, q.x, q.y, q.z]) - [
                math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])) <= 1e-10
    held = [t.twist.angular.y for t in twists if nanoseconds(t.header.stamp) - first_ns > 520 * MS]
    assert len(set(held)) == 1  # torque zeroed after the timeout: torque-free spin
    # The command ends 0.5 s after its stamp, inside at most one 1 ms step: within 1/500.
    assert held[0] == pytest.approx(rate * 0.5, rel=2e-3)

    def stale_reported() -> bool:
        return any(status_values(m)['rejected stale_torque'] == '1'
                   for m in own_statuses(diagnostics, node))
    assert harness.spin_until(stale_reported, 3.0)
    values = status_values(own_statuses(diagnostics, node)[-1])
    assert values['rejected non_finite'] == '1' and values['commanded_torque.stale'] == '1'
    assert values['integrator'] == 'rk4' and values['step [s]'] == '0.001'
    # The balance as the core computes it (printed with 4 digits); its size comes from the
    # step in which the command ends, where the torque is discontinuous.
    residual = propagator.diagnostics().energy_balance_residual
    assert float(values['energy_balance_residual [J]']) == pytest.approx(residual, rel=1e-3)

    response = harness.call(Trigger, 'attitude_propagator/reset', Trigger.Request())
    assert response.success
    advance_clock(harness, first_ns + (ticks + 1) * 20 * MS, twists, ticks + 2)
    assert (twists[-1].twist.angular.x, twists[-1].twist.angular.y,
            twists[-1].twist.angular.z) == (0.0, 0.0, 0.0)


def test_commanded_force_moves_the_pose_as_the_core_predicts(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='free_flyer', use_sim_time=True, publish_rate=50.0)
    harness.publisher(Clock, '/clock')
    harness.publisher(WrenchStamped, 'torque')
    twists = harness.record(TwistStamped, 'twist')
    poses = harness.record(PoseStamped, 'pose')
    harness.wait_for_connections()
    advance_clock(harness, 1000 * 10**9, twists, 1)
    first_ns = nanoseconds(twists[0].header.stamp)
    force_body, torque_body = (2.0, 0.0, -1.0), (0.0, 0.0, 0.05)
    wrench = WrenchStamped()
    wrench.header.stamp = stamp(first_ns)
    wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.force.z = force_body
    wrench.wrench.torque.x, wrench.wrench.torque.y, wrench.wrench.torque.z = torque_body
    publish_and_wait(harness, node, 'torque', wrench)
    assert node.built.session.commands_accepted == 1  # torque and force from one WrenchStamped
    for k in range(1, 11):
        advance_clock(harness, first_ns + k * 20 * MS, twists, k + 1)
    assert harness.spin_until(lambda: len(poses) >= 11, 2.0)

    propagator = build_propagator(load_scene('free_flyer'))
    driver, commands, time_base = ClockDriver(propagator, 1.0), CommandStream(propagator), \
        TimeBase()
    time_base.start(first_ns)  # scene time 0 at the first tick
    driver.tick(time_base.seconds(first_ns))
    start = time_base.seconds(first_ns)
    commands.add('torque', first_ns, start, torque_body)
    commands.add('force', first_ns, start, force_body)
    for k in range(1, 11):
        driver.tick(time_base.seconds(first_ns + k * 20 * MS))
    position, twist = poses[-1].pose.position, twists[-1].twist
    # The node adds nothing to the core: the same bits.
    assert (position.x, position.y, position.z) == tuple(propagator.state.position.tolist())
    assert (twist.angular.x, twist.angular.y, twist.angular.z) == \
        tuple(propagator.state.omega_body.tolist())
    assert (twist.linear.x, twist.linear.y, twist.linear.z) == \
        body_frame_velocity(propagator)
    assert twists[-1].header.frame_id == 'base_link'
    # Against the physics: the cube spins about z only (isotropic inertia, torque about z),
    # so the world force keeps F_z exactly, and the translation update is exact for a
    # constant force: z = F_z t²/2m to round-off. Its x component is F_x cos θ with
    # θ < 0.03 rad over 0.2 s: x = v0 t + F_x t²/2m within (1 − cos 0.03) of the force term,
    # 1e-4 of x; 1e-3 bounds it.
    elapsed, mass = 0.2, propagator.scene.mass
    assert position.z == pytest.approx(force_body[2] * elapsed**2 / (2 * mass), rel=1e-12)
    assert position.x == pytest.approx(0.1 * elapsed + force_body[0] * elapsed**2 / (2 * mass),
                                       rel=1e-3)


def test_a_refused_integration_resets_instead_of_crashing(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='commanded_torque', use_sim_time=True)
    harness.publisher(Clock, '/clock')
    harness.publisher(WrenchStamped, 'torque')
    twists = harness.record(TwistStamped, 'twist')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    advance_clock(harness, 1000 * 10**9, twists, 1)
    first_ns = nanoseconds(twists[0].header.stamp)
    wrench = WrenchStamped()
    wrench.header.stamp = stamp(first_ns)
    wrench.wrench.torque.y = 1e12  # ω reaches 6e10 rad/s after one 1 ms step
    publish_and_wait(harness, node, 'torque', wrench)
    clock = Clock()
    clock.clock = stamp(first_ns + 20 * MS)
    harness.publishers['/clock'].publish(clock)
    # RK4 would need > 1e6 substeps (h|ω| ≤ 2 rad each): refused, counted, scene reset.
    session = node.built.session
    assert harness.spin_until(lambda: session.rejections['integration_failed'] == 1, 5.0)
    assert len(twists) == 1
    advance_clock(harness, first_ns + 40 * MS, twists, 2)
    last = twists[-1]
    assert nanoseconds(last.header.stamp) == first_ns + 40 * MS
    assert (last.twist.angular.x, last.twist.angular.y, last.twist.angular.z) == (0., 0., 0.)

    def error_reported() -> bool:
        return any(m.status[0].level == DiagnosticStatus.ERROR
                   and '1 integration_failed in the last period' in m.status[0].message
                   for m in own_statuses(diagnostics, node))
    assert harness.spin_until(error_reported, 3.0)
    assert status_values(own_statuses(diagnostics, node)[-1])['rejected integration_failed'] \
        == '1'


def test_diagnostics_error_when_the_step_is_too_coarse(ros, request):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='torque_free_box', step=0.5, publish_rate=2.0,
                      use_sim_time=True)
    harness.publisher(Clock, '/clock')
    momenta = harness.record(Vector3Stamped, 'angular_momentum')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    start_ns = 1000 * 10**9
    advance_clock(harness, start_ns, momenta, 1)
    first_ns = nanoseconds(momenta[0].header.stamp)
    for k in range(1, 5):  # 2 s at ω h ≈ 1.5: RK4's momentum drift reaches 1.5e-3
        advance_clock(harness, first_ns + k * 500 * MS, momenta, k + 1)

    propagator = build_propagator(load_scene('torque_free_box').with_overrides(step=0.5))
    propagator.advance_to(2.0)
    drift = propagator.diagnostics().momentum_drift
    assert drift > 1e-3  # the scenario really is past the ERROR threshold

    def error_reported() -> bool:
        return any(m.status[0].level == DiagnosticStatus.ERROR
                   for m in own_statuses(diagnostics, node))
    assert harness.spin_until(error_reported, 3.0)
    status = own_statuses(diagnostics, node)[-1].status[0]
    assert status.level == DiagnosticStatus.ERROR and 'momentum drift' in status.message
    values = status_values(own_statuses(diagnostics, node)[-1])
    assert values['step [s]'] == '0.5'
    assert float(values['momentum_drift']) == pytest.approx(drift, rel=1e-3)  # printed %.3e
    h = momenta[-1].vector
    assert np.allclose((h.x, h.y, h.z), propagator.world_momentum(), rtol=1e-12, atol=1e-15)
