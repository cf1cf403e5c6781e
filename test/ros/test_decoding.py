"""The node's decoders hand the session the values as sent, or refuse the bytes."""

import pytest
from geometry_msgs.msg import PoseStamped, Vector3Stamped, WrenchStamped
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Imu

from rigid_body_attitude.session.decoding import decoder, MALFORMED


def stamped(message, sec, nanosec, frame_id='imu_link'):
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    message.header.frame_id = frame_id
    return message


@pytest.mark.parametrize('nanosec', [0, 999_999_999, 1_000_000_000, 2**32 - 1])
def test_stamps_are_passed_on_unnormalised(nanosec):
    """A nanosec of 1e9 or more is the session's to refuse (invalid_stamp), not to fold."""
    imu = stamped(Imu(), 1_700_000_000, nanosec)
    imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z = 1.0, 2.0, 3.0
    data = serialize_message(imu)
    sec, got, frame_id, rate, accel = decoder('imu')(data)
    assert (sec, got, frame_id, tuple(rate)) == (1_700_000_000, nanosec, 'imu_link',
                                                 (1.0, 2.0, 3.0))
    assert tuple(accel) == (0.0, 0.0, 0.0)  # zeros: the session takes them for none


def test_every_topic_decodes_its_type():
    wrench = stamped(WrenchStamped(), 5, 6, 'base_link')
    wrench.wrench.force.x, wrench.wrench.torque.z = 7.0, 8.0
    assert decoder('torque')(serialize_message(wrench))[:3] == (5, 6, 'base_link')
    assert tuple(decoder('torque')(serialize_message(wrench))[3]) == (7.0, 0.0, 0.0)
    assert tuple(decoder('torque')(serialize_message(wrench))[4]) == (0.0, 0.0, 8.0)
    pose = stamped(PoseStamped(), 1, 2, 'world')
    pose.pose.orientation.w, pose.pose.position.y = 1.0, 3.0
    _, _, frame_id, attitude, position = decoder('set_pose')(serialize_message(pose))
    assert (frame_id, tuple(attitude), tuple(position)) == ('world', (1.0, 0, 0, 0), (0, 3.0, 0))
    rate = stamped(Vector3Stamped(), 1, 2)
    rate.vector.z = 4.0
    for topic in ('angular_velocity', 'rotor_torque'):
        assert tuple(decoder(topic)(serialize_message(rate))[3]) == (0.0, 0.0, 4.0)


@pytest.mark.parametrize('topic, message', [
    ('imu', Imu()), ('angular_velocity', Vector3Stamped()), ('torque', WrenchStamped()),
    ('rotor_torque', Vector3Stamped()), ('set_pose', PoseStamped())])
def test_every_truncation_is_refused(topic, message):
    data = serialize_message(message)
    for length in range(len(data)):
        with pytest.raises(MALFORMED):
            decoder(topic)(data[:length])
