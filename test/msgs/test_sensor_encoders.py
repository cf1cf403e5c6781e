"""The encoders of the simulated sensors' messages and of their mounts against rclpy's
serialiser: rclpy reads our bytes back as the message built from the same numbers, the lengths
are rclpy's, and rosbags' serialiser of rclpy's bytes gives ours byte for byte (rclpy leaves
its padding bytes uninitialised; ours are zero, as rosbags writes them)."""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import Imu, MagneticField
from tf2_msgs.msg import TFMessage

from rigid_body_attitude import bag
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs import MAGNETIC_FIELD, POSE_WITH_COVARIANCE_STAMPED, TF_MESSAGE
from rigid_body_attitude.msgs.cdr import encode_pose_with_covariance_stamped
from rigid_body_attitude.msgs.sensor_encoders import (
    attitude_with_covariance_encoder, encode_tf_message, magnetic_field_encoder,
    simulated_imu_encoder)
from rigid_body_attitude.msgs.types import IMU

FRAME_IDS = ['', 'a', 'imu_lin', 'base_link', 'abcdefghijkl', 'ünïcode']
SEC, NANOSEC = 1_700_000_123, 456_789_012
ATTITUDE = (0.5, -0.5, 0.5, 0.5)  # (w, x, y, z)


def header(message, frame_id):
    message.header.stamp.sec, message.header.stamp.nanosec = SEC, NANOSEC
    message.header.frame_id = frame_id
    return message


def same_as_rclpy(encoded: bytes, message, msgtype: str) -> None:
    """rclpy reads ``encoded`` as ``message``; rosbags writes rclpy's bytes as ``encoded``."""
    assert deserialize_message(encoded, type(message)) == message
    reference = serialize_message(message)
    assert len(encoded) == len(reference)
    typestore = bag.typestore()
    zero_padded = typestore.serialize_cdr(typestore.deserialize_cdr(reference, msgtype), msgtype)
    assert encoded == bytes(zero_padded)


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_magnetic_field_encoder_gives_rclpys_message(frame_id):
    covariance = (4e-14, 1e-15, 0.0, 1e-15, 4e-14, 0.0, 0.0, 0.0, 9e-14)
    field = (2.1e-5, -3.4e-6, -4.3e-5)
    message = header(MagneticField(), frame_id)
    message.magnetic_field.x, message.magnetic_field.y, message.magnetic_field.z = field
    message.magnetic_field_covariance = np.array(covariance)
    encoded = magnetic_field_encoder(frame_id, covariance)(SEC, NANOSEC, field)
    same_as_rclpy(encoded, message, MAGNETIC_FIELD)


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_attitude_with_covariance_encoder_gives_rclpys_message(frame_id):
    block = (1e-9, 2e-10, -3e-10, 2e-10, 4e-9, 5e-10, -3e-10, 5e-10, 2.9e-8)
    message = header(PoseWithCovarianceStamped(), frame_id)
    orientation = message.pose.pose.orientation
    orientation.w, orientation.x, orientation.y, orientation.z = ATTITUDE
    covariance = np.zeros((6, 6))
    covariance[:3, :3] = np.eye(3) * 1e9
    covariance[3:, 3:] = np.reshape(block, (3, 3))
    message.pose.covariance = covariance.reshape(36)
    encoded = attitude_with_covariance_encoder(frame_id, 1e9)(SEC, NANOSEC, ATTITUDE, block)
    same_as_rclpy(encoded, message, POSE_WITH_COVARIANCE_STAMPED)
    assert encoded == encode_pose_with_covariance_stamped(
        SEC * 10**9 + NANOSEC, frame_id, (0.0, 0.0, 0.0), ATTITUDE, covariance.reshape(36))


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_simulated_imu_encoder_gives_rclpys_message(frame_id):
    message = header(Imu(), frame_id)
    message.orientation_covariance = np.array([-1.0] + [0.0] * 8)
    rate, specific_force = (0.1, -0.2, 0.3), (0.4, 9.7, -0.5)
    message.angular_velocity.x, message.angular_velocity.y, message.angular_velocity.z = rate
    acc = message.linear_acceleration
    acc.x, acc.y, acc.z = specific_force
    message.angular_velocity_covariance = np.diag([2e-4] * 3).reshape(9)
    message.linear_acceleration_covariance = np.diag([3e-3] * 3).reshape(9)
    encoded = simulated_imu_encoder(frame_id, 2e-4, 3e-3)(SEC, NANOSEC, rate, specific_force)
    same_as_rclpy(encoded, message, IMU)


def transform(parent, child, rotation):
    stamped = TransformStamped()
    stamped.header.stamp.sec, stamped.header.stamp.nanosec = SEC, NANOSEC
    stamped.header.frame_id, stamped.child_frame_id = parent, child
    r = stamped.transform.rotation
    r.w, r.x, r.y, r.z = rotation
    return stamped


@pytest.mark.parametrize('count', [0, 1, 2, 3])
@pytest.mark.parametrize('body', ['base_link', 'b', 'body12'])
def test_a_tf_message_of_several_mounts_gives_rclpys_message(count, body):
    """Frames of every length modulo 8 one after the other: every transform starts at its own
    alignment."""
    half = math.sqrt(0.5)
    mounts = [('imu_link', (half, 0.0, 0.0, half)), ('magnetometer_lnk', ATTITUDE),
              ('st', (0.0, 1.0, 0.0, 0.0))][:count]
    message = TFMessage(transforms=[transform(body, child, q) for child, q in mounts])
    encoded = encode_tf_message(SEC, NANOSEC, [(body, child, q) for child, q in mounts])
    same_as_rclpy(encoded, message, TF_MESSAGE)


def test_the_encoders_refuse_what_they_cannot_write():
    with pytest.raises(InputError, match='Expected `covariance` to have 9 values, got 3'):
        magnetic_field_encoder('mag', (1.0, 2.0, 3.0))
    with pytest.raises(InputError, match='Expected `sec` in int32'):
        magnetic_field_encoder('mag', (0.0,) * 9)(2**31, 0, (0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='Expected `sec` in int32'):
        attitude_with_covariance_encoder('world', 1e9)(0, 2**32, ATTITUDE, (0.0,) * 9)
    with pytest.raises(InputError, match='Expected `sec` in int32'):
        encode_tf_message(-2**31 - 1, 0, [('a', 'b', ATTITUDE)])
    with pytest.raises(InputError, match='without NUL'):
        encode_tf_message(0, 0, [('a', 'b\x00', ATTITUDE)])
