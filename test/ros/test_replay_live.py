"""Bag-replayed tests: each analytic bag offline through ``replay`` and live through the node.

For every case of :mod:`bag_fixtures` (constant rate, coning, generic rate, torque-free
tumbling, constant commanded torque), and for the constant-rate bag with hostile records
injected (:data:`FAULTS`: truncated, header-only, unknown encapsulation, a rate of 1e200 rad/s,
published to the node as the raw bytes they are):

(a) ``replay`` (its ``main``) writes the node's outputs for the bag to an output bag;
(b) a player publishes the bag's messages, with their recorded stamps, over real rclpy topics
    into the running ``attitude_propagator`` node (in-process, ``use_sim_time``), while a
    recorder collects the node's outputs.

The player follows the replay tool's documented clock rule: ``/clock`` is published at every
multiple ``k P`` of the timer period within the bag's time span (gyro bags: plus one after the
last sample), before the messages recorded at that instant; each message is delivered and
taken by the node before the next event (the player waits for the session's input counters,
for the node clock to reach each tick, and in dynamics scenes for the session's tick counter;
a gyro scene has no output timer). Then (a) and (b) must agree to 1e-12 output by output
(matched by stamp), and both must match the closed form within the integrator's error bound
given by the case.
"""

from __future__ import annotations

import math
from pathlib import Path
import struct
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import (
    PoseStamped, PoseWithCovarianceStamped, QuaternionStamped, TwistStamped, Vector3Stamped,
    WrenchStamped)
import numpy as np
import pytest
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from ros_helpers import Harness, RosContext, unique_namespace
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64

from bag_fixtures import (
    AnalyticCase, build_case, CASES, GYRO_RATE, write_case_bag, write_records, write_scene)
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.bag import BagReader, typestore
from rigid_body_attitude.msgs import (
    decode_pose_with_covariance_stamped,
    encode_imu, float64_value, header_stamp_ns, IMU, pose_orientation, pose_position, TF_MESSAGE,
    quaternion_stamped, twist_angular, twist_linear, vector3_stamped)
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.qos import TF_STATIC_QOS
from tf2_msgs.msg import TFMessage
from rigid_body_attitude.tools.replay import main as replay_main
from rigid_body_attitude.session.settings import timer_period_ns

PUBLISH_RATE = 100.0
#: (a) and (b) run the same float operations on the same inputs; the issue asks 1e-12.
AGREEMENT = 1e-12
#: Seconds to wait for one input to be taken or one tick to happen before re-publishing it
#: (the node's inputs are best effort), and how often to try.
RETRY_AFTER = 1.0
ATTEMPTS = 5
#: The hostile variant of ``constant_rate``: sample index → what replaces it (not a valid
#: Imu, or a valid one with an absurd rate). The node and the replay must reject the same.
FAULTS = {
    100: lambda data: data[:-9],                        # truncated
    400: lambda data: data[:20],                        # a header only
    700: lambda data: b'\x01\x05' + data[2:],           # unknown CDR encapsulation
    1000: lambda data: encode_imu(header_stamp_ns(data), 'base_link', (1e200, 0.0, 0.0)),
}


def _ns(stamp: Time) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _time(nanoseconds: int) -> Time:
    sec, nanosec = divmod(nanoseconds, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


# -- the offline outputs ---------------------------------------------------------------------

def offline_outputs(path: Path) -> dict[str, Any]:
    """The replay's output bag as ``{topic: {stamp_ns: values}}`` (energy: a list)."""
    decoders = {
        '/orientation': lambda data: quaternion_stamped(data)[1],
        '/pose': lambda data: pose_position(data)[1] + pose_orientation(data)[1],
        '/twist': lambda data: twist_angular(data)[1] + twist_linear(data)[1],
        '/imu/data': _imu_orientation,
        '/pose_with_covariance': lambda data: decode_pose_with_covariance_stamped(data)[3:],
        '/angular_momentum': lambda data: vector3_stamped(data)[1],
    }
    outputs: dict[str, Any] = {name.lstrip('/'): {} for name in decoders}
    outputs['energy'] = []
    outputs['momentum_order'] = []
    with BagReader(path) as reader:
        topics = [name for name in reader.topics if name.lstrip('/') in outputs]
        for topic, _, _, data in reader.messages(topics):
            name = topic.lstrip('/')
            if name == 'energy':
                outputs['energy'].append(float64_value(data))
                continue
            outputs[name][header_stamp_ns(data)] = decoders['/' + name](data)
            if name == 'angular_momentum':
                outputs['momentum_order'].append(header_stamp_ns(data))
    return outputs


def _imu_orientation(data: bytes) -> tuple[float, ...]:
    """(w, x, y, z) and the orientation covariance of a little-endian CDR Imu (the body starts
    with x, y, z, w and the 9 covariance values)."""
    offset = 4 + ((12 + int.from_bytes(data[12:16], 'little') + 7) & -8)
    x, y, z, w, *covariance = struct.unpack_from('<13d', data, offset)
    return (w, x, y, z, *covariance)


# -- the live run ------------------------------------------------------------------------------

class LiveRun:
    """Player and recorder around the in-process node, in lockstep with the node's counters."""

    def __init__(self, ros: RosContext, namespace: str, case: AnalyticCase,
                 scene_path: Path, parameters: dict[str, Any] | None = None) -> None:
        """Start the node with the case's scene (and ``parameters``) on sim time and connect
        the harness."""
        self.harness = Harness(ros, namespace)
        self.node = self.harness.add_node(AttitudePropagatorNode(
            context=ros.context, namespace=namespace, parameter_overrides=[
                Parameter('scene', value=str(scene_path)),
                Parameter('publish_rate', value=PUBLISH_RATE),
                Parameter('use_sim_time', value=True),
                *(Parameter(name, value=value) for name, value in (parameters or {}).items())]))
        self.is_gyro = case.rate_source == 'gyro'
        harness = self.harness
        self.clock = harness.publisher(Clock, '/clock')
        self.received = {
            'orientation': harness.record(QuaternionStamped, 'orientation'),
            'pose': harness.record(PoseStamped, 'pose'),
        }
        if self.is_gyro:
            self.received['imu/data'] = harness.record(Imu, 'imu/data')
            self.received['pose_with_covariance'] = harness.record(PoseWithCovarianceStamped,
                                                                   'pose_with_covariance')
            self.input = harness.publisher(Imu, 'imu')
        else:
            self.received['twist'] = harness.record(TwistStamped, 'twist')
            self.received['energy'] = harness.record(Float64, 'energy')
            self.received['angular_momentum'] = harness.record(Vector3Stamped,
                                                               'angular_momentum')
            self.input = (harness.publisher(WrenchStamped, 'torque')
                          if case.torques is not None else None)
        harness.wait_for_connections()
        self.inputs_sent = 0
        self.ticks_done = 0

    def _until(self, condition: Any, resend: Any, what: str) -> None:
        for _ in range(ATTEMPTS):
            if self.harness.spin_until(condition, RETRY_AFTER):
                return
            resend()
        raise AssertionError(f'the node did not take {what} after {ATTEMPTS} attempts')

    def send_input(self, data: bytes) -> None:
        """Publish one recorded message and wait until the node has taken it."""
        self.inputs_sent += 1
        expected = self.inputs_sent

        def publish() -> None:
            self.input.publish(data)
        publish()
        self._until(lambda: self.node.built.session.received_count() >= expected, publish,
                    f'input {expected}')

    def tick(self, clock_ns: int) -> None:
        """Publish ``/clock = clock_ns`` and wait until the node's timer has run at it."""
        message = Clock(clock=_time(clock_ns))

        def publish() -> None:
            self.clock.publish(message)
        publish()
        self._until(lambda: self.node.get_clock().now().nanoseconds >= clock_ns, publish,
                    f'/clock {clock_ns}')
        if self.is_gyro:  # no output timer: the clock is all
            return
        self.ticks_done += 1
        count = self.ticks_done
        clock = self.node.built.session.clock
        self._until(lambda: clock.accepted >= count, publish, f'the tick at {clock_ns}')

    def wait_for_outputs(self, counts: dict[str, int]) -> None:
        """Spin until the recorder holds as many messages per topic as ``counts``."""
        def complete() -> bool:
            return all(len(self.received[name]) >= count for name, count in counts.items())
        self.harness.spin_until(complete, 10.0)

    def outputs(self) -> dict[str, Any]:
        """The recorded outputs in the structure of :func:`offline_outputs`."""
        received = {'energy': [], 'angular_momentum': [], **self.received}
        outputs: dict[str, Any] = {
            'orientation': {_ns(m.header.stamp): _wxyz(m.quaternion)
                            for m in received['orientation']},
            'pose': {_ns(m.header.stamp): _xyz(m.pose.position) + _wxyz(m.pose.orientation)
                     for m in received['pose']},
            'angular_momentum': {_ns(m.header.stamp): _xyz(m.vector)
                                 for m in received['angular_momentum']},
            'momentum_order': [_ns(m.header.stamp) for m in received['angular_momentum']],
            'energy': [m.data for m in received['energy']],
            'twist': {}, 'imu/data': {}, 'pose_with_covariance': {},
        }
        if 'twist' in received:
            outputs['twist'] = {_ns(m.header.stamp): _xyz(m.twist.angular) + _xyz(m.twist.linear)
                                for m in received['twist']}
        if 'imu/data' in received:
            outputs['imu/data'] = {
                _ns(m.header.stamp): _wxyz(m.orientation) + tuple(m.orientation_covariance)
                for m in received['imu/data']}
            outputs['pose_with_covariance'] = {
                _ns(m.header.stamp): (_xyz(m.pose.pose.position), _wxyz(m.pose.pose.orientation),
                                      tuple(m.pose.covariance))
                for m in received['pose_with_covariance']}
        return outputs


def _wxyz(q: Any) -> tuple[float, float, float, float]:
    return (q.w, q.x, q.y, q.z)


def _xyz(v: Any) -> tuple[float, float, float]:
    return (v.x, v.y, v.z)


def play(run: LiveRun, bag_path: Path) -> None:
    """Publish the bag in bag-time order with /clock ticks at the multiples of the period.

    Ticks within the bag's time span (gyro bags: of the gyro messages, plus the first tick
    after the last one); a tick at T comes before the messages recorded at T.
    """
    period = timer_period_ns(PUBLISH_RATE)
    with BagReader(bag_path) as reader:
        messages = list(reader.messages(list(reader.topics)))
    inputs = 'imu' if run.is_gyro else 'torque'
    if run.is_gyro:
        times = [bag_ns for topic, bag_ns, _, _ in messages if topic == inputs]
    else:
        times = [bag_ns for _, bag_ns, _, _ in messages]
    next_tick = max(-(-times[0] // period), 1) * period
    for topic, bag_ns, _, data in messages:
        if run.is_gyro and topic != inputs:
            continue
        while next_tick <= bag_ns:
            run.tick(next_tick)
            next_tick += period
        if topic == inputs:
            run.send_input(data)
    if run.is_gyro:
        run.tick(next_tick)


# -- comparisons -----------------------------------------------------------------------------

def _differences(offline: dict[int, tuple[float, ...]], live: dict[int, tuple[float, ...]],
                 name: str) -> float:
    assert offline, f'no {name} output offline'
    assert sorted(offline) == sorted(live), (
        f'{name}: stamps differ; offline only {sorted(set(offline) - set(live))[:5]}, live '
        f'only {sorted(set(live) - set(offline))[:5]}')
    return max(float(np.max(np.abs(np.subtract(offline[stamp], live[stamp]))))
               for stamp in offline)


def compare(offline: dict[str, Any], live: dict[str, Any]) -> dict[str, float]:
    """Largest absolute difference per output between (a) and (b)."""
    differences = {}
    for name in ('orientation', 'pose', 'twist', 'imu/data', 'angular_momentum'):
        if offline[name] or live[name]:
            differences[name] = _differences(offline[name], live[name], name)
    assert offline['momentum_order'] == live['momentum_order']
    assert len(offline['energy']) == len(live['energy'])
    if offline['energy']:
        differences['energy'] = float(np.max(np.abs(np.subtract(offline['energy'],
                                                                live['energy']))))
    if offline['imu/data']:  # the covariances: bit for bit, symmetric positive definite
        assert {stamp: values[4:] for stamp, values in offline['imu/data'].items()} == \
            {stamp: values[4:] for stamp, values in live['imu/data'].items()}
        assert offline['pose_with_covariance'] == live['pose_with_covariance']
        for _, _, covariance in offline['pose_with_covariance'].values():
            matrix = np.reshape(covariance, (6, 6))
            assert np.array_equal(matrix, matrix.T) and np.linalg.eigvalsh(matrix)[0] > 0.0
        grown = [values[4] for _, values in sorted(offline['imu/data'].items())]
        assert grown[-1] > grown[0]  # the covariance grows along the run
    return differences


def closed_form_errors(case: AnalyticCase, orientation: dict[int, tuple[float, ...]]
                       ) -> np.ndarray:
    """Attitude error [rad] of every orientation output against the closed form."""
    stamps = np.array(sorted(orientation), dtype=np.int64)
    attitudes = np.array([orientation[stamp] for stamp in stamps.tolist()])
    tau = (stamps - stamps[0]) * 1e-9
    return np.atleast_1d(quaternion.attitude_error(attitudes, case.attitude(tau)))


# -- the test --------------------------------------------------------------------------------

def write_faulty_bag(case: AnalyticCase, path: Path) -> None:
    """The gyro case's Imu samples with :data:`FAULTS` injected (real rosbag2 records)."""
    records = []
    for index, (stamp, rate) in enumerate(zip(case.stamps.tolist(), case.rates.tolist())):
        stamp_ns = round(stamp * 1e9)
        data = encode_imu(stamp_ns, 'base_link', rate)
        records.append(('imu', stamp_ns, FAULTS[index](data) if index in FAULTS else data))
    write_records(path, {'imu': IMU}, records)


#: Rest samples before the motion of the levelled variant, and the rest it averages [s].
REST_SAMPLES = 500
ALIGN_SECONDS = 0.2


def write_levelled_bag(case: AnalyticCase, path: Path) -> float:
    """The gyro case's Imu samples with the accelerometer's gravity at the case's initial
    attitude, after :data:`REST_SAMPLES` of rest; returns that attitude's heading [rad]."""
    q0 = case.attitude(np.zeros(1))[0]
    gravity = tuple(quaternion.rotate_inverse(q0, [0.0, 0.0, 9.80665]).tolist())
    period_ns = round(1e9 / GYRO_RATE)
    first_ns = round(case.stamps[0] * 1e9)
    records = [('imu', stamp_ns, encode_imu(stamp_ns, 'base_link', (0.0, 0.0, 0.0), gravity))
               for stamp_ns in (first_ns - (REST_SAMPLES - k) * period_ns
                                for k in range(REST_SAMPLES))]
    for stamp, rate in zip(case.stamps.tolist(), case.rates.tolist()):
        stamp_ns = round(stamp * 1e9)
        records.append(('imu', stamp_ns, encode_imu(stamp_ns, 'base_link', rate, gravity)))
    write_records(path, {'imu': IMU}, records)
    w, x, y, z = q0.tolist()
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


#: The mounted variant: base_link -> torso (yaw 90°) -> the sensor frame (roll 60°) on
#: /tf_static, the samples measured in the sensor frame.
MOUNT_CHAIN = (quaternion.exp([0.0, 0.0, math.pi / 2]), quaternion.exp([math.pi / 3, 0.0, 0.0]))


def write_mounted_bag(case: AnalyticCase, path: Path, sensor: str) -> tuple[bytes, np.ndarray]:
    """The gyro case's body rates measured in ``sensor`` (mounted by :data:`MOUNT_CHAIN`) and
    the chain on ``/tf_static`` as robot_state_publisher records it; returns the TFMessage
    bytes and the mount (w, x, y, z)."""
    yaw, roll = MOUNT_CHAIN
    tf_static = bytes(typestore().serialize_cdr(_tf_message(
        ('base_link', f'{sensor}_torso', yaw), (f'{sensor}_torso', sensor, roll)), TF_MESSAGE))
    mount = quaternion.multiply(yaw, roll)
    first_ns = round(case.stamps[0] * 1e9)
    records = [('/tf_static', first_ns - 1, tf_static)]
    for stamp, rate in zip(case.stamps.tolist(), case.rates.tolist()):
        stamp_ns = round(stamp * 1e9)
        rate_sensor = tuple(quaternion.rotate_inverse(mount, rate).tolist())
        records.append(('imu', stamp_ns, encode_imu(stamp_ns, sensor, rate_sensor)))
    write_records(path, {'imu': IMU, '/tf_static': TF_MESSAGE}, records)
    return tf_static, mount


def _tf_message(*chain: tuple[str, str, np.ndarray]) -> Any:
    store = typestore()
    header, stamped = store.types['std_msgs/msg/Header'], store.types[
        'geometry_msgs/msg/TransformStamped']
    time, transform = store.types['builtin_interfaces/msg/Time'], store.types[
        'geometry_msgs/msg/Transform']
    vector, rotation = store.types['geometry_msgs/msg/Vector3'], store.types[
        'geometry_msgs/msg/Quaternion']
    return store.types[TF_MESSAGE](transforms=[stamped(
        header=header(stamp=time(sec=0, nanosec=0), frame_id=parent), child_frame_id=child,
        transform=transform(translation=vector(x=0.0, y=0.0, z=0.0), rotation=rotation(
            x=float(q[1]), y=float(q[2]), z=float(q[3]), w=float(q[0]))))
        for parent, child, q in chain])


def levelled_closed_form_errors(case: AnalyticCase, orientation: dict[int, tuple[float, ...]]
                                ) -> np.ndarray:
    """Angles [rad] between the outputs and the closed form, the body at rest (``τ = 0``)
    until the first moving sample: the case's ``exp_map`` holds each sample's rate over the
    interval after it, so the last rest sample's zero rate covers the interval before it."""
    assert case.scene['integrator'] == 'exp_map'
    stamps = np.array(sorted(orientation), dtype=np.int64)
    attitudes = np.array([orientation[stamp] for stamp in stamps.tolist()])
    tau = np.maximum(stamps - round(case.stamps[0] * 1e9), 0) * 1e-9
    return np.atleast_1d(quaternion.attitude_error(attitudes, case.attitude(tau)))


@pytest.mark.parametrize('name', [*CASES, 'constant_rate_faults', 'constant_rate_levelled',
                                  'generic_rate_mounted'])
def test_replay_offline_and_live_agree_and_match_the_closed_form(name, ros, tmp_path,
                                                                 request):
    faulty = name.endswith('_faults')
    levelled = name.endswith('_levelled')
    mounted = name.endswith('_mounted')
    case = build_case(name.removesuffix('_faults').removesuffix('_levelled').removesuffix(
        '_mounted'))
    scene_path = write_scene(case, tmp_path)
    bag_path = tmp_path / 'input'
    parameters: dict[str, Any] = {}
    namespace = unique_namespace(request)
    if faulty:
        write_faulty_bag(case, bag_path)
    elif mounted:  # the mount from the bag's /tf_static offline, from /tf_static live
        tf_static, mount = write_mounted_bag(case, bag_path, f'{namespace[1:]}_imu')
    elif levelled:  # levelled from gravity first: the accelerometer path, node and replay
        yaw = write_levelled_bag(case, bag_path)
        parameters = {'align_seconds': ALIGN_SECONDS, 'initial_yaw': yaw}
    else:
        write_case_bag(case, bag_path)
    offline_path = tmp_path / 'offline'
    options = [f'--{key.replace("_", "-")}={value!r}' for key, value in parameters.items()]
    assert replay_main([str(bag_path), '-o', str(offline_path), '--scene', str(scene_path),
                        '--publish-rate', str(PUBLISH_RATE), '--no-progress', *options]) == 0
    offline = offline_outputs(offline_path)
    # Energy and momentum only where a body is simulated.
    assert bool(offline['energy']) == bool(offline['angular_momentum']) == (
        case.rate_source == 'dynamics')

    run = LiveRun(ros, namespace, case, scene_path, parameters)
    if mounted:
        run.harness.node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS).publish(
            tf_static)
        gate = run.node.built.mount_gate
        assert run.harness.spin_until(lambda: gate.transforms.count == 2, 10.0)
    play(run, bag_path)
    run.wait_for_outputs({name: len(offline[name]) for name in run.received})
    live = run.outputs()

    differences = compare(offline, live)
    worst = max(differences.values())
    assert worst <= AGREEMENT, differences
    for outputs in (offline, live):
        errors = (levelled_closed_form_errors if levelled else closed_form_errors)(
            case, outputs['orientation'])
        # The case's bound: the integrator's error at this step (see bag_fixtures).
        assert np.max(errors) <= case.tolerance, (case.tolerance_reason, np.max(errors))
    if mounted:  # imu/data: the sensor frame's orientation, body ⊗ mount
        for stamp, body in offline['orientation'].items():
            sensor = quaternion.multiply(body, mount)
            assert quaternion.attitude_error(offline['imu/data'][stamp][:4], sensor) < 1e-12
    if levelled:
        alignment = run.node.built.session.alignment
        assert alignment.at_rest and alignment.gyro_bias == (0.0, 0.0, 0.0)
        stamps = sorted(offline['orientation'])
        # Nothing before the rest window was averaged; every moving sample published.
        assert stamps[0] > round(case.stamps[0] * 1e9) - round(1e9 / GYRO_RATE) * (
            REST_SAMPLES - round(ALIGN_SECONDS * GYRO_RATE))
        assert set(round(stamp * 1e9) for stamp in case.stamps.tolist()) <= set(stamps)
        return
    assert len(offline['orientation']) == (
        case.stamps.size - len(FAULTS) * faulty if case.rate_source == 'gyro'
        else _tick_count(case.stamps))
    if faulty:  # rejected alike: 3 malformed, 1 out of range
        rejected = run.node.built.session.rejection_counts()
        assert (rejected['malformed'], rejected['out_of_range']) == (3, 1)
        assert run.node.built.session.malformed_by_topic == {'imu': 3}
    print(f'{name}: offline vs live max difference {worst:.3g} over {differences}; '
          f'closed-form error {np.max(closed_form_errors(case, offline["orientation"])):.3g} '
          f'rad (bound {case.tolerance:.3g})')


def _tick_count(stamps: np.ndarray) -> int:
    """Ticks at the multiples of the period within the stamps' span."""
    period = timer_period_ns(PUBLISH_RATE)
    first = round(stamps[0] * 1e9)
    last = round(stamps[-1] * 1e9)
    return last // period - max(math.ceil(first / period), 1) + 1
