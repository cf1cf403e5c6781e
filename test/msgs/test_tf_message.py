"""The TFMessage decoder against rclpy's serialiser, and against hostile bytes."""

from __future__ import annotations

import struct

from geometry_msgs.msg import TransformStamped
import pytest
from rclpy.serialization import serialize_message
from tf2_msgs.msg import TFMessage

from rigid_body_attitude import bag
from rigid_body_attitude.msgs import MalformedMessage, decode_tf_message
from rigid_body_attitude.msgs.tf_message import MAX_TF_TRANSFORMS, TF_MESSAGE


def tf_message(*transforms: tuple[str, str, tuple[float, ...], tuple[float, ...]]) -> TFMessage:
    """(parent, child, translation, rotation (x, y, z, w)) each."""
    message = TFMessage()
    for index, (parent, child, translation, xyzw) in enumerate(transforms):
        transform = TransformStamped()
        transform.header.stamp.sec, transform.header.stamp.nanosec = 1_700_000_000 + index, 7
        transform.header.frame_id, transform.child_frame_id = parent, child
        t, r = transform.transform.translation, transform.transform.rotation
        t.x, t.y, t.z = translation
        r.x, r.y, r.z, r.w = xyzw
        message.transforms.append(transform)
    return message


CHAIN = (('base_link', 'torso', (0.1, 0.2, 0.3), (0.0, 0.0, 0.6, 0.8)),
         ('torso', 'imu_link_with_a_longer_name', (-1.0, 0.0, 2.5), (0.5, -0.5, 0.5, 0.5)),
         ('a', 'bc', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))


@pytest.mark.parametrize('count', [0, 1, 2, 3])
def test_decodes_what_rclpy_serialises_and_rosbags_reads(count):
    """Every field, for frame names of several paddings, scalar-first rotations."""
    data = serialize_message(tf_message(*CHAIN[:count]))
    decoded = decode_tf_message(data)
    assert [(t.parent_frame, t.child_frame, t.translation, t.rotation) for t in decoded] == [
        (parent, child, translation, (xyzw[3], *xyzw[:3]))
        for parent, child, translation, xyzw in CHAIN[:count]]
    assert [(t.sec, t.nanosec) for t in decoded] == [(1_700_000_000 + k, 7) for k in range(count)]
    reference = bag.typestore().deserialize_cdr(data, TF_MESSAGE)
    assert [t.child_frame_id for t in reference.transforms] == [t.child_frame for t in decoded]


def test_big_endian_bytes_decode_alike():
    message = bag.typestore().deserialize_cdr(serialize_message(tf_message(*CHAIN)), TF_MESSAGE)
    big = bytes(bag.typestore().serialize_cdr(message, TF_MESSAGE, little_endian=False))
    assert big[:2] == b'\x00\x00'
    assert decode_tf_message(big) == decode_tf_message(serialize_message(tf_message(*CHAIN)))


def test_every_truncation_is_refused():
    data = serialize_message(tf_message(*CHAIN))
    for size in range(len(data)):
        with pytest.raises(MalformedMessage):
            decode_tf_message(data[:size])


def _with_uint32(data: bytes, offset: int, value: int) -> bytes:
    return data[:offset] + struct.pack('<I', value) + data[offset + 4:]


@pytest.mark.parametrize('mutate, reason', [
    (lambda d: _with_uint32(d, 4, MAX_TF_TRANSFORMS + 1), 'transforms in'),
    (lambda d: _with_uint32(d, 4, 0xFFFFFFFF), 'transforms in'),
    (lambda d: _with_uint32(d, 16, 0), 'frame_id length 0'),
    (lambda d: _with_uint32(d, 16, 0xFFFFFFFF), 'frame_id length 4294967295'),
    (lambda d: d[:20] + b'\xff' + d[21:], 'not UTF-8'),
    (lambda d: d[:20] + b'\x00' + d[21:], 'NUL'),
    (lambda d: b'\x01\x05' + d[2:], 'bad encapsulation 0x0105'),
    (lambda d: 'text', 'expected bytes'),
])
def test_hostile_bytes_are_refused_with_a_bounded_reason(mutate, reason):
    data = serialize_message(tf_message(*CHAIN))
    with pytest.raises(MalformedMessage) as caught:
        decode_tf_message(mutate(data))
    assert reason in caught.value.reason and len(caught.value.reason) < 120
