"""The JointState codec against rclpy's serialiser, and against hostile bytes."""

from __future__ import annotations

import struct

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState

from rigid_body_attitude import bag
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs import MalformedMessage
from rigid_body_attitude.msgs.joint_state import (
    JOINT_STATE, MAX_JOINT_NAME, MAX_JOINTS, decode_joint_state, joint_state_encoder)


def joint_state(names, position=(), velocity=(), effort=(), frame='base_link'):
    message = JointState()
    message.header.stamp.sec, message.header.stamp.nanosec = 1_700_000_000, 123
    message.header.frame_id = frame
    message.name = list(names)
    message.position, message.velocity, message.effort = (
        list(position), list(velocity), list(effort))
    return message


CASES = [
    ((), (), (), ()),
    (('wheel_a',), (), (), (0.01,)),
    (('wheel_a', 'wb', 'wheel_ccc', 'wheel_dddd'), (), (1.0, -2.0, 3.5, 1e300), ()),
    (('a', 'bc', 'def'), (0.1, 0.2, 0.3), (-1.0, 0.0, 2.0), (0.5, -0.5, 0.25)),
    (('only_effort', 'x'), (), (), (float('nan'), float('inf'))),
]


@pytest.mark.parametrize('names, position, velocity, effort', CASES)
@pytest.mark.parametrize('frame', ['', 'base_link', 'abc'])
def test_decode_joint_state_reads_what_rclpy_serialises(names, position, velocity, effort,
                                                        frame):
    """Every field, names and frames of every padding; NaN and Inf come out as sent."""
    data = serialize_message(joint_state(names, position, velocity, effort, frame))
    decoded = decode_joint_state(data)
    assert (decoded.sec, decoded.nanosec, decoded.frame_id) == (1_700_000_000, 123, frame)
    assert decoded.names == names
    assert [repr(v) for v in decoded.position + decoded.velocity + decoded.effort] == [
        repr(float(v)) for v in position + velocity + effort]


@pytest.mark.parametrize('names, position, velocity, effort', CASES)
def test_joint_state_encoder_gives_what_rclpy_reads(names, position, velocity, effort):
    """The encoder's bytes deserialise in rclpy and in rosbags to the same message."""
    for frame in ('', 'b', 'body_frame'):
        data = joint_state_encoder(frame, names)(7, 9, position, velocity, effort)
        message = deserialize_message(data, JointState)
        assert (message.header.stamp.sec, message.header.stamp.nanosec) == (7, 9)
        assert message.header.frame_id == frame
        assert tuple(message.name) == names
        assert [repr(float(v)) for v in (*message.position, *message.velocity,
                                         *message.effort)] == [
            repr(float(v)) for v in position + velocity + effort]
        reference = bag.typestore().deserialize_cdr(data, JOINT_STATE)
        assert tuple(reference.name) == names


def test_joint_state_encoder_refuses_wrong_lengths_and_names():
    encode = joint_state_encoder('body', ('a', 'b'))
    with pytest.raises(InputError, match='`effort` empty or 2 values, got 1'):
        encode(0, 0, (), (), (1.0,))
    with pytest.raises(InputError, match='without NUL'):
        joint_state_encoder('body', ('a\x00b',))
    with pytest.raises(InputError, match='at most 255 bytes'):
        joint_state_encoder('body', ('x' * MAX_JOINT_NAME,))


def test_big_endian_bytes_decode_alike():
    little = joint_state_encoder('base', ('a', 'bc', 'def'))(
        3, 4, (0.1, 0.2, 0.3), (-1.0, 0.0, 2.0), ())
    typed = bag.typestore().deserialize_cdr(little, JOINT_STATE)
    big = bytes(bag.typestore().serialize_cdr(typed, JOINT_STATE, little_endian=False))
    assert big[:2] == b'\x00\x00'
    assert decode_joint_state(big) == decode_joint_state(little)


def test_every_truncation_is_refused():
    data = serialize_message(joint_state(('a', 'bc', 'def'), (), (1.0, 2.0, 3.0), (4.0,) * 3))
    for size in range(len(data)):
        with pytest.raises(MalformedMessage):
            decode_joint_state(data[:size])
    assert decode_joint_state(data + b'\x00' * 100) == decode_joint_state(data)


def test_hostile_counts_and_strings_are_refused_with_their_reason():
    data = bytearray(serialize_message(joint_state(('a', 'bc'), (), (1.0, 2.0), ())))
    name_count_at = 4 + 12 + 12  # stamp, frame length, 'base_link\0' padded to 12
    assert struct.unpack_from('<I', data, name_count_at) == (2,)
    huge = bytearray(data)
    struct.pack_into('<I', huge, name_count_at, MAX_JOINTS + 1)
    with pytest.raises(MalformedMessage, match=f'name: {MAX_JOINTS + 1} elements'):
        decode_joint_state(bytes(huge))
    unterminated = bytearray(data)
    unterminated[name_count_at + 4 + 4 + 1] = ord('x')  # 'a\0' -> 'ax'
    with pytest.raises(MalformedMessage, match='not NUL-terminated'):
        decode_joint_state(bytes(unterminated))
    empty = bytearray(data)
    struct.pack_into('<I', empty, name_count_at + 4, 0)
    with pytest.raises(MalformedMessage, match='name length 0'):
        decode_joint_state(bytes(empty))
    with pytest.raises(MalformedMessage, match='bad encapsulation 0x0004'):
        decode_joint_state(b'\x00\x04' + bytes(data[2:]))
    with pytest.raises(MalformedMessage, match='expected bytes'):
        decode_joint_state('text')  # type: ignore[arg-type]
