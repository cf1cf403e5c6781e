"""Live = replay for the attitude filter: a BROAD excerpt over ROS and through ``replay``.

Twelve seconds of BROAD trial 28 (``data/broad_mag``: rest, then rotations and translations
past a magnet), its IMU frame ``imu_link`` mounted in ``base_link`` by a transform on
``/tf_static``, as a bag of ``sensor_msgs/Imu`` and ``sensor_msgs/MagneticField`` records
(each field before the Imu of its sample):

(a) ``replay`` (its ``main``) with the ``imu_filter`` scene writes the node's outputs;
(b) a player publishes the same bytes with the sensor-data QoS a driver uses (best effort)
    into the running node (in process), ``/tf_static`` first (transient local, as tf2_ros's
    static broadcaster), each message taken by the node before the next, while a recorder
    collects ``orientation``, ``imu/data``, ``pose_with_covariance`` and ``accel/filtered``.

The two must agree output by output (matched by stamp) to 1e-12, the covariances bit for bit;
the filter ran (levelled, turned to magnetic north, updates counted) in both.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from geometry_msgs.msg import (
    AccelWithCovarianceStamped, PoseWithCovarianceStamped, QuaternionStamped)
import numpy as np
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import Imu, MagneticField
from tf2_msgs.msg import TFMessage

from bag_fixtures import write_records
from rigid_body_attitude.bag import BagReader, typestore
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.msgs import TF_MESSAGE, decode_pose_with_covariance_stamped, IMU
from rigid_body_attitude.msgs.cdr import encode_imu, encode_magnetic_field, header_stamp_ns
from rigid_body_attitude.msgs.decoders import decode_imu, decode_quaternion_stamped
from rigid_body_attitude.msgs.types import MAGNETIC_FIELD
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.qos import TF_STATIC_QOS
from rigid_body_attitude.tools.broad import load_trial
from rigid_body_attitude.tools.replay import main as replay_main

REPO_ROOT = Path(__file__).resolve().parents[2]
TRIAL = REPO_ROOT / 'data' / 'broad_mag' / '28_disturbed_stationary_magnet_A_excerpt.npz'
START_NS = 1_700_000_000 * 10**9
AGREEMENT = 1e-12
RETRY_AFTER, ATTEMPTS = 1.0, 5
#: The IMU's mount: imu_link in base_link (yaw 90°, then roll 180°).
MOUNT = quaternion.multiply(quaternion.exp([0.0, 0.0, math.pi / 2]),
                            quaternion.exp([math.pi, 0.0, 0.0]))


def tf_static_bytes() -> bytes:
    """``base_link -> imu_link`` as a TFMessage (CDR), as robot_state_publisher sends it."""
    store = typestore()
    types = store.types
    stamped = types['geometry_msgs/msg/TransformStamped'](
        header=types['std_msgs/msg/Header'](stamp=types['builtin_interfaces/msg/Time'](
            sec=0, nanosec=0), frame_id='base_link'), child_frame_id='imu_link',
        transform=types['geometry_msgs/msg/Transform'](
            translation=types['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0),
            rotation=types['geometry_msgs/msg/Quaternion'](
                x=float(MOUNT[1]), y=float(MOUNT[2]), z=float(MOUNT[3]), w=float(MOUNT[0]))))
    return bytes(store.serialize_cdr(types[TF_MESSAGE](transforms=[stamped]), TF_MESSAGE))


def write_trial_bag(path: Path) -> list[tuple[str, int, bytes]]:
    """The excerpt as records (``/tf_static``, then per sample ``imu/mag`` and ``imu``)."""
    trial = load_trial(TRIAL)
    period = 1e9 / trial.sampling_rate
    records = [('/tf_static', START_NS - 1000, tf_static_bytes())]
    for k, (gyro, acc, field) in enumerate(zip(trial.gyro.tolist(), trial.acc.tolist(),
                                               trial.field.tolist())):
        stamp_ns = START_NS + round(k * period)
        records.append(('imu/mag', stamp_ns, encode_magnetic_field(stamp_ns, 'imu_link', field)))
        records.append(('imu', stamp_ns, encode_imu(stamp_ns, 'imu_link', gyro, acc)))
    write_records(path, {'imu': IMU, 'imu/mag': MAGNETIC_FIELD, '/tf_static': TF_MESSAGE},
                  records)
    return records


def offline_outputs(path: Path) -> dict[str, dict[int, tuple[float, ...]]]:
    """The replay's outputs by topic and stamp."""
    outputs: dict[str, dict[int, tuple[float, ...]]] = {
        'orientation': {}, 'imu/data': {}, 'pose_with_covariance': {}, 'accel/filtered': {}}
    with BagReader(path) as reader:
        topics = [name for name in reader.topics if name.lstrip('/') in outputs]
        for topic, _, _, data in reader.messages(topics):
            name = topic.lstrip('/')
            stamp = header_stamp_ns(data)
            if name == 'orientation':
                outputs[name][stamp] = tuple(decode_quaternion_stamped(data)[3])
            elif name == 'imu/data':
                outputs[name][stamp] = tuple(decode_imu(data)[3]) + _imu_covariance(data)
            elif name == 'pose_with_covariance':
                _, _, _, _, q, covariance = decode_pose_with_covariance_stamped(data)
                outputs[name][stamp] = tuple(q) + tuple(covariance)
            else:
                outputs[name][stamp] = _accel(typestore().deserialize_cdr(
                    data, 'geometry_msgs/msg/AccelWithCovarianceStamped'))
    return outputs


def _imu_covariance(data: bytes) -> tuple[float, ...]:
    message = typestore().deserialize_cdr(data, IMU)
    return tuple(message.orientation_covariance.tolist())


def _accel(message: Any) -> tuple[float, ...]:
    linear = message.accel.accel.linear
    return (linear.x, linear.y, linear.z, *np.asarray(message.accel.covariance).tolist())


def _ns(stamp: Any) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _wxyz(q: Any) -> tuple[float, ...]:
    return (q.w, q.x, q.y, q.z)


class Player:
    """Publishes records into the node in process, each taken before the next."""

    def __init__(self, ros: Any, namespace: str) -> None:
        self.harness = Harness(ros, namespace)
        self.node = self.harness.add_node(AttitudePropagatorNode(
            context=ros.context, namespace=namespace,
            parameter_overrides=[Parameter('scene', value='imu_filter')]))
        harness = self.harness
        self.inputs = {'imu': harness.publisher(Imu, 'imu', qos_profile_sensor_data),
                       'imu/mag': harness.publisher(MagneticField, 'imu/mag',
                                                    qos_profile_sensor_data)}
        self.received = {
            'orientation': harness.record(QuaternionStamped, 'orientation'),
            'imu/data': harness.record(Imu, 'imu/data'),
            'pose_with_covariance': harness.record(PoseWithCovarianceStamped,
                                                   'pose_with_covariance'),
            'accel/filtered': harness.record(AccelWithCovarianceStamped, 'accel/filtered')}
        harness.wait_for_connections()
        self.sent = 0

    def send(self, topic: str, data: bytes) -> None:
        self.sent += 1
        expected = self.sent
        session = self.node.built.session
        for _ in range(ATTEMPTS):
            self.inputs[topic].publish(data)
            if self.harness.spin_until(lambda: session.received_count() >= expected,
                                       RETRY_AFTER):
                return
        raise AssertionError(f'the node did not take input {expected} ({topic})')

    def outputs(self) -> dict[str, dict[int, tuple[float, ...]]]:
        received = self.received
        return {
            'orientation': {_ns(m.header.stamp): _wxyz(m.quaternion)
                            for m in received['orientation']},
            'imu/data': {_ns(m.header.stamp): _wxyz(m.orientation)
                         + tuple(m.orientation_covariance) for m in received['imu/data']},
            'pose_with_covariance': {
                _ns(m.header.stamp): _wxyz(m.pose.pose.orientation) + tuple(m.pose.covariance)
                for m in received['pose_with_covariance']},
            'accel/filtered': {_ns(m.header.stamp): _accel(m)
                               for m in received['accel/filtered']}}


def test_a_broad_trial_live_gives_the_replays_outputs(ros, tmp_path, request):
    bag = tmp_path / 'input'
    records = write_trial_bag(bag)
    assert replay_main([str(bag), '-o', str(tmp_path / 'offline'), '--scene', 'imu_filter',
                        '--no-progress']) == 0
    offline = offline_outputs(tmp_path / 'offline')
    assert len(offline['orientation']) > 0.6 * (len(records) - 1) / 2

    player = Player(ros, unique_namespace(request))
    player.harness.node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS).publish(
        records[0][2])
    gate = player.node.built.mount_gate
    assert player.harness.spin_until(lambda: gate.mount_of('imu_link') is not None, 10.0)
    for topic, _, data in records[1:]:
        player.send(topic, data)
    counts = {name: len(values) for name, values in offline.items()}
    player.harness.spin_until(lambda: all(
        len(player.received[name]) >= count for name, count in counts.items()), 10.0)
    live = player.outputs()

    for name in offline:
        assert sorted(offline[name]) == sorted(live[name]), name
        worst = max(float(np.max(np.abs(np.subtract(offline[name][stamp], live[name][stamp]))))
                    for stamp in offline[name])
        assert worst <= AGREEMENT, (name, worst)
    assert {s: v[4:] for s, v in offline['imu/data'].items()} == {
        s: v[4:] for s, v in live['imu/data'].items()}
    session = player.node.built.session
    counts = session.estimation.estimator.counts
    assert session.estimation.estimator.field is not None
    assert sum(counts.values()) > 200 and sum(
        count for name, count in counts.items() if name.startswith('magnetometer')) > 100
    assert session.rejection_counts()['magnetometer_no_mount'] == 0
