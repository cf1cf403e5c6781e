"""``imu/data`` under a mount (REP-145): the session tells its sink the mount, and the shared
encoder writes the sensor frame's orientation ``q_world_body ⊗ q_body_sensor`` into the input
Imu, its frame, rates, accelerations and orientation covariance untouched."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from conftest import BASE_NS, MS
from rigid_body_attitude.bag import deserialize
from rigid_body_attitude.msgs import IMU, encode_imu, imu_with_orientation
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.core.attitude.quaternion import from_rpy


def rpy(*angles):
    """``from_rpy`` of roll, pitch, yaw as a (w, x, y, z) tuple."""
    return tuple(from_rpy(angles).tolist())


MOUNT_RPY = (0.4, -0.7, 2.0)
RATE_SENSOR = (0.3, -0.1, 0.8)
ACCEL_SENSOR = (0.2, 9.7, -0.4)


def test_the_session_tells_its_sink_the_mount_given_or_found(open_scene):
    """``mount_rpy``: told at start; ``set_mount`` (the TF mount): told again, the identity
    as ``None`` (nothing composed per sample); no mount: nothing told."""
    session, sink = open_scene('strapdown', mount_rpy=MOUNT_RPY)
    assert len(sink.mounts) == 1  # normalised: equal to the last bit or so
    assert np.max(np.abs(np.subtract(sink.mounts[0], rpy(*MOUNT_RPY)))) < 1e-15
    plain, plain_sink = open_scene('strapdown')
    assert plain_sink.mounts == []
    plain.set_mount((0.0, 2.0, 0.0, 0.0))  # normalised
    plain.set_mount((1.0, 0.0, 0.0, 0.0))
    assert plain_sink.mounts == [(0.0, 1.0, 0.0, 0.0), None]


def test_imu_data_is_the_sensor_frames_orientation_and_the_sensors_rates(open_scene):
    """A mounted Imu in ``imu_link`` through the session; ``imu/data`` as the node and the
    replay write it: frame ``imu_link``, the input's rates and accelerations, orientation
    body ⊗ mount (against scipy's composition), the body's covariance."""
    session, sink = open_scene('strapdown', mount_rpy=MOUNT_RPY, align_seconds=0.0,
                               covariance=True)
    handle = input_handler(session, 'imu')
    for k in range(50):
        handle(encode_imu(BASE_NS + k * MS, 'imu_link', RATE_SENSOR, ACCEL_SENSOR))
    assert len(sink.attitudes) == 50 and session.sample_map.mount == sink.mounts[-1]
    mount = Rotation.from_euler('xyz', MOUNT_RPY)  # tf2's setRPY: Rz(yaw) Ry(pitch) Rx(roll)
    covariance = sink.covariances[-1]
    for (_, _, (w, x, y, z)), imu in zip(sink.attitudes[-5:], sink.imus[-5:]):
        message = deserialize(imu_with_orientation(imu, (w, x, y, z), None, covariance,
                                                   sink.mounts[-1]), IMU)
        expected = (Rotation.from_quat([x, y, z, w]) * mount).as_quat()
        got = message.orientation
        assert abs(np.dot(expected, [got.x, got.y, got.z, got.w])) > 1.0 - 1e-15
        assert message.header.frame_id == 'imu_link'
        assert (message.angular_velocity.x, message.angular_velocity.y,
                message.angular_velocity.z) == RATE_SENSOR
        assert (message.linear_acceleration.x, message.linear_acceleration.y,
                message.linear_acceleration.z) == ACCEL_SENSOR
        # About fixed world axes: the mount turns no world axis, the covariance is the body's.
        assert tuple(message.orientation_covariance) == covariance
    assert any(covariance)  # a covariance that could have been changed


def test_without_a_mount_the_orientation_is_written_as_given():
    data = encode_imu(BASE_NS, 'base_link', RATE_SENSOR, ACCEL_SENSOR)
    attitude = (0.5, 0.5, -0.5, 0.5)
    message = deserialize(imu_with_orientation(data, attitude), IMU)
    got = message.orientation
    assert (got.w, got.x, got.y, got.z) == attitude
