"""TF in and out: ``/tf`` with ``publish_tf``, the sensor's mount from ``/tf_static``.

The encoder is checked byte for byte against rclpy's serialiser of the built ``tf2_msgs``;
the chain composition against products computed here; the node (installed, started as
``ros2 run`` would) against a harness in this process that subscribes to ``/tf`` and
publishes ``/tf_static`` as robot_state_publisher does (transient local).
"""

from __future__ import annotations

import math
import re

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import QuaternionStamped, TransformStamped
import numpy as np
import pytest
from rclpy.qos import qos_profile_sensor_data
from rclpy.serialization import deserialize_message, serialize_message
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu
from tf2_msgs.msg import TFMessage
from ros_helpers import unique_namespace
from test_input_qos import (
    BASE_NS, connect, missing_stamps, PERIOD_NS, receive_all, RECORD_QOS, start_node)
from test_node_subprocess import stop_with_sigint

from rigid_body_attitude import bag
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.msgs.cdr import transform_encoder
from rigid_body_attitude.ros.qos import TF_STATIC_QOS
from rigid_body_attitude.session.mount import StaticTransforms


def _axis(angle: float, axis: int) -> tuple[float, float, float, float]:
    q = [math.cos(angle / 2), 0.0, 0.0, 0.0]
    q[1 + axis] = math.sin(angle / 2)
    return q[0], q[1], q[2], q[3]


def _xyzw(q) -> tuple[float, float, float, float]:
    return q[1], q[2], q[3], q[0]


@pytest.mark.parametrize('parent, child', [
    ('world', 'base_link'), ('w', 'b'), ('odom', 'imu'), ('map', 'a_much_longer_frame_name'),
    ('abc', 'abcd'), ('', 'x')])
def test_the_transform_encoder_gives_the_bytes_of_rosbags_and_rclpy_reads_them(parent, child):
    """One TransformStamped in a TFMessage, for frame names of every padding: rosbags'
    serialiser gives the same bytes (zero padding; rclpy's leaves its padding bytes
    uninitialised) and rclpy deserialises them to the message."""
    q = (0.5, 0.5, -0.5, 0.5)
    message = TFMessage()
    transform = TransformStamped()
    transform.header.frame_id, transform.child_frame_id = parent, child
    transform.header.stamp.sec, transform.header.stamp.nanosec = 1_700_000_000, 123_456_789
    rotation = transform.transform.rotation
    rotation.x, rotation.y, rotation.z, rotation.w = _xyzw(q)
    message.transforms = [transform]
    encoded = transform_encoder(parent, child)(1_700_000_000, 123_456_789, q)
    assert deserialize_message(encoded, TFMessage) == message
    assert len(encoded) == len(serialize_message(message))
    typestore = bag.typestore()
    expected = typestore.deserialize_cdr(serialize_message(message), 'tf2_msgs/msg/TFMessage')
    assert encoded == bytes(typestore.serialize_cdr(expected, 'tf2_msgs/msg/TFMessage'))


def test_a_chain_of_static_transforms_is_composed_up_and_down_the_tree():
    """base_footprint -> base_link (yaw 90 deg), base_footprint -> torso (pitch 30 deg),
    torso -> imu_link (roll 180 deg): base_link -> imu_link goes up to base_footprint and
    down to imu_link."""
    yaw, pitch, roll = _axis(math.pi / 2, 2), _axis(math.pi / 6, 1), _axis(math.pi, 0)
    transforms = StaticTransforms()
    assert transforms.add('base_footprint', 'base_link', yaw) == ''
    assert transforms.add('base_footprint', 'torso', pitch) == ''
    assert transforms.add('torso', 'imu_link', roll) == ''
    expected = quaternion.multiply(quaternion.conjugate(yaw), quaternion.multiply(pitch, roll))
    found = transforms.rotation('base_link', 'imu_link')
    assert found is not None
    assert quaternion.attitude_error(found, expected) < 1e-12
    assert transforms.rotation('base_link', 'camera_link') is None


def test_hostile_static_transforms_are_refused():
    """Non-finite or zero rotations and self-loops are refused, never stored."""
    transforms = StaticTransforms()
    assert transforms.add('a', 'b', (1.0, math.nan, 0.0, 0.0))
    assert transforms.add('a', 'b', (0.0, 0.0, 0.0, 0.0))
    assert transforms.add('a', 'a', (1.0, 0.0, 0.0, 0.0))
    assert transforms.rotation('a', 'b') is None


def static_transforms(*chain: tuple[str, str, tuple[float, float, float, float]]) -> TFMessage:
    """A TFMessage of (parent, child, rotation (w, x, y, z))."""
    message = TFMessage()
    for parent, child, q in chain:
        transform = TransformStamped()
        transform.header.frame_id, transform.child_frame_id = parent, child
        rotation = transform.transform.rotation
        rotation.x, rotation.y, rotation.z, rotation.w = _xyzw(q)
        message.transforms.append(transform)
    return message


def logged_mount(stderr: str) -> np.ndarray:
    """The mount quaternion of the node's log line."""
    found = re.search(r'from /tf_static: \(w, x, y, z\) \(([^)]*)\)', stderr)
    assert found, stderr
    return np.array([float(value) for value in found.group(1).split(',')])


@pytest.mark.parametrize('transforms_first', [True, False])
def test_the_mount_is_read_from_a_chain_on_tf_static(ros, request, processes, transforms_first):
    """Frames ``base_link`` -> ``<ns>_torso`` -> ``<ns>_imu`` on /tf_static (transient local,
    as robot_state_publisher): the node composes the chain, logs the mount, and integrates
    every sample, also those that arrived before the transform (held, then integrated)."""
    namespace = unique_namespace(request)
    sensor, torso = f'{namespace[1:]}_imu', f'{namespace[1:]}_torso'
    yaw, roll = _axis(math.pi / 2, 2), _axis(math.pi / 3, 0)
    node = start_node(processes, namespace)
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data, sensor)
    tf_static = harness.node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
    message = static_transforms(('base_link', torso, yaw), (torso, sensor, roll))
    count = 400
    if transforms_first:
        tf_static.publish(message)
        harness.spin_for(0.5)
        sender.paced(500.0, count)
    else:
        sender.paced(500.0, count // 2)
        harness.spin_for(0.5)
        tf_static.publish(message)
        harness.spin_for(0.5)
        sender.paced(500.0, count)
    receive_all(harness, poses, count, 10.0)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert missing_stamps(poses, count) == []
    expected = quaternion.multiply(yaw, roll)
    assert quaternion.attitude_error(logged_mount(stderr), expected) < 1e-5
    assert 'Traceback' not in stderr


def test_a_missing_mount_gives_one_clear_line_and_diagnostics(ros, request, processes):
    """No transform to the sensor frame: after ``tf_timeout`` the samples are dropped and
    counted (``rejected no_mount``, WARN naming ``mount_rpy``), with a throttled error line
    naming both frames and the remedy; never a traceback."""
    namespace = unique_namespace(request)
    sensor = f'{namespace[1:]}_imu'
    node = start_node(processes, namespace, 'tf_timeout:=0.5')
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data, sensor)
    statuses = harness.record(DiagnosticArray, '/diagnostics', RECORD_QOS)
    harness.wait_for_connections()
    sender.paced(200.0, 800)  # 4 s
    harness.spin_for(1.5)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert poses == []
    lines = [line for line in stderr.splitlines() if 'no static transform' in line]
    assert 1 <= len(lines) <= 2, stderr
    assert f"'base_link' -> '{sensor}'" in lines[0] and 'mount_rpy' in lines[0]
    assert 'static_transform_publisher' in lines[0]
    values = {v.key: v.value for v in statuses[-1].status[0].values}
    assert int(values['rejected no_mount']) == 800
    warned = [s.status[0] for s in statuses if 'no_mount' in s.status[0].message]
    assert warned and all(status.level == DiagnosticStatus.WARN for status in warned)
    assert all('mount_rpy' in status.message for status in warned)
    assert 'Traceback' not in stderr


@pytest.mark.parametrize('tf_rate, spacing_ns', [(0.0, PERIOD_NS), (100.0, 10 * PERIOD_NS)])
def test_publish_tf_sends_world_to_body_at_the_output_stamps(
        ros, request, processes, tf_rate, spacing_ns):
    """``publish_tf:=true``: a subscriber of ``/tf`` receives ``world`` -> ``body_frame`` with
    the rotation and stamp of ``pose``; every output with ``tf_rate:=0``, one per 10 ms of
    stamps with 100 Hz."""
    namespace = unique_namespace(request)
    body = f'{namespace[1:]}_body'
    node = start_node(processes, namespace, 'publish_tf:=true', f'tf_rate:={tf_rate}',
                      f'body_frame:={body}')
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data)
    transforms: list = []
    harness.subscriptions['/tf'] = harness.node.create_subscription(
        TFMessage, '/tf', transforms.append, RECORD_QOS)
    harness.wait_for_connections()
    count = 500
    sender.paced(500.0, count)
    receive_all(harness, poses, count, 10.0)
    harness.spin_for(0.5)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    ours = [t for message in transforms for t in message.transforms if t.child_frame_id == body]
    assert ours and all(t.header.frame_id == 'world' for t in ours)
    by_stamp = {(p.header.stamp.sec, p.header.stamp.nanosec): p.pose.orientation for p in poses}
    stamps = [t.header.stamp.sec * 10**9 + t.header.stamp.nanosec for t in ours]
    assert stamps == sorted(stamps)
    assert set(np.diff(stamps)) == {spacing_ns}
    expected = (count - 1) * PERIOD_NS // spacing_ns + 1  # from the first sample's output
    assert len(ours) == expected
    for t in ours:
        pose = by_stamp[(t.header.stamp.sec, t.header.stamp.nanosec)]
        r = t.transform.rotation
        assert (r.x, r.y, r.z, r.w) == (pose.x, pose.y, pose.z, pose.w)
        assert (t.transform.translation.x, t.transform.translation.y,
                t.transform.translation.z) == (0.0, 0.0, 0.0)
    assert stamps[0] == BASE_NS


def _wxyz(q) -> np.ndarray:
    return np.array([q.w, q.x, q.y, q.z])


@pytest.mark.parametrize('source', ['mount_rpy', 'tf_static'])
def test_imu_data_carries_the_sensor_frames_orientation_under_a_mount(
        ros, request, processes, source):
    """REP-145: with the mount from ``mount_rpy`` or from a chain on /tf_static, a subscriber
    in this process receives ``imu/data`` in the sensor frame with the input's rates and the
    orientation ``orientation ⊗ mount`` (scipy's composition), while ``orientation`` keeps the
    body's attitude in ``world``."""
    namespace = unique_namespace(request)
    if source == 'mount_rpy':
        sensor, mount = 'imu_link', Rotation.from_euler('xyz', [0.4, -0.7, 2.0])
        node = start_node(processes, namespace, 'mount_rpy:=[0.4,-0.7,2.0]')
    else:
        sensor, torso = f'{namespace[1:]}_imu', f'{namespace[1:]}_torso'
        yaw, roll = _axis(math.pi / 2, 2), _axis(math.pi / 3, 0)
        mount = Rotation.from_quat(_xyzw(yaw)) * Rotation.from_quat(_xyzw(roll))
        node = start_node(processes, namespace)
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data, sensor)
    imu_data = harness.record(Imu, 'imu/data', RECORD_QOS)
    orientations = harness.record(QuaternionStamped, 'orientation', RECORD_QOS)
    harness.wait_for_connections()
    if source == 'tf_static':
        tf_static = harness.node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        tf_static.publish(static_transforms(('base_link', torso, yaw), (torso, sensor, roll)))
        harness.spin_for(0.5)
    count = 200
    sender.paced(500.0, count)
    harness.spin_until(lambda: len(imu_data) >= count and len(orientations) >= count, 10.0)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    body = {(m.header.stamp.sec, m.header.stamp.nanosec): m for m in orientations}
    assert len(imu_data) == count and set(body) == {
        (m.header.stamp.sec, m.header.stamp.nanosec) for m in imu_data}
    for message in imu_data:
        q = _wxyz(body[(message.header.stamp.sec, message.header.stamp.nanosec)].quaternion)
        assert body[(message.header.stamp.sec, message.header.stamp.nanosec)
                    ].header.frame_id == 'world'
        expected = (Rotation.from_quat(_xyzw(q)) * mount).as_quat()
        got = message.orientation
        assert abs(np.dot(expected, [got.x, got.y, got.z, got.w])) > 1.0 - 1e-14
        assert message.header.frame_id == sensor
        assert (message.angular_velocity.x, message.angular_velocity.y,
                message.angular_velocity.z) == (0.3, 0.0, -0.2)
    turned = [quaternion.attitude_error(_wxyz(m.orientation), _wxyz(body[
        (m.header.stamp.sec, m.header.stamp.nanosec)].quaternion)) for m in imu_data]
    assert min(turned) > 0.1  # imu/data is not the body's attitude
