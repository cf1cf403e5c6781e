"""Tests of rigid_body_attitude.msgs' codecs: against rosbags' serialiser, round trips, errors."""

import numpy as np
import pytest

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.attitude.quaternion import from_ros, normalize, to_ros
from rigid_body_attitude.msgs import cdr

FRAME_IDS = ['', 'a', 'imu_lin', 'base_link', 'abcdefghijkl', 'ünïcode']
STAMP_NS = 1_700_000_123_456_789_012


def _types():
    return bag.typestore().types


def _header(stamp_ns, frame_id):
    types = _types()
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame_id)


def _vector3(values):
    return _types()['geometry_msgs/msg/Vector3'](x=values[0], y=values[1], z=values[2])


def _quaternion_msg(q_wxyz):
    x, y, z, w = to_ros(q_wxyz).tolist()
    return _types()['geometry_msgs/msg/Quaternion'](x=x, y=y, z=z, w=w)


def _reference_messages(frame_id):
    """(msgtype, rosbags message, our encoding) triples built from the same numbers."""
    types = _types()
    rng = np.random.default_rng(len(frame_id))
    rate, acceleration, force, torque, position = rng.normal(size=(5, 3)).tolist()
    attitude = normalize(rng.normal(size=4)).tolist()
    header = _header(STAMP_NS, frame_id)
    provided = np.zeros(9)
    not_provided = np.zeros(9)
    not_provided[0] = -1.0
    imu_full = types[msgs.IMU](
        header=header, orientation=_quaternion_msg(attitude), orientation_covariance=provided,
        angular_velocity=_vector3(rate), angular_velocity_covariance=provided,
        linear_acceleration=_vector3(acceleration), linear_acceleration_covariance=provided)
    imu_rates_only = types[msgs.IMU](
        header=header, orientation=_quaternion_msg([1.0, 0.0, 0.0, 0.0]),
        orientation_covariance=not_provided, angular_velocity=_vector3(rate),
        angular_velocity_covariance=provided, linear_acceleration=_vector3([0.0, 0.0, 0.0]),
        linear_acceleration_covariance=not_provided)
    pose = types['geometry_msgs/msg/Pose'](
        position=types['geometry_msgs/msg/Point'](x=position[0], y=position[1], z=position[2]),
        orientation=_quaternion_msg(attitude))
    return [
        (msgs.IMU, imu_full, cdr.encode_imu(STAMP_NS, frame_id, rate, acceleration, attitude)),
        (msgs.IMU, imu_rates_only, cdr.encode_imu(STAMP_NS, frame_id, rate)),
        (msgs.VECTOR3_STAMPED, types[msgs.VECTOR3_STAMPED](header=header, vector=_vector3(rate)),
         cdr.encode_vector3_stamped(STAMP_NS, frame_id, rate)),
        (msgs.WRENCH_STAMPED, types[msgs.WRENCH_STAMPED](
            header=header, wrench=types['geometry_msgs/msg/Wrench'](
                force=_vector3(force), torque=_vector3(torque))),
         cdr.encode_wrench_stamped(STAMP_NS, frame_id, force, torque)),
        (msgs.TWIST_STAMPED, types[msgs.TWIST_STAMPED](
            header=header, twist=types['geometry_msgs/msg/Twist'](
                linear=_vector3(force), angular=_vector3(rate))),
         cdr.encode_twist_stamped(STAMP_NS, frame_id, force, rate)),
        (msgs.QUATERNION_STAMPED, types[msgs.QUATERNION_STAMPED](
            header=header, quaternion=_quaternion_msg(attitude)),
         cdr.encode_quaternion_stamped(STAMP_NS, frame_id, attitude)),
        (msgs.POSE_STAMPED, types[msgs.POSE_STAMPED](header=header, pose=pose),
         cdr.encode_pose_stamped(STAMP_NS, frame_id, position, attitude)),
    ]


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_encoders_byte_equal_to_rosbags_serializer(frame_id):
    for msgtype, message, encoded in _reference_messages(frame_id):
        expected = bytes(bag.typestore().serialize_cdr(message, msgtype))
        assert encoded == expected, msgtype


def test_encode_float64_byte_equal_to_rosbags_serializer():
    for value in (0.0, -2.5, 1e300, float('inf')):
        message = _types()[msgs.FLOAT64](data=value)
        expected = bytes(bag.typestore().serialize_cdr(message, msgs.FLOAT64))
        assert cdr.encode_float64(value) == expected


def _decoded_fields(msgtype, message):
    """What our decoders must return for a rosbags message (stamps in s, (w, x, y, z))."""
    stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9

    def vec(v):
        return (v.x, v.y, v.z)

    def quat(q):
        return tuple(from_ros([q.x, q.y, q.z, q.w]).tolist())
    fields = {
        msgs.IMU: lambda m: [(cdr.imu_rates, vec(m.angular_velocity)),
                             (cdr.imu_acceleration, vec(m.linear_acceleration))],
        msgs.VECTOR3_STAMPED: lambda m: [(cdr.vector3_stamped, vec(m.vector))],
        msgs.WRENCH_STAMPED: lambda m: [(cdr.wrench_force, vec(m.wrench.force)),
                                        (cdr.wrench_torque, vec(m.wrench.torque))],
        msgs.TWIST_STAMPED: lambda m: [(cdr.twist_linear, vec(m.twist.linear)),
                                       (cdr.twist_angular, vec(m.twist.angular))],
        msgs.QUATERNION_STAMPED: lambda m: [(cdr.quaternion_stamped, quat(m.quaternion))],
        msgs.POSE_STAMPED: lambda m: [(cdr.pose_position, vec(m.pose.position)),
                                      (cdr.pose_orientation, quat(m.pose.orientation))],
    }[msgtype](message)
    return [(decoder, (stamp, value)) for decoder, value in fields]


@pytest.mark.parametrize('little_endian', [True, False])
@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_decoders_read_rosbags_serialized_messages(frame_id, little_endian):
    for msgtype, message, _ in _reference_messages(frame_id):
        data = bytes(bag.typestore().serialize_cdr(message, msgtype, little_endian=little_endian))
        for decoder, expected in _decoded_fields(msgtype, message):
            assert decoder(data) == expected, (msgtype, decoder.__name__)
        assert cdr.header_stamp_ns(data) == STAMP_NS
        assert cdr.header_frame_id(data) == frame_id


@pytest.mark.parametrize('little_endian', [True, False])
@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_rate_decoders_read_the_integer_stamp_and_the_rate(frame_id, little_endian):
    sec, nanosec = divmod(STAMP_NS, 1_000_000_000)
    float_stamped = {msgs.IMU: cdr.imu_rates, msgs.VECTOR3_STAMPED: cdr.vector3_stamped,
                     msgs.TWIST_STAMPED: cdr.twist_angular}
    assert set(msgs.RATE_DECODERS) == set(float_stamped)
    for msgtype, message, _ in _reference_messages(frame_id):
        if msgtype not in msgs.RATE_DECODERS:
            continue
        data = bytes(bag.typestore().serialize_cdr(message, msgtype, little_endian=little_endian))
        _, rate = float_stamped[msgtype](data)
        decoded = msgs.RATE_DECODERS[msgtype](data)
        assert decoded[:4] == (sec, nanosec, frame_id, rate), msgtype
        if msgtype != msgs.IMU:
            assert decoded[4] is None, msgtype  # no specific force


def test_the_imu_rate_decoder_rejects_what_the_float_stamp_decoder_rejects():
    imu = cdr.encode_imu(0, 'base_link', [1.0, 2.0, 3.0])
    decode = msgs.RATE_DECODERS[msgs.IMU]
    for data, message in [(cdr.encode_vector3_stamped(0, 'base_link', [1.0, 2.0, 3.0]),
                           'malformed sensor_msgs/msg/Imu: truncated: 52 of 324 bytes'),
                          (imu[:100], 'truncated: 100 of 324 bytes'),
                          (imu[:2], 'truncated: 2 of at least 316 bytes'),
                          (b'\x00\x05' + imu[2:], 'bad encapsulation 0x0005')]:
        for decoder in (decode, cdr.imu_rates):
            with pytest.raises(msgs.MalformedMessage, match=message):
                decoder(data)


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_frame_encoders_give_the_general_encoders_bytes(frame_id):
    rng = np.random.default_rng(len(frame_id))
    encode_orientation = cdr.quaternion_stamped_encoder(frame_id)
    encode_pose = cdr.pose_stamped_encoder(frame_id)
    encode_vector = cdr.stamped_floats_encoder(frame_id, 3)
    encode_twist = cdr.stamped_floats_encoder(frame_id, 6)
    for stamp_ns in (0, STAMP_NS, 2 ** 31 * 1_000_000_000 - 1):
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        attitude = tuple(normalize(rng.normal(size=4)).tolist())
        position = tuple(rng.normal(size=3).tolist())
        assert encode_orientation(sec, nanosec, attitude) == cdr.encode_quaternion_stamped(
            stamp_ns, frame_id, attitude)
        assert encode_pose(sec, nanosec, position, attitude) == cdr.encode_pose_stamped(
            stamp_ns, frame_id, position, attitude)
        linear, angular = tuple(rng.normal(size=3).tolist()), tuple(rng.normal(size=3).tolist())
        assert encode_vector(sec, nanosec, linear) == cdr.encode_vector3_stamped(
            stamp_ns, frame_id, linear)
        assert encode_twist(sec, nanosec, linear + angular) == cdr.encode_twist_stamped(
            stamp_ns, frame_id, linear, angular)


def test_frame_encoders_reject_bad_frames_and_stamps():
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.quaternion_stamped_encoder('a\x00b')
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.pose_stamped_encoder(None)
    with pytest.raises(InputError, match='`sec` in int32 .* got sec=2147483648'):
        cdr.quaternion_stamped_encoder('world')(2 ** 31, 0, (1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='nanosec=-1'):
        cdr.pose_stamped_encoder('world')(0, -1, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.stamped_floats_encoder('a\x00b', 3)
    with pytest.raises(InputError, match='`sec` in int32 .* got sec=-2147483649'):
        cdr.stamped_floats_encoder('world', 3)(-2 ** 31 - 1, 0, (0.0, 0.0, 0.0))


@pytest.mark.parametrize('little_endian', [True, False])
@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_imu_with_orientation_sets_the_orientation_and_nothing_else(frame_id, little_endian):
    for msgtype, message, _ in _reference_messages(frame_id):
        if msgtype != msgs.IMU:
            continue
        data = bytes(bag.typestore().serialize_cdr(message, msgtype, little_endian=little_endian))
        attitude = tuple(normalize([0.3, -0.1, 0.8, 0.5]).tolist())
        message.orientation = _quaternion_msg(attitude)
        message.orientation_covariance = np.zeros(9)
        expected = bytes(bag.typestore().serialize_cdr(message, msgtype,
                                                       little_endian=little_endian))
        assert cdr.imu_with_orientation(data, attitude) == expected
    with pytest.raises(msgs.MalformedMessage, match='truncated: 52 of 324 bytes'):
        cdr.imu_with_orientation(cdr.encode_vector3_stamped(0, 'base_link', [1.0, 2.0, 3.0]),
                                 (1.0, 0.0, 0.0, 0.0))


def test_quaternion_codecs_agree_with_to_ros_and_from_ros():
    attitude = normalize([0.1, -0.7, 0.3, 0.5])
    message = bag.deserialize(cdr.encode_quaternion_stamped(0, 'world', attitude),
                              msgs.QUATERNION_STAMPED)
    fields = [message.quaternion.x, message.quaternion.y, message.quaternion.z,
              message.quaternion.w]
    assert fields == to_ros(attitude).tolist()
    data = bag.serialize(message, msgs.QUATERNION_STAMPED)
    assert list(cdr.quaternion_stamped(data)[1]) == from_ros(fields).tolist()


def test_imu_encoding_marks_missing_fields_per_rep145():
    message = bag.deserialize(cdr.encode_imu(5, 'imu', [1.0, 2.0, 3.0]), msgs.IMU)
    assert message.orientation_covariance[0] == -1.0
    assert message.linear_acceleration_covariance[0] == -1.0
    assert message.angular_velocity_covariance.tolist() == [0.0] * 9
    full = bag.deserialize(cdr.encode_imu(5, 'imu', [1.0, 2.0, 3.0], [0.0, 0.0, 9.8],
                                          [1.0, 0.0, 0.0, 0.0]), msgs.IMU)
    assert full.orientation_covariance[0] == 0.0
    assert full.linear_acceleration_covariance[0] == 0.0
    assert (full.header.stamp.sec, full.header.stamp.nanosec) == (0, 5)


def test_stamp_to_ns_keeps_epoch_resolution():
    assert cdr.stamp_to_ns(1.5) == 1_500_000_000
    assert cdr.stamp_to_ns(-0.25) == -250_000_000
    # 1.7e9 s: the float's own spacing is 2.4e-7 s; the fraction must survive to that level.
    stamp = 1_700_000_000.123456
    assert abs(cdr.stamp_to_ns(stamp) - 1_700_000_000_123_456_000) <= 240


def test_decoder_rejects_wrong_type_truncation_and_encapsulation():
    vector = cdr.encode_vector3_stamped(0, 'base_link', [1.0, 2.0, 3.0])
    with pytest.raises(msgs.MalformedMessage,
                       match='malformed sensor_msgs/msg/Imu: truncated: 52 of 324 bytes'):
        cdr.imu_rates(vector)
    imu = cdr.encode_imu(0, 'base_link', [1.0, 2.0, 3.0])
    with pytest.raises(msgs.MalformedMessage, match='truncated: 100 of 324 bytes'):
        cdr.imu_rates(imu[:100])
    with pytest.raises(msgs.MalformedMessage, match='truncated: 2 of at least 316 bytes'):
        cdr.imu_rates(imu[:2])
    with pytest.raises(msgs.MalformedMessage, match='bad encapsulation 0x0004'):
        cdr.imu_rates(b'\x00\x04' + imu[2:])
    with pytest.raises(msgs.MalformedMessage,
                       match='std_msgs/msg/Float64: truncated: 11 of 12 bytes'):
        cdr.float64_value(cdr.encode_float64(1.0)[:11])


def test_encoders_reject_bad_arguments():
    with pytest.raises(InputError, match='`angular_velocity` to have 3 components'):
        cdr.encode_imu(0, 'imu', [1.0, 2.0])
    with pytest.raises(InputError, match=r'`attitude` to be \(w, x, y, z\)'):
        cdr.encode_quaternion_stamped(0, 'world', [1.0, 0.0, 0.0])
    with pytest.raises(InputError, match='`stamp_ns` to be an integer'):
        cdr.encode_vector3_stamped(1.5, 'imu', [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match='`stamp_ns` to be an integer'):
        cdr.encode_vector3_stamped(2 ** 31 * 1_000_000_000, 'imu', [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.encode_vector3_stamped(0, 'a\x00b', [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match='`value` to be a float'):
        cdr.encode_float64('one')


def test_pose_with_covariance_encoders_match_rosbags_and_the_decoder():
    from rigid_body_attitude.msgs.cdr import (
        encode_pose_with_covariance_stamped, pose_with_covariance_stamped_encoder)
    from rigid_body_attitude.msgs.decoders import decode_pose_with_covariance_stamped
    covariance = tuple(float(k) for k in range(36))
    store = bag.typestore()
    for frame in ('w', 'world', 'odom_frame'):
        fast = pose_with_covariance_stamped_encoder(frame)(
            1_700_000_000, 5, (1.0, 2.0, 3.0), (0.5, 0.5, 0.5, 0.5), covariance)
        slow = encode_pose_with_covariance_stamped(
            1_700_000_000 * 10**9 + 5, frame, (1.0, 2.0, 3.0), (0.5, 0.5, 0.5, 0.5), covariance)
        message = store.deserialize_cdr(fast, msgs.POSE_WITH_COVARIANCE_STAMPED)
        assert fast == slow == bytes(store.serialize_cdr(message,
                                                         msgs.POSE_WITH_COVARIANCE_STAMPED))
        assert decode_pose_with_covariance_stamped(fast) == (
            1_700_000_000, 5, frame, (1.0, 2.0, 3.0), (0.5, 0.5, 0.5, 0.5), covariance)
    with pytest.raises(InputError):
        encode_pose_with_covariance_stamped(0, 'w', (0.0,) * 3, (1.0, 0.0, 0.0, 0.0), (0.0,) * 35)
