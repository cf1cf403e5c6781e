"""Checked decoders of the fixed-layout messages the node and replay read, from CDR bytes.

Every decoder takes the serialised bytes of one message (a raw rclpy subscription's
``bytes``, or a bag record) and returns plain values, or raises
:class:`~rigid_body_attitude.msgs.errors.MalformedMessage` (one type, never ``struct.error``,
``IndexError``, ``UnicodeDecodeError`` or ``MemoryError``) with a short, bounded ``reason``.
No value is judged here beyond the wire format: ``nanosec ≥ 10⁹``, NaN or 1e308 come out as
they are (physical bounds are the session's job).

==================================  ===========================================================
``decode_imu_rate(data)``           ``(sec, nanosec, frame_id, (ωx, ωy, ωz))`` of an Imu
``decode_imu_motion(data)``         ``(sec, nanosec, frame_id, (ωx, ωy, ωz), (ax, ay, az))``
``decode_vector3_stamped(data)``    ``(sec, nanosec, frame_id, (x, y, z))``
``decode_twist_angular(data)``      ``(sec, nanosec, frame_id, (ωx, ωy, ωz))`` of a TwistStamped
``decode_wrench_stamped(data)``     ``(sec, nanosec, frame_id, force, torque)``
``decode_pose_stamped(data)``       ``(sec, nanosec, frame_id, position, (w, x, y, z))``
``decode_pose_with_covariance_stamped(data)`` the same and the row-major 6×6 covariance (36)
``decode_quaternion_stamped(data)`` ``(sec, nanosec, frame_id, (w, x, y, z))``
``decode_twist_stamped(data)``      ``(sec, nanosec, frame_id, linear, angular)``
``decode_imu(data)``                ``(sec, nanosec, frame_id, (w, x, y, z), ω, a)``
``decode_float64(data)``            ``value``
``decode_header(data)``             ``(sec, nanosec, frame_id)`` of any stamped message
==================================  ===========================================================

``sec`` is the int32 and ``nanosec`` the uint32 of the header stamp, as sent; vectors are
tuples of floats; quaternions scalar-first (the message holds ``(x, y, z, w)``; see
:mod:`rigid_body_attitude.core.attitude.quaternion`). :data:`RATE_DECODERS` is the one registry
of rate decoders: each gyro message type (Imu, Vector3Stamped, TwistStamped's angular part) to
the decoder of ``(sec, nanosec, frame_id, (ωx, ωy, ωz), (ax, ay, az) or None)``.

What is taken. Layout (OMG CDR): a 4-byte encapsulation header, then ``std_msgs/Header``
(``int32 sec`` at payload offset 0, ``uint32 nanosec`` at 4, ``uint32 n`` at 8, ``n`` string
bytes at 12 including the terminating NUL), then the float64 body at the next multiple of the
float64 alignment. The reference is what a typed subscription of rclpy (Jazzy, rmw_fastrtps_cpp,
Fast CDR 2.2) takes, measured by ``test/msgs/test_decoders_rclpy.py`` through
``rclpy.serialization`` and a real publisher sending raw bytes to a typed subscription; where
it differs from ``rosbags``' ``deserialize_cdr`` that is said below and tested by
``test/msgs/test_decoders_properties.py``.

* Encapsulation (bytes 0-1): ``0x0000`` CDR_BE and ``0x0001`` CDR_LE (what every ROS 2 writer
  produces), and, as rclpy reads them, ``0x0002``/``0x0003`` (PL_CDR, read as plain XCDR1) and
  ``0x0006``-``0x000b`` (the XCDR2 ids, read as plain XCDR2: float64 aligned to 4 bytes, not 8).
  Anything else (``0x0004``, ``0x0105``, ...) is refused. ``rosbags`` takes only
  ``0x0000``/``0x0001``. Bytes 2-3 (options) are ignored, by rclpy and ``rosbags`` alike.
* ``frame_id``: a length of 1 or more, within the message, the last byte NUL, no other NUL,
  UTF-8. rclpy also takes a length of 0, a missing terminator, an inner NUL (it cuts the string
  there) and invalid UTF-8 (replaced by U+FFFD); these are refused here, as ``rosbags`` refuses
  all but the inner NUL (which it keeps in the string).
* Alignment padding: any byte values (neither deserialiser checks them), but the bytes must be
  there.
* Length: a message shorter than its header, frame id and body is refused (``truncated``).
  Bytes after the body are taken and ignored, any number, as rclpy does (a raw publisher's
  message with 100 extra bytes reaches a typed subscription); ``rosbags`` refuses more than 3.
* These message types hold no sequences: ``frame_id`` is the only length field.

Speed. A CDR_LE message of the frame id a decoder saw last (the normal case: one sensor, one
frame) is read by one ``struct`` call (encapsulation, stamp, frame-id length and bytes, the
fields wanted) and two byte-string comparisons. A known frame id that is not the last one seen
costs a second ``struct`` call and a dictionary look-up; anything else (another encapsulation,
a new frame id, any fault) goes through the complete, slower check that names the fault and
learns the frame id (up to 64 of at most 256 bytes; the table is emptied when full).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from struct import Struct
from typing import Any, NamedTuple

from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.types import (
    FIXED_LAYOUTS,
    FLOAT64,
    IMU,
    MAGNETIC_FIELD,
    POSE_STAMPED,
    POSE_WITH_COVARIANCE_STAMPED,
    QUATERNION_STAMPED,
    TWIST_STAMPED,
    VECTOR3_STAMPED,
    WRENCH_STAMPED,
)

__all__ = [
    'ENCAPSULATIONS',
    'Floats',
    'RATE_DECODERS',
    'RateDecoder',
    'RateSample',
    'StampedFloats',
    'StampedFloatsDecoder',
    'body_offset',
    'decode_float64',
    'decode_header',
    'decode_imu',
    'decode_imu_motion',
    'decode_imu_rate',
    'decode_magnetic_field',
    'decode_pose_stamped',
    'decode_pose_with_covariance_stamped',
    'decode_quaternion_stamped',
    'decode_twist_angular',
    'decode_twist_stamped',
    'decode_vector3_stamped',
    'decode_wrench_stamped',
    'parse_stamped',
]

Floats = tuple[float, ...]
#: ``(sec, nanosec, frame_id, values)``: a header and float64 fields (a vector, a wrench...).
StampedFloats = tuple[int, int, str, Floats]
#: A decoder of a stamped message's float64 fields: CDR bytes → :data:`StampedFloats`.
StampedFloatsDecoder = Callable[[bytes], StampedFloats]


class Encapsulation(NamedTuple):
    """How the payload after one encapsulation id is read."""

    name: str
    little_endian: bool
    float64_alignment: int


#: Encapsulation ids taken (bytes 0-1 as a big-endian number) and how they are read.
ENCAPSULATIONS: dict[int, Encapsulation] = {
    0x0000: Encapsulation('CDR_BE', False, 8),
    0x0001: Encapsulation('CDR_LE', True, 8),
    0x0002: Encapsulation('PL_CDR_BE', False, 8),
    0x0003: Encapsulation('PL_CDR_LE', True, 8),
    0x0006: Encapsulation('CDR2_BE', False, 4),
    0x0007: Encapsulation('CDR2_LE', True, 4),
    0x0008: Encapsulation('D_CDR2_BE', False, 4),
    0x0009: Encapsulation('D_CDR2_LE', True, 4),
    0x000a: Encapsulation('PL_CDR2_BE', False, 4),
    0x000b: Encapsulation('PL_CDR2_LE', True, 4),
}

# Body sizes in float64 after the header of each stamped message, and field positions.
_IMU = FIXED_LAYOUTS[IMU]
IMU_COUNT = _IMU.count      # orientation 4, cov 9, angular_velocity 3, cov 9, accel 3, cov 9
_IMU_RATE_AT = _IMU.at('angular_velocity.x')
_IMU_ACCELERATION_AT = _IMU.at('linear_acceleration.x')
_HEADER = 16                 # encapsulation 4, sec, nanosec, string length
_MAX_FRAMES = 64
_MAX_CACHED_FRAME = 256
_PLAUSIBLE_FRAME = 2 ** 16

#: Frame-id bytes (with the NUL) seen in good messages → the decoded text.
_FRAMES: dict[bytes, str] = {}
# Fast path: encapsulation (bytes 0-1 read little-endian, so CDR_LE is 0x0100) and header.
_LE_HEADER = Struct('<H2xiII').unpack_from
_LE_FLOAT64 = Struct('<H2xd').unpack_from
_CDR_LE = 0x0100
_FAST_ERRORS = (KeyError, TypeError, ValueError, struct.error)


class Parsed(NamedTuple):
    """A checked stamped message: header fields, where the body starts, its float64 values."""

    sec: int
    nanosec: int
    frame_id: str
    encapsulation: Encapsulation
    body_offset: int
    body: Floats


def _bytes(data: object, msgtype: str) -> bytes:
    if isinstance(data, bytes):
        return data
    if isinstance(data, (bytearray, memoryview)):
        return bytes(data)
    raise MalformedMessage(msgtype, f'expected bytes, got {type(data).__name__[:40]}')


def _encapsulation(raw: bytes, msgtype: str, minimum: int) -> Encapsulation:
    if len(raw) < 4:
        raise MalformedMessage(msgtype, f'truncated: {len(raw)} of at least {minimum} bytes')
    identifier = raw[0] << 8 | raw[1]
    encapsulation = ENCAPSULATIONS.get(identifier)
    if encapsulation is None:
        raise MalformedMessage(msgtype, f'bad encapsulation 0x{identifier:04x}')
    return encapsulation


def _frame_text(raw: bytes, length: int, msgtype: str, size: int) -> str:
    """The checked ``frame_id`` of ``length`` bytes at offset 16 (learned if short).

    ``size`` is the message size the length implies: a message shorter than that is
    ``truncated`` if the length is plausible (up to 64 KiB), else the length is named.
    """
    if length == 0:
        raise MalformedMessage(msgtype, 'frame_id length 0 (a CDR string holds at least '
                                        'its NUL)')
    end = _HEADER + length
    if end > len(raw):
        if length <= _PLAUSIBLE_FRAME:
            raise MalformedMessage(msgtype, f'truncated: {len(raw)} of {size} bytes')
        raise MalformedMessage(msgtype, f'frame_id length {length} exceeds message '
                                        f'({len(raw)} bytes)')
    text = raw[_HEADER:end]
    if text[-1] != 0:
        raise MalformedMessage(msgtype, 'frame_id lacks its NUL terminator')
    inner = text.find(0)
    if inner < length - 1:
        raise MalformedMessage(msgtype, f'frame_id has a NUL at byte {inner} of {length}')
    try:
        value = text[:-1].decode('utf-8')
    except UnicodeDecodeError as err:
        raise MalformedMessage(msgtype, f'frame_id is not UTF-8 (byte {err.start})') from None
    if length <= _MAX_CACHED_FRAME:
        if len(_FRAMES) >= _MAX_FRAMES:
            _FRAMES.clear()
        _FRAMES[text] = value
    return value


def _float64s(little_endian: bool, count: int) -> Callable[[bytes, int], Floats]:
    return Struct(('<' if little_endian else '>') + f'{count}d').unpack_from


def parse_stamped(data: bytes, msgtype: str, count: int) -> Parsed:
    """Check a message of a ``Header`` and ``count`` float64 completely; the slow path.

    ``count = 0`` checks the header alone (any stamped message; no padding after the frame id
    is required then).
    """
    raw = _bytes(data, msgtype)
    minimum = 4 + 16 + 8 * count
    encapsulation = _encapsulation(raw, msgtype, minimum)
    if len(raw) < _HEADER:
        raise MalformedMessage(msgtype, f'truncated: {len(raw)} of at least {minimum} bytes')
    order = '<' if encapsulation.little_endian else '>'
    sec, nanosec, length = struct.unpack_from(order + 'iII', raw, 4)
    alignment = encapsulation.float64_alignment
    offset = 4 + -(-(12 + length) // alignment) * alignment
    frame_id = _frame_text(raw, length, msgtype, offset + 8 * count)
    if count and len(raw) < offset + 8 * count:
        raise MalformedMessage(msgtype, f'truncated: {len(raw)} of {offset + 8 * count} bytes')
    body = _float64s(encapsulation.little_endian, count)(raw, offset) if count else ()
    return Parsed(sec, nanosec, frame_id, encapsulation, offset, body)


class _Primed(NamedTuple):
    """A decoder's one-call path for the CDR_LE messages of one frame id."""

    unpack: Callable[[bytes, int], tuple[Any, ...]]
    length_and_frame: bytes
    frame_id: str
    size: int


def _primed(frame_bytes: bytes, frame_id: str, count: int, at: int, width: int,
            tail: str = '') -> _Primed:
    """Encapsulation, stamp, string length and bytes, and the fields wanted, in one call
    (``tail``: more of the ``struct`` format after them)."""
    length = len(frame_bytes)
    offset = ((_HEADER + length + 3) & -8) + 4
    unpack = Struct(f'<2s2xiI{4 + length}s{offset - _HEADER - length}x{8 * at}x{width}d{tail}')
    return _Primed(unpack.unpack_from, struct.pack('<I', length) + frame_bytes, frame_id,
                   offset + 8 * count)


def decode_header(data: bytes) -> tuple[int, int, str]:
    """``(sec, nanosec, frame_id)`` of any message that starts with a ``std_msgs/Header``.

    Only the header is checked (the body's layout depends on the type).
    """
    try:
        encapsulation, sec, nanosec, length = _LE_HEADER(data, 0)
        frame_id = _FRAMES[data[_HEADER:_HEADER + length]]
        if encapsulation == _CDR_LE:
            return sec, nanosec, frame_id
    except _FAST_ERRORS:
        pass
    parsed = parse_stamped(data, 'stamped message', 0)
    return parsed.sec, parsed.nanosec, parsed.frame_id


def body_offset(data: bytes, msgtype: str, count: int) -> tuple[int, bool]:
    """``(offset, little_endian)`` of the float64 body of a checked stamped message.

    Checked as :func:`parse_stamped` checks (:class:`MalformedMessage`); a CDR_LE message of a
    frame id seen before costs one ``struct`` call and a look-up.
    """
    try:
        encapsulation, _, _, length = _LE_HEADER(data, 0)
        end = _HEADER + length
        if encapsulation == _CDR_LE and data[_HEADER:end] in _FRAMES:
            offset = ((end + 3) & -8) + 4
            if len(data) >= offset + 8 * count:
                return offset, True
    except _FAST_ERRORS:
        pass
    parsed = parse_stamped(data, msgtype, count)
    return parsed.body_offset, parsed.encapsulation.little_endian


def _decoder(msgtype: str, count: int, at: int, width: int) -> StampedFloatsDecoder:
    """A decoder of ``(sec, nanosec, frame_id, body[at:at + width])``.

    Three paths, each taken only if the one before does not apply: one ``struct`` call for a
    CDR_LE message of the frame id seen last (:class:`_Primed`); two calls and a look-up in the
    frame ids seen; :func:`parse_stamped`. A frame id that comes twice in a row through the
    second path becomes the primed one (frame ids that alternate stay on the second path).
    """
    body_size = 8 * count
    field_at = 8 * at
    unpack = Struct(f'<{width}d').unpack_from
    header = _LE_HEADER
    frames = _FRAMES
    primed = _primed(b'\x00', '', count, at, width)
    missed = b''

    def decode_other(data: bytes) -> StampedFloats:
        """The second and third paths."""
        nonlocal primed, missed
        try:
            encapsulation, sec, nanosec, length = header(data, 0)
            end = _HEADER + length
            frame_bytes = data[_HEADER:end]
            frame_id = frames[frame_bytes]
            offset = ((end + 3) & -8) + 4
            if encapsulation == _CDR_LE and len(data) >= offset + body_size:
                if frame_bytes == missed:
                    primed = _primed(bytes(frame_bytes), frame_id, count, at, width)
                missed = frame_bytes
                return sec, nanosec, frame_id, unpack(data, offset + field_at)
        except _FAST_ERRORS:
            pass
        parsed = parse_stamped(data, msgtype, count)
        return parsed.sec, parsed.nanosec, parsed.frame_id, parsed.body[at:at + width]

    def decode_vector(data: bytes) -> StampedFloats:
        unpack_all, length_and_frame, frame_id, size = primed
        try:
            encapsulation, sec, nanosec, frame, x, y, z = unpack_all(data, 0)
            if encapsulation == b'\x00\x01' and frame == length_and_frame and len(data) >= size:
                return sec, nanosec, frame_id, (x, y, z)
        except _FAST_ERRORS:
            pass
        return decode_other(data)

    def decode_fields(data: bytes) -> StampedFloats:
        unpack_all, length_and_frame, frame_id, size = primed
        try:
            fields = unpack_all(data, 0)
            if fields[0] == b'\x00\x01' and fields[3] == length_and_frame and len(data) >= size:
                return fields[1], fields[2], frame_id, fields[4:]
        except _FAST_ERRORS:
            pass
        return decode_other(data)
    return decode_vector if width == 3 else decode_fields


decode_imu_rate = _decoder(IMU, IMU_COUNT, _IMU_RATE_AT, 3)
decode_imu_rate.__doc__ = ('``(sec, nanosec, frame_id, (ωx, ωy, ωz))`` of a '
                           '``sensor_msgs/msg/Imu``: the body-frame rate [rad/s].')
decode_vector3_stamped = _decoder(VECTOR3_STAMPED, FIXED_LAYOUTS[VECTOR3_STAMPED].count, 0, 3)
decode_vector3_stamped.__doc__ = ('``(sec, nanosec, frame_id, (x, y, z))`` of a '
                                  '``geometry_msgs/msg/Vector3Stamped``.')
decode_twist_angular = _decoder(TWIST_STAMPED, FIXED_LAYOUTS[TWIST_STAMPED].count,
                                FIXED_LAYOUTS[TWIST_STAMPED].at('twist.angular.x'), 3)
decode_twist_angular.__doc__ = ('``(sec, nanosec, frame_id, (ωx, ωy, ωz))``: the angular '
                                'velocity of a ``geometry_msgs/msg/TwistStamped`` [rad/s].')


#: A gyro sample: ``(sec, nanosec, frame_id, (ωx, ωy, ωz), (ax, ay, az) or None)``, the rate
#: [rad/s] and the specific force [m/s²] when the message provides one (an Imu), sensor frame.
RateSample = tuple[int, int, str, Floats, Floats | None]
#: A rate decoder: CDR bytes → :data:`RateSample`.
RateDecoder = Callable[[bytes], RateSample]
# After the angular velocity: its covariance (9 float64, skipped), the linear acceleration and
# the first element of its covariance (-1: not provided, REP-145).
_IMU_MOTION_TAIL = f'{8 * (_IMU_ACCELERATION_AT - _IMU_RATE_AT - 3)}x4d'


def _imu_motion_decoder() -> RateDecoder:
    """The decoder of an Imu's rate and specific force: the three paths of :func:`_decoder`
    with the acceleration read by the same ``struct`` call."""
    field_at = 8 * _IMU_RATE_AT
    unpack = Struct(f'<3d{_IMU_MOTION_TAIL}').unpack_from
    accel_at = _IMU_ACCELERATION_AT
    header = _LE_HEADER
    frames = _FRAMES
    primed = _primed(b'\x00', '', IMU_COUNT, _IMU_RATE_AT, 3, _IMU_MOTION_TAIL)
    missed = b''

    def decode_other(data: bytes) -> RateSample:
        nonlocal primed, missed
        try:
            encapsulation, sec, nanosec, length = header(data, 0)
            end = _HEADER + length
            frame_bytes = data[_HEADER:end]
            frame_id = frames[frame_bytes]
            offset = ((end + 3) & -8) + 4
            if encapsulation == _CDR_LE and len(data) >= offset + 8 * IMU_COUNT:
                if frame_bytes == missed:
                    primed = _primed(bytes(frame_bytes), frame_id, IMU_COUNT, _IMU_RATE_AT, 3,
                                     _IMU_MOTION_TAIL)
                missed = frame_bytes
                x, y, z, ax, ay, az, covariance = unpack(data, offset + field_at)
                return (sec, nanosec, frame_id, (x, y, z),
                        None if covariance == -1.0 else (ax, ay, az))
        except _FAST_ERRORS:
            pass
        parsed = parse_stamped(data, IMU, IMU_COUNT)
        body = parsed.body
        return (parsed.sec, parsed.nanosec, parsed.frame_id,
                body[_IMU_RATE_AT:_IMU_RATE_AT + 3],
                None if body[accel_at + 3] == -1.0 else body[accel_at:accel_at + 3])

    def decode_imu_motion(data: bytes) -> RateSample:
        """``(sec, nanosec, frame_id, (ωx, ωy, ωz), (ax, ay, az))`` of a
        ``sensor_msgs/msg/Imu``: rate [rad/s] and specific force [m/s²] in its frame; the
        acceleration is ``None`` when its covariance says "not provided" (element 0 is −1,
        REP-145)."""
        unpack_all, length_and_frame, frame_id, size = primed
        try:
            encapsulation, sec, nanosec, frame, x, y, z, ax, ay, az, covariance = unpack_all(
                data, 0)
            if encapsulation == b'\x00\x01' and frame == length_and_frame and len(data) >= size:
                return (sec, nanosec, frame_id, (x, y, z),
                        None if covariance == -1.0 else (ax, ay, az))
        except _FAST_ERRORS:
            pass
        return decode_other(data)
    return decode_imu_motion


decode_imu_motion = _imu_motion_decoder()


def _whole(msgtype: str) -> StampedFloatsDecoder:
    """A decoder of every float64 of a fixed-layout message."""
    count = FIXED_LAYOUTS[msgtype].count
    return _decoder(msgtype, count, 0, count)


_wrench = _whole(WRENCH_STAMPED)
_twist = _whole(TWIST_STAMPED)
_pose = _whole(POSE_STAMPED)
_pose_with_covariance = _whole(POSE_WITH_COVARIANCE_STAMPED)
_quaternion = _whole(QUATERNION_STAMPED)
_magnetic_field = _whole(MAGNETIC_FIELD)


def _without_acceleration(decode_rate: StampedFloatsDecoder) -> RateDecoder:
    """The rate decoder of a type that carries no specific force."""
    def decode(data: bytes) -> RateSample:
        sec, nanosec, frame_id, rate = decode_rate(data)
        return sec, nanosec, frame_id, rate, None
    decode.__doc__ = f'{decode_rate.__doc__} No specific force (``None``).'
    return decode


#: THE rate decoders, by gyro message type (TwistStamped: its angular part): the node's gyro
#: topics and any gyro topic of a bag are decoded through these.
RATE_DECODERS: dict[str, RateDecoder] = {
    IMU: decode_imu_motion,
    VECTOR3_STAMPED: _without_acceleration(decode_vector3_stamped),
    TWIST_STAMPED: _without_acceleration(decode_twist_angular),
}


def decode_wrench_stamped(data: bytes) -> tuple[int, int, str, Floats, Floats]:
    """``(sec, nanosec, frame_id, force, torque)`` of a ``geometry_msgs/msg/WrenchStamped``."""
    sec, nanosec, frame_id, values = _wrench(data)
    return sec, nanosec, frame_id, values[:3], values[3:]


def decode_twist_stamped(data: bytes) -> tuple[int, int, str, Floats, Floats]:
    """``(sec, nanosec, frame_id, linear, angular)`` of a ``geometry_msgs/msg/TwistStamped``."""
    sec, nanosec, frame_id, values = _twist(data)
    return sec, nanosec, frame_id, values[:3], values[3:]


def decode_pose_stamped(data: bytes) -> tuple[int, int, str, Floats, Floats]:
    """``(sec, nanosec, frame_id, position, (w, x, y, z))`` of a ``PoseStamped``."""
    sec, nanosec, frame_id, (px, py, pz, x, y, z, w) = _pose(data)
    return sec, nanosec, frame_id, (px, py, pz), (w, x, y, z)


def decode_pose_with_covariance_stamped(
        data: bytes) -> tuple[int, int, str, Floats, Floats, Floats]:
    """``(sec, nanosec, frame_id, position, (w, x, y, z), covariance)`` of a
    ``geometry_msgs/msg/PoseWithCovarianceStamped`` (covariance: the 36 row-major values)."""
    sec, nanosec, frame_id, values = _pose_with_covariance(data)
    px, py, pz, x, y, z, w = values[:7]
    return sec, nanosec, frame_id, (px, py, pz), (w, x, y, z), values[7:]


def decode_magnetic_field(data: bytes) -> tuple[int, int, str, Floats, Floats]:
    """``(sec, nanosec, frame_id, field, covariance)`` of a ``sensor_msgs/msg/MagneticField``
    (field [T], sensor frame; covariance: the 9 row-major values)."""
    sec, nanosec, frame_id, values = _magnetic_field(data)
    return sec, nanosec, frame_id, values[:3], values[3:]


def decode_quaternion_stamped(data: bytes) -> tuple[int, int, str, Floats]:
    """``(sec, nanosec, frame_id, (w, x, y, z))`` of a ``QuaternionStamped``."""
    sec, nanosec, frame_id, (x, y, z, w) = _quaternion(data)
    return sec, nanosec, frame_id, (w, x, y, z)


def decode_imu(data: bytes) -> tuple[int, int, str, Floats, Floats, Floats]:
    """``(sec, nanosec, frame_id, (w, x, y, z), ω, a)`` of a ``sensor_msgs/msg/Imu``.

    Orientation, angular velocity [rad/s] and linear acceleration [m/s²]; the covariances are
    checked for presence (they are part of the layout) and not returned.
    """
    parsed = parse_stamped(data, IMU, IMU_COUNT)
    x, y, z, w = parsed.body[:4]
    return (parsed.sec, parsed.nanosec, parsed.frame_id, (w, x, y, z),
            parsed.body[_IMU_RATE_AT:_IMU_RATE_AT + 3],
            parsed.body[_IMU_ACCELERATION_AT:_IMU_ACCELERATION_AT + 3])


def decode_float64(data: bytes) -> float:
    """The value of a ``std_msgs/msg/Float64`` (no header)."""
    try:
        encapsulation, value = _LE_FLOAT64(data, 0)
        if encapsulation == _CDR_LE:
            return float(value)
    except _FAST_ERRORS:
        pass
    raw = _bytes(data, FLOAT64)
    found = _encapsulation(raw, FLOAT64, 12)
    if len(raw) < 12:
        raise MalformedMessage(FLOAT64, f'truncated: {len(raw)} of 12 bytes')
    return float(_float64s(found.little_endian, 1)(raw, 4)[0])
