"""The decoders under test, the two typed deserialisers they are held to, and the contract.

Every decoder of :mod:`rigid_body_attitude.msgs.decoders` is paired with the typed message class
(rclpy's generated Python class, deserialised by ``rclpy.serialization`` through
rmw_fastrtps_cpp, as a typed subscription does) and the ``rosbags`` type name. :func:`check`
runs one byte string through all three and asserts the documented contract:

1. the decoder returns values or raises :class:`MalformedMessage`, nothing else;
2. what it takes, rclpy takes with the same values (frame id included);
3. what it takes and ``rosbags`` takes, ``rosbags`` reads with the same values;
4. what it takes and ``rosbags`` refuses has an encapsulation other than ``0x0000``/``0x0001``
   or more than 3 bytes after the body (rclpy takes both);
5. what it refuses and ``rosbags`` takes has a NUL inside the frame id;
6. what it refuses and rclpy takes has one of the frame-id faults rclpy forgives (length 0, no
   terminator, an inner NUL, invalid UTF-8).
"""

from __future__ import annotations

from collections.abc import Callable
import math
import struct
from typing import Any, NamedTuple

from geometry_msgs.msg import (
    PoseStamped, PoseWithCovarianceStamped, QuaternionStamped, TwistStamped, Vector3Stamped,
    WrenchStamped)
from rclpy.serialization import deserialize_message
from rosbags.serde import SerdeError
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.msgs import decoders
from rigid_body_attitude.msgs.errors import MalformedMessage

#: Reasons for refusing a frame id that rclpy forgives (documented in msgs/decoders.py).
FRAME_FAULTS = ('frame_id length 0', 'frame_id lacks its NUL terminator', 'frame_id has a NUL',
                'frame_id is not UTF-8')


def _xyz(vector: Any) -> tuple[float, ...]:
    return (vector.x, vector.y, vector.z)


def _wxyz(quaternion: Any) -> tuple[float, ...]:
    return (quaternion.w, quaternion.x, quaternion.y, quaternion.z)


def _head(message: Any) -> tuple[Any, ...]:
    stamp = message.header.stamp
    return (stamp.sec, stamp.nanosec, message.header.frame_id)


class Kind(NamedTuple):
    """One decoder and how to read the same values from a typed message object."""

    decode: Callable[[bytes], Any]
    msgtype: str
    rclpy_class: type
    values: Callable[[Any], Any]
    floats: int  # float64 count of the body


KINDS: dict[str, Kind] = {
    'imu_rate': Kind(decoders.decode_imu_rate, msgs.IMU, Imu,
                     lambda m: (*_head(m), _xyz(m.angular_velocity)), 37),
    'imu': Kind(decoders.decode_imu, msgs.IMU, Imu,
                lambda m: (*_head(m), _wxyz(m.orientation), _xyz(m.angular_velocity),
                           _xyz(m.linear_acceleration)), 37),
    'vector3_stamped': Kind(decoders.decode_vector3_stamped, msgs.VECTOR3_STAMPED,
                            Vector3Stamped, lambda m: (*_head(m), _xyz(m.vector)), 3),
    'twist_angular': Kind(decoders.decode_twist_angular, msgs.TWIST_STAMPED, TwistStamped,
                          lambda m: (*_head(m), _xyz(m.twist.angular)), 6),
    'twist_stamped': Kind(decoders.decode_twist_stamped, msgs.TWIST_STAMPED, TwistStamped,
                          lambda m: (*_head(m), _xyz(m.twist.linear), _xyz(m.twist.angular)), 6),
    'wrench_stamped': Kind(decoders.decode_wrench_stamped, msgs.WRENCH_STAMPED, WrenchStamped,
                           lambda m: (*_head(m), _xyz(m.wrench.force), _xyz(m.wrench.torque)),
                           6),
    'pose_stamped': Kind(decoders.decode_pose_stamped, msgs.POSE_STAMPED, PoseStamped,
                         lambda m: (*_head(m), _xyz(m.pose.position),
                                    _wxyz(m.pose.orientation)), 7),
    'pose_with_covariance_stamped': Kind(
        decoders.decode_pose_with_covariance_stamped, msgs.POSE_WITH_COVARIANCE_STAMPED,
        PoseWithCovarianceStamped,
        lambda m: (*_head(m), _xyz(m.pose.pose.position), _wxyz(m.pose.pose.orientation),
                   tuple(float(v) for v in m.pose.covariance)), 43),
    'quaternion_stamped': Kind(decoders.decode_quaternion_stamped, msgs.QUATERNION_STAMPED,
                               QuaternionStamped,
                               lambda m: (*_head(m), _wxyz(m.quaternion)), 4),
    'float64': Kind(decoders.decode_float64, msgs.FLOAT64, Float64, lambda m: m.data, 1),
}


def same(first: Any, second: Any) -> bool:
    """Equal values, NaN equal to NaN, floats and ints compared as numbers."""
    if isinstance(first, tuple) and isinstance(second, tuple):
        return len(first) == len(second) and all(map(same, first, second))
    if isinstance(first, float) and isinstance(second, float):
        return first == second or (math.isnan(first) and math.isnan(second))
    return bool(type(first) is type(second) and first == second)


def encode(little_endian: bool, sec: int, nanosec: int, frame: bytes, floats: list[float],
           alignment: int = 8, encapsulation: int | None = None,
           header: bool = True) -> bytes:
    """Bytes of a Header + float64 message laid out by hand (any frame bytes, no checks)."""
    order = '<' if little_endian else '>'
    identifier = int(little_endian) if encapsulation is None else encapsulation
    start = struct.pack('>H', identifier) + b'\x00\x00'
    if not header:
        return start + struct.pack(f'{order}{len(floats)}d', *floats)
    payload = struct.pack(order + 'iII', sec, nanosec, len(frame)) + frame
    payload += bytes(-len(payload) % alignment)
    return start + payload + struct.pack(f'{order}{len(floats)}d', *floats)


def _outcome(run: Callable[[], Any]) -> tuple[bool, Any]:
    try:
        return True, run()
    except MalformedMessage as err:
        return False, err


def _rosbags(kind: Kind, data: bytes) -> tuple[bool, Any]:
    try:
        return True, kind.values(bag.typestore().deserialize_cdr(data, kind.msgtype))
    except SerdeError as err:
        return False, err


def _rclpy(kind: Kind, data: bytes) -> tuple[bool, Any]:
    try:
        return True, kind.values(deserialize_message(data, kind.rclpy_class))
    except Exception as err:  # rclpy raises _rclpy.RMWError, not importable by name
        return False, err


def _same_outcome(first: tuple[bool, Any], second: tuple[bool, Any]) -> bool:
    if first[0] and second[0]:
        return same(first[1], second[1])
    return first[0] == second[0] and first[1].reason == second[1].reason


def check(name: str, data: bytes, warm: bytes | None = None) -> str:
    """Assert the contract for ``data`` decoded as ``name``; return which case it was.

    With ``warm`` (a good message), ``data`` is decoded again after ``warm`` three times, so
    that the decoder's one-call path is primed with ``warm``'s frame id: both outcomes must be
    the same (every path of the decoder meets the contract).
    """
    kind = KINDS[name]
    taken, ours = _outcome(lambda: kind.decode(data))
    if warm is not None:
        for _ in range(3):
            kind.decode(warm)
        again = _outcome(lambda: kind.decode(data))
        assert _same_outcome((taken, ours), again), (name, data.hex(), ours, again)
    rosbags_taken, rosbags_value = _rosbags(kind, data)
    rclpy_taken, rclpy_value = _rclpy(kind, data)
    if taken:
        assert rclpy_taken and same(ours, rclpy_value), (name, data.hex(), ours, rclpy_value)
        if rosbags_taken:
            assert same(ours, rosbags_value), (name, data.hex(), ours, rosbags_value)
            return 'all take'
        if data[:2] not in (b'\x00\x00', b'\x00\x01'):
            return 'taken: encapsulation rosbags refuses'
        assert 'size mismatch' in str(rosbags_value), (name, data.hex(), rosbags_value)
        return 'taken: trailing bytes rosbags refuses'
    reason = ours.reason
    assert len(str(ours)) < 160, str(ours)
    if rosbags_taken:
        assert '\x00' in rosbags_value[2] and reason.startswith('frame_id has a NUL'), (
            name, data.hex(), reason, rosbags_value)
        return 'refused: inner NUL rosbags keeps'
    if rclpy_taken:
        assert reason.startswith(FRAME_FAULTS), (name, data.hex(), reason, rclpy_value)
        return 'refused: frame id rclpy forgives'
    return 'all refuse'
