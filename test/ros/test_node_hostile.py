"""Malformed bytes on every input topic of the running node, through real rclpy publishers.

Each malformed payload is published raw (serialized bytes) between good messages. The node must
count it per topic (``rejected malformed``, ``malformed <topic>`` in /diagnostics), keep going,
and end with exactly the attitude the good messages alone give: the malformed ones changed
nothing.
"""

from __future__ import annotations

import struct
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import (
    PoseStamped, PoseWithCovarianceStamped, QuaternionStamped, Vector3Stamped, WrenchStamped)
import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from ros_helpers import Harness, stamp, unique_namespace
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from rigid_body_attitude.ros.node import AttitudePropagatorNode

BASE_NS = 1_700_000_000 * 10**9 + 123_456_789
MS = 1_000_000
OMEGA = (0.3, -0.2, 1.1)


def malformed_variants(good: bytes) -> list[bytes]:
    """Bytes no decoder may accept: truncations, bad encapsulation, absurd string lengths,
    garbage, nothing."""
    frame_length_at = 12  # after the encapsulation header (4) and the stamp (8)
    absurd_length = bytearray(good)
    struct.pack_into('<I', absurd_length, frame_length_at, 0xFFFFFFFF)
    unterminated = bytearray(good)
    unterminated[16 + struct.unpack_from('<I', good, frame_length_at)[0] - 1] = ord('x')
    return [
        good[:20], good[:len(good) // 2], good[:-1], good[:3], b'',
        b'\x01\x05' + good[2:],                      # encapsulation 0x0105
        b'\x00\x0a' + good[2:],                      # encapsulation 0x000a
        bytes(absurd_length), bytes(unterminated),
        bytes(range(256)) * 2,
    ]


def start_node(harness: Harness, **parameters: Any) -> AttitudePropagatorNode:
    node = AttitudePropagatorNode(
        context=harness.ros.context, namespace=harness.node.get_namespace(),
        parameter_overrides=[Parameter(name, value=value) for name, value in parameters.items()])
    return harness.add_node(node)


def send(harness: Harness, node: AttitudePropagatorNode, topic: str, payload: Any) -> None:
    """Publish one message (a message or raw bytes); spin until the node has taken it."""
    expected = node.session.received_count() + 1
    harness.publishers[topic].publish(payload)
    assert harness.spin_until(lambda: node.session.received_count() >= expected, 5.0), topic


def gyro_message(topic: str, at_ns: int) -> Any:
    if topic == 'imu':
        message = Imu()
        message.angular_velocity.x, message.angular_velocity.y, message.angular_velocity.z = OMEGA
    else:
        message = Vector3Stamped()
        message.vector.x, message.vector.y, message.vector.z = OMEGA
    message.header.stamp = stamp(at_ns)
    message.header.frame_id = 'base_link'  # mounted in the body frame: no mount to look up
    return message


def own_values(diagnostics: list[DiagnosticArray], node: AttitudePropagatorNode
               ) -> dict[str, str]:
    name = node.get_fully_qualified_name()
    mine = [m for m in diagnostics if m.status and m.status[0].name == name]
    return {pair.key: pair.value for pair in mine[-1].status[0].values} if mine else {}


@pytest.mark.parametrize('topic, message_type', [('imu', Imu),
                                                 ('angular_velocity', Vector3Stamped)])
def test_malformed_gyro_bytes_change_nothing(ros, request, topic, message_type):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(message_type, topic)
    harness.publisher(PoseStamped, 'set_pose')
    orientations = harness.record(QuaternionStamped, 'orientation')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    bad = malformed_variants(serialize_message(gyro_message(topic, BASE_NS)))
    good_count = 2 * len(bad) + 1
    for k in range(good_count):
        send(harness, node, topic, gyro_message(topic, BASE_NS + k * MS))
        if k < len(bad):
            send(harness, node, topic, bad[k])
            pose = malformed_variants(serialize_message(PoseStamped()))[k]
            send(harness, node, 'set_pose', pose)
    assert harness.spin_until(lambda: len(orientations) == good_count, 5.0)
    # The good stream alone: a constant rate, so exp((n − 1) h ω) to round-off (20 steps).
    expected = _exp((good_count - 1) * 1e-3 * np.array(OMEGA))
    last = orientations[-1].quaternion
    assert np.max(np.abs(np.array([last.w, last.x, last.y, last.z]) - expected)) <= 1e-14
    session = node.session
    assert session.malformed_by_topic == {topic: len(bad), 'set_pose': len(bad)}
    assert session.accepted_count() == good_count
    assert harness.spin_until(
        lambda: own_values(diagnostics, node).get('rejected malformed') == str(2 * len(bad)),
        3.0)
    values = own_values(diagnostics, node)
    assert values[f'malformed {topic}'] == str(len(bad))
    assert values['malformed set_pose'] == str(len(bad))


def _exp(rotation_vector: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotation_vector))
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * rotation_vector / angle])


@pytest.mark.parametrize('scene, topic, message_type', [
    ('commanded_torque', 'torque', WrenchStamped),
    ('gyrostat', 'rotor_torque', Vector3Stamped),
])
def test_malformed_command_bytes_change_nothing(ros, request, scene, topic, message_type):
    """On sim time: a node fed only malformed commands ticks exactly like one fed nothing."""
    outputs = {}
    for role in ('hostile', 'quiet'):
        harness = Harness(ros, unique_namespace(request) + '_' + role)
        node = start_node(harness, scene=scene, use_sim_time=True)
        harness.publisher(Clock, '/clock')
        harness.publisher(message_type, topic)
        poses = harness.record(QuaternionStamped, 'orientation')
        harness.wait_for_connections()
        if role == 'hostile':
            good = message_type()
            good.header.stamp = stamp(BASE_NS)
            for payload in malformed_variants(serialize_message(good)):
                send(harness, node, topic, payload)
            assert node.session.malformed_by_topic == {topic: 10}
        for k in range(1, 6):
            clock = Clock()
            clock.clock = stamp(1000 * 10**9 + k * 20 * MS)
            harness.publishers['/clock'].publish(clock)
            assert harness.spin_until(lambda: len(poses) >= k, 5.0)
        outputs[role] = [(m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z)
                         for m in poses[:5]]
        ros.executor.remove_node(node)
        node.destroy_node()
    assert outputs['hostile'] == outputs['quiet']


def test_huge_covariances_on_set_pose_with_covariance_change_nothing(ros, request):
    """Finite but huge, or unphysical, orientation blocks on ``set_pose_with_covariance``
    between good gyro samples: each refused and counted as ``invalid_covariance`` in
    /diagnostics, the attitude the good stream alone gives, every ``imu/data`` and
    ``pose_with_covariance`` covariance finite, no internal error."""
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(Imu, 'imu')
    harness.publisher(PoseWithCovarianceStamped, 'set_pose_with_covariance')
    orientations = harness.record(QuaternionStamped, 'orientation')
    imu_outputs = harness.record(Imu, 'imu/data')
    poses = harness.record(PoseWithCovarianceStamped, 'pose_with_covariance')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    blocks = [np.diag([1e308] * 3), np.full((3, 3), 1e308), np.diag([1e-4, 1e-4, 1e300]),
              np.diag([1e-4, 1e-4, 10.0])]
    good_count = 2 * len(blocks) + 1
    for k in range(good_count):
        send(harness, node, 'imu', gyro_message('imu', BASE_NS + k * MS))
        if k < len(blocks):
            pose = PoseWithCovarianceStamped()
            pose.header.frame_id = 'world'
            pose.pose.pose.orientation.x = 1.0
            covariance = np.eye(6)
            covariance[3:, 3:] = blocks[k]
            pose.pose.covariance = covariance.reshape(36).tolist()
            send(harness, node, 'set_pose_with_covariance', pose)
    assert harness.spin_until(lambda: min(len(orientations), len(imu_outputs), len(poses))
                              == good_count, 5.0)
    expected = _exp((good_count - 1) * 1e-3 * np.array(OMEGA))
    last = orientations[-1].quaternion
    assert np.max(np.abs(np.array([last.w, last.x, last.y, last.z]) - expected)) <= 1e-14
    assert all(np.all(np.isfinite(m.orientation_covariance)) for m in imu_outputs)
    assert all(np.all(np.isfinite(m.pose.covariance)) and max(m.pose.covariance[21::7]) < 10.0
               for m in poses)
    assert harness.spin_until(
        lambda: own_values(diagnostics, node).get('rejected invalid_covariance')
        == str(len(blocks)), 3.0)
    assert own_values(diagnostics, node)['rejected internal_error'] == '0'
