"""Hand-written CDR codecs for the fixed-layout messages read and written once per sample.

``rosbags``' generic ``deserialize_cdr``/``serialize_cdr`` build full message objects; the
node and the replay tool read and write a message per sample, so the per-sample fields are read
and written here with precompiled ``struct`` calls (``test/msgs/test_cdr.py`` proves byte
equality with ``rosbags``' serialiser for every message type and frame-id padding).

Decoding is done, and every byte checked, by :mod:`rigid_body_attitude.msgs.decoders` (what is
taken and refused, and why, is stated there); every decoder here raises
:class:`~rigid_body_attitude.msgs.errors.MalformedMessage` and nothing else for bad bytes. The
functions here are the float-stamp forms used by bag readers: ``(stamp_s, values)`` with
``stamp_s = sec + nanosec·10⁻⁹``.

Encoders write OMG CDR / XCDR1 little-endian (``00 01 00 00``), as ROS 2 and ``rosbags`` do:
``std_msgs/msg/Header`` is ``int32 sec`` at payload offset 0, ``uint32 nanosec`` at 4,
``uint32 n`` at 8 (frame-id bytes including the terminating NUL) and the frame id at 12; the
float64 body follows at the next multiple of 8.

Quaternions: decoders return and encoders take **scalar-first** ``(w, x, y, z)``; the message
order is ``(x, y, z, w)``. This is :func:`rigid_body_attitude.core.attitude.quaternion.to_ros` /
:func:`~rigid_body_attitude.core.attitude.quaternion.from_ros` done inside the ``struct`` argument
list,
because the NumPy versions cost microseconds per call (the tests check the codecs against
them). Encoders take integer nanoseconds. Encoders do not check finiteness (fault-injection
bags need NaN values); :func:`rigid_body_attitude.bag.write_bag` does.

Per-sample fast paths of the node and the replay tool: the gyro decoders of
:mod:`rigid_body_attitude.msgs.decoders` read the header stamp as integers ``(sec, nanosec)``,
the frame id and the rate in one pass; :func:`quaternion_stamped_encoder`
and :func:`pose_stamped_encoder` precompute the header bytes of one frame id (one ``struct``
call per message); :func:`imu_with_orientation` splices the orientation into an Imu's bytes.
They give the bytes of the general functions (tested).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence
from struct import Struct

from rigid_body_attitude.msgs.decoders import (
    IMU_COUNT,
    Floats,
    body_offset,
    decode_float64,
    decode_header,
    decode_imu,
    decode_imu_rate,
    decode_pose_stamped,
    decode_quaternion_stamped,
    decode_twist_angular,
    decode_twist_stamped,
    decode_vector3_stamped,
    decode_wrench_stamped,
)
from rigid_body_attitude.msgs.types import (
    IMU,
    POSE_STAMPED,
    QUATERNION_STAMPED,
    VECTOR3_STAMPED,
    WRENCH_STAMPED,
)
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.attitude.quaternion import multiply_floats

__all__ = [
    'ATTITUDE_DECODERS',
    'TORQUE_DECODERS',
    'Decoder',
    'encode_clock',
    'encode_float64',
    'encode_imu',
    'encode_pose_stamped',
    'encode_pose_with_covariance_stamped',
    'encode_quaternion_stamped',
    'encode_twist_stamped',
    'encode_vector3_stamped',
    'encode_wrench_stamped',
    'UNKNOWN_ANGULAR_ACCELERATION_VARIANCE',
    'accel_with_covariance_stamped_encoder',
    'encode_magnetic_field',
    'float64_value',
    'header_frame_id',
    'header_stamp_ns',
    'imu_acceleration',
    'imu_rates',
    'imu_with_orientation',
    'pose_orientation',
    'pose_position',
    'pose_stamped_encoder',
    'pose_with_covariance_stamped_encoder',
    'quaternion_stamped',
    'quaternion_stamped_encoder',
    'stamp_to_ns',
    'stamped_floats_encoder',
    'transform_encoder',
    'twist_angular',
    'twist_linear',
    'vector3_stamped',
    'wrench_force',
    'wrench_torque',
]

#: A decoder maps CDR bytes to ``(stamp_seconds, values)``.
Decoder = Callable[[bytes], tuple[float, Floats]]
#: A sample decoder maps CDR bytes to ``(sec, nanosec, values)`` (the header stamp as is).

_NS_PER_S = 1_000_000_000
_ENCAPSULATION_LE = b'\x00\x01\x00\x00'

#: REP-145: covariance[0] = −1 marks a field the sensor does not provide; all zeros = unknown.
_NOT_PROVIDED = (-1.0,) + (0.0,) * 8
_UNKNOWN_COVARIANCE = (0.0,) * 9
_IDENTITY_XYZW = (0.0, 0.0, 0.0, 1.0)
_ZERO_VECTOR = (0.0, 0.0, 0.0)


def _stamp(sec: int, nanosec: int) -> float:
    return sec + nanosec * 1e-9


def header_stamp_ns(data: bytes) -> int:
    """Header stamp of any ``std_msgs/msg/Header``-first message, in integer nanoseconds."""
    sec, nanosec, _ = decode_header(data)
    return sec * _NS_PER_S + nanosec


def header_frame_id(data: bytes) -> str:
    """Header frame id of any ``std_msgs/msg/Header``-first message."""
    return decode_header(data)[2]


def imu_rates(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, (ωx, ωy, ωz))`` of a ``sensor_msgs/msg/Imu``: body-frame rate, rad/s."""
    sec, nanosec, _, rate = decode_imu_rate(data)
    return _stamp(sec, nanosec), rate


def imu_acceleration(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, (ax, ay, az))`` of a ``sensor_msgs/msg/Imu``: specific force, m/s²."""
    sec, nanosec, _, _, _, acceleration = decode_imu(data)
    return _stamp(sec, nanosec), acceleration


def vector3_stamped(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, (x, y, z))`` of a ``geometry_msgs/msg/Vector3Stamped``."""
    sec, nanosec, _, vector = decode_vector3_stamped(data)
    return _stamp(sec, nanosec), vector


def wrench_force(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, force)`` of a ``geometry_msgs/msg/WrenchStamped`` (N)."""
    sec, nanosec, _, force, _ = decode_wrench_stamped(data)
    return _stamp(sec, nanosec), force


def wrench_torque(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, torque)`` of a ``geometry_msgs/msg/WrenchStamped`` (N m)."""
    sec, nanosec, _, _, torque = decode_wrench_stamped(data)
    return _stamp(sec, nanosec), torque


def twist_linear(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, linear velocity)`` of a ``geometry_msgs/msg/TwistStamped`` (m/s)."""
    sec, nanosec, _, linear, _ = decode_twist_stamped(data)
    return _stamp(sec, nanosec), linear


def twist_angular(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, angular velocity)`` of a ``geometry_msgs/msg/TwistStamped`` (rad/s)."""
    sec, nanosec, _, angular = decode_twist_angular(data)
    return _stamp(sec, nanosec), angular


def quaternion_stamped(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, (w, x, y, z))`` of a ``geometry_msgs/msg/QuaternionStamped``."""
    sec, nanosec, _, attitude = decode_quaternion_stamped(data)
    return _stamp(sec, nanosec), attitude


def pose_orientation(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, (w, x, y, z))`` orientation of a ``geometry_msgs/msg/PoseStamped``."""
    sec, nanosec, _, _, attitude = decode_pose_stamped(data)
    return _stamp(sec, nanosec), attitude


def pose_position(data: bytes) -> tuple[float, Floats]:
    """``(stamp_s, (x, y, z))`` position of a ``geometry_msgs/msg/PoseStamped`` (m)."""
    sec, nanosec, _, position, _ = decode_pose_stamped(data)
    return _stamp(sec, nanosec), position


def float64_value(data: bytes) -> float:
    """The value of a ``std_msgs/msg/Float64`` (no header, so no stamp)."""
    return decode_float64(data)


#: Decoders of a body-frame torque, by message type.
TORQUE_DECODERS: dict[str, Decoder] = {
    WRENCH_STAMPED: wrench_torque,
    VECTOR3_STAMPED: vector3_stamped,
}
#: Decoders of an attitude (scalar-first, body → world), by message type.
ATTITUDE_DECODERS: dict[str, Decoder] = {
    QUATERNION_STAMPED: quaternion_stamped,
    POSE_STAMPED: pose_orientation,
}


def stamp_to_ns(stamp_s: float) -> int:
    """Seconds (float) → integer nanoseconds, rounding the fractional part only.

    Splitting off the whole seconds first keeps the full float resolution of epoch-scale
    stamps (``round(t·10⁹)`` would first round the product to 256 ns near 1.7·10⁹ s).
    """
    whole = math.floor(stamp_s)
    return whole * _NS_PER_S + round((stamp_s - whole) * _NS_PER_S)


_IMU_ORIENTATION = {True: Struct('<4d9d'), False: Struct('>4d9d')}  # quaternion, covariance
_IMU_ORIENTATION_SIZE = 13 * 8


def imu_with_orientation(data: bytes, attitude: Sequence[float],
                         stamp: tuple[int, int] | None = None,
                         covariance: Sequence[float] = _UNKNOWN_COVARIANCE,
                         mount: Sequence[float] | None = None) -> bytes:
    """The ``sensor_msgs/msg/Imu`` ``data`` with orientation ``(w, x, y, z)`` and its covariance.

    What the node publishes on ``imu/data``: the input message with the propagated attitude
    and ``covariance`` (9 row-major values, rad², about fixed world axes; default all zero,
    REP-145's "unknown"), and with the header stamp ``stamp``
    ``(sec, nanosec)`` when given (the receive time the node used instead of the message's);
    everything else, the encapsulation and byte order included, as it came. With ``mount``,
    the rotation ``q_body_sensor`` of the message's frame in the body frame, the orientation
    written is the sensor frame's, ``attitude ⊗ mount`` (REP-145: the orientation of the
    header's frame; its rates and accelerations stay in that frame too). ``covariance`` is
    written as given: a constant mount moves no world axis, so the error about fixed world
    axes of the sensor's orientation is the body's. ``data`` is checked as
    :func:`~rigid_body_attitude.msgs.decoders.decode_imu` checks it
    (:class:`~rigid_body_attitude.msgs.errors.MalformedMessage`).
    """
    offset, little_endian = body_offset(data, IMU, IMU_COUNT)
    w, x, y, z = attitude if mount is None else multiply_floats(attitude, mount)
    orientation = _IMU_ORIENTATION[little_endian].pack(x, y, z, w, *covariance)
    head = data[:offset]
    if stamp is not None:
        head = _STAMP[little_endian].pack(*stamp).join((head[:4], head[12:]))
    return b''.join((head, orientation, data[offset + _IMU_ORIENTATION_SIZE:]))


_STAMP = {False: Struct('>iI'), True: Struct('<iI')}  # header stamp, by byte order
_PACKERS: dict[tuple[str, int], tuple[Struct, bytes]] = {}
_MAX_PACKERS = 256


def _frame_bytes(frame_id: str) -> bytes:
    """The CDR string bytes of ``frame_id`` (UTF-8 and the terminating NUL)."""
    if not isinstance(frame_id, str) or '\x00' in frame_id:
        raise InputError(f'Expected `frame_id` to be a string without NUL, got {frame_id!r}')
    return frame_id.encode('utf-8') + b'\x00'


def _packer(frame_id: str, count: int) -> tuple[Struct, bytes]:
    """The struct packing encapsulation, header and ``count`` float64 for ``frame_id``."""
    packer = _PACKERS.get((frame_id, count))
    if packer is None:
        encoded = _frame_bytes(frame_id)
        padding = -(12 + len(encoded)) % 8
        packer = Struct(f'<4siII{len(encoded)}s{padding}x{count}d'), encoded
        if len(_PACKERS) >= _MAX_PACKERS:
            _PACKERS.clear()
        _PACKERS[(frame_id, count)] = packer
    return packer


def _pack(frame_id: str, stamp_ns: int, values: Sequence[float]) -> bytes:
    packer, encoded = _packer(frame_id, len(values))
    try:
        sec, nanosec = divmod(stamp_ns, _NS_PER_S)
        return packer.pack(_ENCAPSULATION_LE, sec, nanosec, len(encoded), encoded, *values)
    except (struct.error, TypeError) as err:
        raise InputError(f'Expected `stamp_ns` to be an integer with seconds in int32 range and '
                         f'float values, got stamp_ns={stamp_ns!r}, values={values!r}') from err


def _vector(value: Sequence[float], name: str) -> tuple[float, ...]:
    values = tuple(value)
    if len(values) != 3:
        raise InputError(f'Expected `{name}` to have 3 components, got {value!r}')
    return values


def _ros_quaternion(value: Sequence[float], name: str) -> tuple[float, ...]:
    """Scalar-first ``(w, x, y, z)`` → message order ``(x, y, z, w)`` (as quaternion.to_ros)."""
    try:
        w, x, y, z = value
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `{name}` to be (w, x, y, z), got {value!r}') from err
    return x, y, z, w


def encode_imu(stamp_ns: int, frame_id: str, angular_velocity: Sequence[float],
               linear_acceleration: Sequence[float] | None = None,
               orientation: Sequence[float] | None = None) -> bytes:
    """CDR bytes of a ``sensor_msgs/msg/Imu``.

    Missing ``orientation`` (w, x, y, z) or ``linear_acceleration`` are written as identity /
    zero with ``covariance[0] = −1`` (REP-145: not provided); given fields get an all-zero
    (unknown) covariance, as does the angular velocity.
    """
    orientation_fields: Floats
    acceleration: Floats
    if orientation is None:
        orientation_fields, orientation_covariance = _IDENTITY_XYZW, _NOT_PROVIDED
    else:
        orientation_fields = _ros_quaternion(orientation, 'orientation')
        orientation_covariance = _UNKNOWN_COVARIANCE
    if linear_acceleration is None:
        acceleration, acceleration_covariance = _ZERO_VECTOR, _NOT_PROVIDED
    else:
        acceleration = _vector(linear_acceleration, 'linear_acceleration')
        acceleration_covariance = _UNKNOWN_COVARIANCE
    return _pack(frame_id, stamp_ns, (
        orientation_fields + orientation_covariance
        + _vector(angular_velocity, 'angular_velocity') + _UNKNOWN_COVARIANCE
        + acceleration + acceleration_covariance))


def encode_vector3_stamped(stamp_ns: int, frame_id: str, vector: Sequence[float]) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/Vector3Stamped``."""
    return _pack(frame_id, stamp_ns, _vector(vector, 'vector'))


def encode_wrench_stamped(stamp_ns: int, frame_id: str, force: Sequence[float],
                          torque: Sequence[float]) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/WrenchStamped`` (force N, torque N m)."""
    return _pack(frame_id, stamp_ns, _vector(force, 'force') + _vector(torque, 'torque'))


def encode_twist_stamped(stamp_ns: int, frame_id: str, linear: Sequence[float],
                         angular: Sequence[float]) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/TwistStamped`` (m/s, rad/s)."""
    return _pack(frame_id, stamp_ns, _vector(linear, 'linear') + _vector(angular, 'angular'))


def encode_quaternion_stamped(stamp_ns: int, frame_id: str, attitude: Sequence[float]) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/QuaternionStamped`` from ``(w, x, y, z)``."""
    return _pack(frame_id, stamp_ns, _ros_quaternion(attitude, 'attitude'))


def encode_pose_stamped(stamp_ns: int, frame_id: str, position: Sequence[float],
                        attitude: Sequence[float]) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/PoseStamped`` (position m, attitude (w, x, y, z))."""
    return _pack(frame_id, stamp_ns,
                 _vector(position, 'position') + _ros_quaternion(attitude, 'attitude'))


def _header_struct(frame_id: str, body: str) -> tuple[Callable[..., bytes], bytes]:
    """``pack`` and the constant bytes after the stamp (length, frame id, padding).

    ``pack(encapsulation, sec, nanosec, constant, *values)`` gives the message.
    """
    encoded = _frame_bytes(frame_id)
    constant = struct.pack('<I', len(encoded)) + encoded + bytes(-(12 + len(encoded)) % 8)
    return Struct(f'<4siI{len(constant)}s{body}').pack, constant


def _stamp_error(sec: int, nanosec: int) -> InputError:
    return InputError(f'Expected `sec` in int32 and `nanosec` in uint32 range, got sec={sec!r}, '
                      f'nanosec={nanosec!r}')


def quaternion_stamped_encoder(frame_id: str) -> Callable[[int, int, Sequence[float]], bytes]:
    """``encode(sec, nanosec, (w, x, y, z))``: :func:`encode_quaternion_stamped` for one frame.

    The header bytes of ``frame_id`` are packed once; each call is one ``struct`` call.
    """
    pack, constant = _header_struct(frame_id, '4d')

    def encode(sec: int, nanosec: int, attitude: Sequence[float]) -> bytes:
        w, x, y, z = attitude
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, x, y, z, w)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def pose_stamped_encoder(frame_id: str
                         ) -> Callable[[int, int, Sequence[float], Sequence[float]], bytes]:
    """``encode(sec, nanosec, position, (w, x, y, z))``: :func:`encode_pose_stamped`, one frame.

    The header bytes of ``frame_id`` are packed once; each call is one ``struct`` call.
    """
    pack, constant = _header_struct(frame_id, '7d')

    def encode(sec: int, nanosec: int, position: Sequence[float],
               attitude: Sequence[float]) -> bytes:
        px, py, pz = position
        w, x, y, z = attitude
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, px, py, pz, x, y, z, w)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def pose_with_covariance_stamped_encoder(
        frame_id: str) -> Callable[[int, int, Sequence[float], Sequence[float], Sequence[float]],
                                   bytes]:
    """``encode(sec, nanosec, position, (w, x, y, z), covariance)``: a
    ``geometry_msgs/msg/PoseWithCovarianceStamped`` of one frame (covariance: 36 row-major
    values); the header bytes of ``frame_id`` are packed once, each call is one ``struct`` call.
    """
    pack, constant = _header_struct(frame_id, '43d')

    def encode(sec: int, nanosec: int, position: Sequence[float], attitude: Sequence[float],
               covariance: Sequence[float]) -> bytes:
        px, py, pz = position
        w, x, y, z = attitude
        if len(covariance) != 36:
            raise InputError(f'Expected `covariance` to have 36 values, got {len(covariance)}')
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, px, py, pz, x, y, z, w,
                        *covariance)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def encode_pose_with_covariance_stamped(stamp_ns: int, frame_id: str,
                                        position: Sequence[float], attitude: Sequence[float],
                                        covariance: Sequence[float]) -> bytes:
    """CDR bytes of a ``geometry_msgs/msg/PoseWithCovarianceStamped`` (position m, attitude
    (w, x, y, z), covariance the 36 row-major values)."""
    values = tuple(covariance)
    if len(values) != 36:
        raise InputError(f'Expected `covariance` to have 36 values, got {len(values)}')
    return _pack(frame_id, stamp_ns, _vector(position, 'position')
                 + _ros_quaternion(attitude, 'attitude') + values)


def stamped_floats_encoder(frame_id: str, count: int
                           ) -> Callable[[int, int, Sequence[float]], bytes]:
    """``encode(sec, nanosec, values)``: a header with ``frame_id`` then ``count`` float64,
    the layout of ``Vector3Stamped`` (3: :func:`encode_vector3_stamped`) and ``TwistStamped``
    (6, linear then angular: :func:`encode_twist_stamped`).

    The header bytes of ``frame_id`` are packed once; each call is one ``struct`` call.
    """
    pack, constant = _header_struct(frame_id, f'{count}d')

    def encode(sec: int, nanosec: int, values: Sequence[float]) -> bytes:
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, *values)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


_FLOAT64_LE = Struct('<4sd')


def encode_float64(value: float) -> bytes:
    """CDR bytes of a ``std_msgs/msg/Float64``."""
    try:
        return _FLOAT64_LE.pack(_ENCAPSULATION_LE, value)
    except struct.error as err:
        raise InputError(f'Expected `value` to be a float, got {value!r}') from err


_CLOCK_LE = struct.Struct('<4siI')


def encode_clock(stamp_ns: int) -> bytes:
    """CDR bytes of a ``rosgraph_msgs/msg/Clock`` at ``stamp_ns`` (a valid ROS time)."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return _CLOCK_LE.pack(_ENCAPSULATION_LE, sec, nanosec)


def transform_encoder(parent_frame: str, child_frame: str
                      ) -> Callable[[int, int, Sequence[float]], bytes]:
    """``encode(sec, nanosec, (w, x, y, z))``: a ``tf2_msgs/msg/TFMessage`` of one
    ``geometry_msgs/msg/TransformStamped`` from ``parent_frame`` to ``child_frame`` with a zero
    translation and the rotation ``(w, x, y, z)`` (what ``/tf`` carries).

    The frames' bytes are packed once; each call is one ``struct`` call. Layout: ``uint32``
    transform count (1), the header (stamp, ``parent_frame``), ``child_frame`` at the next
    multiple of 4, translation and rotation (float64) at the next multiple of 8.
    """
    parent, child = _frame_bytes(parent_frame), _frame_bytes(child_frame)
    child_at = 16 + len(parent) + (-(16 + len(parent)) % 4)  # payload offset of its length
    end = child_at + 4 + len(child)
    constant = (struct.pack('<I', len(parent)) + parent + bytes(child_at - 16 - len(parent))
                + struct.pack('<I', len(child)) + child + bytes(-end % 8))
    pack = Struct(f'<4sIiI{len(constant)}s7d').pack

    def encode(sec: int, nanosec: int, attitude: Sequence[float]) -> bytes:
        w, x, y, z = attitude
        try:
            return pack(_ENCAPSULATION_LE, 1, sec, nanosec, constant, 0.0, 0.0, 0.0, x, y, z, w)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def encode_magnetic_field(stamp_ns: int, frame_id: str, field: Sequence[float],
                          covariance: Sequence[float] = _UNKNOWN_COVARIANCE) -> bytes:
    """CDR bytes of a ``sensor_msgs/msg/MagneticField`` (field [T], sensor frame; covariance:
    the 9 row-major values [T²], all zeros = unknown)."""
    values = tuple(covariance)
    if len(values) != 9:
        raise InputError(f'Expected `covariance` to have 9 values, got {len(values)}')
    return _pack(frame_id, stamp_ns, _vector(field, 'field') + values)


#: The angular block of an ``accel/filtered`` covariance: not estimated (REP-145 has no
#: marker for a block; a large finite variance, as the position of ``pose_with_covariance``).
UNKNOWN_ANGULAR_ACCELERATION_VARIANCE = 1e9


def accel_with_covariance_stamped_encoder(
        frame_id: str) -> Callable[[int, int, Sequence[float], Sequence[float]], bytes]:
    """``encode(sec, nanosec, linear, covariance)``: a
    ``geometry_msgs/msg/AccelWithCovarianceStamped`` of one frame with the linear acceleration
    [m/s²] and its row-major 3×3 covariance [(m/s²)²]; the angular part zero with
    :data:`UNKNOWN_ANGULAR_ACCELERATION_VARIANCE` on its diagonal. One ``struct`` call."""
    pack, constant = _header_struct(frame_id, '42d')
    unknown = UNKNOWN_ANGULAR_ACCELERATION_VARIANCE

    def encode(sec: int, nanosec: int, linear: Sequence[float],
               covariance: Sequence[float]) -> bytes:
        ax, ay, az = linear
        c = covariance
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, ax, ay, az, 0.0, 0.0, 0.0,
                        c[0], c[1], c[2], 0.0, 0.0, 0.0,
                        c[3], c[4], c[5], 0.0, 0.0, 0.0,
                        c[6], c[7], c[8], 0.0, 0.0, 0.0,
                        0.0, 0.0, 0.0, unknown, 0.0, 0.0,
                        0.0, 0.0, 0.0, 0.0, unknown, 0.0,
                        0.0, 0.0, 0.0, 0.0, 0.0, unknown)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode
