"""Encoders of the simulated sensors' messages and of their mounts, for the node and the
replay tool alike (:mod:`rigid_body_attitude.session.sensors`): a ``sensor_msgs/msg/Imu``
without orientation, a ``sensor_msgs/msg/MagneticField``, a
``geometry_msgs/msg/PoseWithCovarianceStamped`` that carries an attitude only, and the
``tf2_msgs/msg/TFMessage`` of several static transforms.

Each per-sample encoder packs the header of its frame and the constant fields once and writes
a message in one ``struct`` call, as :mod:`rigid_body_attitude.msgs.cdr`'s per-frame encoders
do, with their header layout (OMG CDR little-endian; ``test/msgs/test_sensor_encoders.py``
checks every one against rclpy's serialiser).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from struct import Struct

from rigid_body_attitude.core.errors import InputError
# The header packing the per-frame encoders of cdr share.
from rigid_body_attitude.msgs.cdr import (
    _ENCAPSULATION_LE, _IDENTITY_XYZW, _NOT_PROVIDED, _STAMP, _frame_bytes, _header_struct,
    _stamp_error)

__all__ = ['attitude_with_covariance_encoder', 'encode_tf_message', 'magnetic_field_encoder',
           'simulated_imu_encoder']


def simulated_imu_encoder(frame_id: str, angular_velocity_variance: float,
                          linear_acceleration_variance: float
                          ) -> Callable[[int, int, Sequence[float], Sequence[float]], bytes]:
    """``encode(sec, nanosec, angular_velocity, linear_acceleration)``: a simulated
    ``sensor_msgs/msg/Imu`` in ``frame_id`` without orientation (``orientation_covariance[0]
    = −1``, REP-145) and with diagonal rate and acceleration covariances of the given
    per-sample variances. The header, the orientation and the covariances are packed once;
    each call is one ``struct`` call of the stamp and the six measured values."""
    _, constant = _header_struct(frame_id, '')
    fixed = Struct('<4d9d').pack(*_IDENTITY_XYZW, *_NOT_PROVIDED)
    gyro_covariance = Struct('<9d').pack(*_diagonal(angular_velocity_variance))
    acc_covariance = Struct('<9d').pack(*_diagonal(linear_acceleration_variance))
    pack = Struct(f'<4siI{len(constant) + len(fixed)}s3d{len(gyro_covariance)}s3d'
                  f'{len(acc_covariance)}s').pack
    constant += fixed

    def encode(sec: int, nanosec: int, angular_velocity: Sequence[float],
               linear_acceleration: Sequence[float]) -> bytes:
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, *angular_velocity,
                        gyro_covariance, *linear_acceleration, acc_covariance)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def magnetic_field_encoder(frame_id: str, covariance: Sequence[float]
                           ) -> Callable[[int, int, Sequence[float]], bytes]:
    """``encode(sec, nanosec, magnetic_field)``: a ``sensor_msgs/msg/MagneticField`` in
    ``frame_id`` with the field [T] given and ``magnetic_field_covariance`` the constant
    ``covariance`` (9 row-major values [T²] about the frame's axes). The header and the
    covariance are packed once; each call is one ``struct`` call of the stamp and the three
    measured values."""
    values = tuple(covariance)
    if len(values) != 9:
        raise InputError(f'Expected `covariance` to have 9 values, got {len(values)}')
    _, constant = _header_struct(frame_id, '')
    tail = Struct('<9d').pack(*values)
    pack = Struct(f'<4siI{len(constant)}s3d{len(tail)}s').pack

    def encode(sec: int, nanosec: int, magnetic_field: Sequence[float]) -> bytes:
        x, y, z = magnetic_field
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, x, y, z, tail)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def attitude_with_covariance_encoder(frame_id: str, position_variance: float
                                     ) -> Callable[[int, int, Sequence[float], Sequence[float]],
                                                   bytes]:
    """``encode(sec, nanosec, (w, x, y, z), orientation_covariance)``: a
    ``geometry_msgs/msg/PoseWithCovarianceStamped`` in ``frame_id`` that carries an attitude
    only: the position zero with ``position_variance`` [m²] on the diagonal of its block (the
    caller's mark of an unknown position), the orientation block the 9 row-major values
    given [rad²], no cross terms (:func:`encode_pose_with_covariance_stamped`'s bytes). The
    header, the position and the constant part of the covariance are packed once; each call
    is one ``struct`` call of the stamp, the quaternion and the block."""
    _, constant = _header_struct(frame_id, '')
    constant += Struct('<3d').pack(0.0, 0.0, 0.0)
    unknown = position_variance
    position_rows = Struct('<21d').pack(unknown, 0.0, 0.0, 0.0, 0.0, 0.0,
                                        0.0, unknown, 0.0, 0.0, 0.0, 0.0,
                                        0.0, 0.0, unknown, 0.0, 0.0, 0.0,
                                        0.0, 0.0, 0.0)
    gap = bytes(3 * 8)  # the cross terms between orientation and position of the next row
    pack = Struct(f'<4siI{len(constant)}s4d{len(position_rows)}s3d{len(gap)}s3d{len(gap)}s'
                  f'3d').pack

    def encode(sec: int, nanosec: int, attitude: Sequence[float],
               orientation_covariance: Sequence[float]) -> bytes:
        w, x, y, z = attitude
        a, b, c, d, e, f, g, h, i = orientation_covariance
        try:
            return pack(_ENCAPSULATION_LE, sec, nanosec, constant, x, y, z, w, position_rows,
                        a, b, c, gap, d, e, f, gap, g, h, i)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
    return encode


def encode_tf_message(sec: int, nanosec: int,
                      transforms: Sequence[tuple[str, str, Sequence[float]]]) -> bytes:
    """CDR bytes of a ``tf2_msgs/msg/TFMessage`` of ``transforms``, each ``(parent_frame,
    child_frame, (w, x, y, z))`` with a zero translation, all stamped ``(sec, nanosec)``
    (what ``/tf_static`` carries: several mounts in one message). Each field at its CDR
    alignment counted from the payload's start: the header's stamp and the two strings at a
    multiple of 4, translation and rotation (float64) at a multiple of 8."""
    payload = bytearray(struct.pack('<I', len(transforms)))
    for parent, child, rotation in transforms:
        w, x, y, z = rotation
        payload += bytes(-len(payload) % 4)
        try:
            payload += _STAMP[True].pack(sec, nanosec)
        except struct.error as err:
            raise _stamp_error(sec, nanosec) from err
        for name in (parent, child):
            encoded = _frame_bytes(name)
            payload += bytes(-len(payload) % 4) + struct.pack('<I', len(encoded)) + encoded
        payload += bytes(-len(payload) % 8) + struct.pack('<7d', 0.0, 0.0, 0.0, x, y, z, w)
    return _ENCAPSULATION_LE + bytes(payload)


def _diagonal(variance: float) -> tuple[float, ...]:
    """A row-major 3×3 covariance with ``variance`` on its diagonal."""
    return (variance, 0.0, 0.0, 0.0, variance, 0.0, 0.0, 0.0, variance)
