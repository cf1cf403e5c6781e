"""imu/data: the input Imu with the orientation filled in and, when asked, another stamp."""

import pytest
from rosbags.typesys import get_typestore, Stores

from rigid_body_attitude.msgs import decoders
from rigid_body_attitude.msgs.cdr import encode_imu, imu_with_orientation

IMU = 'sensor_msgs/msg/Imu'


@pytest.mark.parametrize('little_endian', [True, False])
def test_orientation_and_stamp_replaced_everything_else_kept(little_endian):
    data = encode_imu(1_700_000_000 * 10**9 + 5, 'imu_link', (0.1, 0.2, 0.3))
    if not little_endian:  # the same message as CDR_BE (rosbags' serialiser)
        typestore = get_typestore(Stores.ROS2_JAZZY)
        data = bytes(typestore.serialize_cdr(typestore.deserialize_cdr(data, IMU), IMU,
                                             little_endian=False))
        assert data[1] == 0  # CDR_BE
    attitude = (0.5, 0.5, 0.5, 0.5)
    same = decoders.decode_imu(imu_with_orientation(data, attitude))
    assert same[:3] == (1_700_000_000, 5, 'imu_link') and same[3] == attitude
    moved = decoders.decode_imu(imu_with_orientation(data, attitude, (42, 7)))
    assert moved[:3] == (42, 7, 'imu_link') and moved[3] == attitude
    assert moved[4:] == same[4:] == ((0.1, 0.2, 0.3), (0.0, 0.0, 0.0))


@pytest.mark.parametrize('little_endian', [True, False])
def test_the_orientation_covariance_goes_in_row_major_and_nothing_else_moves(little_endian):
    data = encode_imu(1_700_000_000 * 10**9 + 5, 'imu_link', (0.1, 0.2, 0.3), (0.0, 0.0, 9.8))
    typestore = get_typestore(Stores.ROS2_JAZZY)
    if not little_endian:
        data = bytes(typestore.serialize_cdr(typestore.deserialize_cdr(data, IMU), IMU,
                                             little_endian=False))
    covariance = (1e-4, 2e-6, 3e-6, 2e-6, 4e-4, 5e-6, 3e-6, 5e-6, 9.8)
    message = typestore.deserialize_cdr(
        imu_with_orientation(data, (0.5, 0.5, 0.5, 0.5), None, covariance), IMU)
    assert tuple(message.orientation_covariance.tolist()) == covariance
    assert (message.orientation.x, message.orientation.w) == (0.5, 0.5)
    assert message.linear_acceleration.z == 9.8
    assert message.angular_velocity_covariance.tolist() == [0.0] * 9
