"""The ``nav_msgs/msg/Odometry`` codec against rclpy's own serialisation (rmw_fastrtps_cpp)."""

from __future__ import annotations

import struct

from nav_msgs.msg import Odometry as RosOdometry
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.odometry import (
    decode_odometry, encode_odometry, EXACT_COVARIANCE, odometry_encoder)

FRAMES = ['', 'a', 'odom', 'world', 'abcdefghijkl', 'ünïcode']
STAMP = (1_700_000_123, 456_789_012)


def _values(seed: int) -> tuple[list[float], ...]:
    rng = np.random.default_rng(seed)
    position, linear, angular = rng.normal(size=(3, 3)).tolist()
    attitude = rng.normal(size=4)
    return position, (attitude / np.linalg.norm(attitude)).tolist(), linear, angular


def _ros_message(frame: str, child: str, seed: int, pose_covariance=EXACT_COVARIANCE,
                 twist_covariance=EXACT_COVARIANCE) -> RosOdometry:
    position, (w, x, y, z), linear, angular = _values(seed)
    message = RosOdometry()
    message.header.stamp.sec, message.header.stamp.nanosec = STAMP
    message.header.frame_id, message.child_frame_id = frame, child
    pose = message.pose.pose
    pose.position.x, pose.position.y, pose.position.z = position
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = x, y, z, w
    twist = message.twist.twist
    twist.linear.x, twist.linear.y, twist.linear.z = linear
    twist.angular.x, twist.angular.y, twist.angular.z = angular
    message.pose.covariance = list(pose_covariance)
    message.twist.covariance = list(twist_covariance)
    return message


def _padding(frame: str, child: str) -> list[int]:
    """Byte offsets of the alignment padding (Fast CDR leaves it uninitialised)."""
    frame_end = 16 + len(frame.encode()) + 1
    child_at = frame_end + -(frame_end - 4) % 4
    child_end = child_at + 4 + len(child.encode()) + 1
    return [*range(frame_end, child_at), *range(child_end, child_end + -(child_end - 4) % 8)]


def _without(data: bytes, offsets: list[int]) -> bytes:
    return bytes(value for index, value in enumerate(data) if index not in offsets)


@pytest.mark.parametrize('child', FRAMES)
@pytest.mark.parametrize('frame', FRAMES)
def test_encoder_bytes_equal_rclpy_serialize_message(frame, child):
    seed = len(frame) * 7 + len(child)
    position, attitude, linear, angular = _values(seed)
    encoded = odometry_encoder(frame, child)(*STAMP, position, attitude, linear, angular)
    rclpy_bytes = serialize_message(_ros_message(frame, child, seed))
    padding = _padding(frame, child)
    assert len(encoded) == len(rclpy_bytes)
    assert _without(encoded, padding) == _without(rclpy_bytes, padding)
    assert all(encoded[index] == 0 for index in padding)
    types = bag.typestore()
    assert encoded == bytes(types.serialize_cdr(types.deserialize_cdr(rclpy_bytes,
                                                                      msgs.ODOMETRY),
                                                msgs.ODOMETRY))  # rosbags pads with zeros
    assert encode_odometry(STAMP[0] * 10**9 + STAMP[1], frame, child, position, attitude,
                           linear, angular) == encoded


def test_encoder_writes_given_covariances():
    pose_covariance = [0.01 * i for i in range(36)]
    twist_covariance = [-0.5 * i for i in range(36)]
    position, attitude, linear, angular = _values(3)
    encoded = odometry_encoder('world', 'base_link', pose_covariance, twist_covariance)(
        *STAMP, position, attitude, linear, angular)
    padding = _padding('world', 'base_link')
    assert _without(encoded, padding) == _without(serialize_message(
        _ros_message('world', 'base_link', 3, pose_covariance, twist_covariance)), padding)


def test_encoder_refuses_bad_frames_covariances_and_stamps():
    with pytest.raises(InputError, match='child_frame_id'):
        odometry_encoder('world', 'a\x00b')
    with pytest.raises(InputError, match='pose_covariance'):
        odometry_encoder('world', 'base_link', (0.0,) * 35)
    encode = odometry_encoder('world', 'base_link')
    with pytest.raises(InputError, match='sec'):
        encode(2**31, 0, (0.0,) * 3, (1.0, 0.0, 0.0, 0.0), (0.0,) * 3, (0.0,) * 3)


@pytest.mark.parametrize('child', FRAMES)
@pytest.mark.parametrize('frame', FRAMES)
def test_decoder_reads_rclpy_and_rosbags_bytes(frame, child):
    seed = len(frame) * 7 + len(child)
    position, attitude, linear, angular = _values(seed)
    message = _ros_message(frame, child, seed)
    expected = (*STAMP, frame, child, tuple(position), tuple(attitude), tuple(linear),
                tuple(angular))
    little = serialize_message(message)
    types = bag.typestore()
    big = bytes(types.serialize_cdr(types.deserialize_cdr(little, msgs.ODOMETRY),
                                    msgs.ODOMETRY, little_endian=False))
    for _ in range(3):  # the slow path, the pair primed, the one-call path
        assert tuple(decode_odometry(little)) == expected
        assert tuple(decode_odometry(big)) == expected


def _hand_made(frame: bytes, child: bytes, encapsulation: int = 0x0001, alignment: int = 8,
               little_endian: bool = True, body: int = 85) -> bytes:
    """An Odometry laid out by hand (any string bytes, no checks)."""
    order = '<' if little_endian else '>'
    payload = struct.pack(order + 'iII', 5, 7, len(frame)) + frame
    payload += bytes(-len(payload) % 4) + struct.pack(order + 'I', len(child)) + child
    payload += bytes(-len(payload) % alignment)
    values = [0.5 + index for index in range(85)]
    values[3:7] = [0.0, 0.0, 0.0, 1.0]
    return (struct.pack('>H', encapsulation) + b'\x00\x00' + payload
            + struct.pack(f'{order}{body}d', *values[:body]))


def _rclpy_takes(data: bytes) -> RosOdometry | None:
    try:
        return deserialize_message(data, RosOdometry)
    except Exception:  # rclpy's RMWError: a typed subscription drops the message
        return None


@pytest.mark.parametrize('payload', [
    _hand_made(b'odom\x00', b'base_link\x00'),
    _hand_made(b'odom\x00', b'base_link\x00') + b'\xab' * 100,
    _hand_made(b'odom\x00', b'base_link\x00', 0x0000, little_endian=False),
    _hand_made(b'odom\x00', b'base_link\x00', 0x0003),
    _hand_made(b'odom\x00', b'bas\x00', 0x0007, alignment=4),
    _hand_made(b'odom\x00', b'bas\x00', 0x0009, alignment=4),
])
def test_what_the_decoder_takes_rclpy_takes_with_the_same_values(payload):
    ours = decode_odometry(payload)
    theirs = _rclpy_takes(payload)
    assert theirs is not None
    pose, twist = theirs.pose.pose, theirs.twist.twist
    assert (ours.sec, ours.nanosec, ours.frame_id, ours.child_frame_id) == (
        theirs.header.stamp.sec, theirs.header.stamp.nanosec, theirs.header.frame_id,
        theirs.child_frame_id)
    assert ours.position == (pose.position.x, pose.position.y, pose.position.z)
    assert ours.orientation == (pose.orientation.w, pose.orientation.x, pose.orientation.y,
                                pose.orientation.z)
    assert ours.linear == (twist.linear.x, twist.linear.y, twist.linear.z)
    assert ours.angular == (twist.angular.x, twist.angular.y, twist.angular.z)


@pytest.mark.parametrize('payload, reason', [
    (_hand_made(b'odom\x00', b'base_link\x00', body=84), 'truncated'),
    (_hand_made(b'odom\x00', b'base_link\x00')[:30], 'truncated'),
    (b'\x00\x01', 'truncated'),
    (b'\x00\x04' + _hand_made(b'odom\x00', b'base_link\x00')[2:], 'bad encapsulation'),
    (_hand_made(b'odom\x00', b''), 'child_frame_id length 0'),
    (_hand_made(b'odom\x00', b'base'), 'child_frame_id is not NUL-terminated'),
    (_hand_made(b'odom\x00', b'ba\x00e\x00'), 'child_frame_id is not NUL-terminated'),
    (_hand_made(b'odom\x00', b'\xff\xfe\x00'), 'child_frame_id is not UTF-8'),
    (_hand_made(b'od\x00m\x00', b'base_link\x00'), 'frame_id is not NUL-terminated'),
    (_hand_made(b'odom\x00', b'base_link\x00')[:12] + struct.pack('<I', 2**32 - 1)
     + _hand_made(b'odom\x00', b'base_link\x00')[16:], 'frame_id length'),
])
def test_decoder_refuses_malformed_bytes_naming_the_fault(payload, reason):
    decode_odometry(serialize_message(_ros_message('odom', 'base_link', 1)))  # primed
    decode_odometry(serialize_message(_ros_message('odom', 'base_link', 1)))
    with pytest.raises(MalformedMessage, match=reason):
        decode_odometry(payload)
    if reason in ('truncated', 'bad encapsulation'):
        assert _rclpy_takes(payload) is None  # rclpy refuses these too


def test_decoder_refuses_what_is_not_bytes():
    with pytest.raises(MalformedMessage, match='expected bytes'):
        decode_odometry('text')  # type: ignore[arg-type]
