"""The node's input decoders: topic → CDR bytes → the plain values its session takes.

Each decoder returns ``(sec, nanosec, frame_id, first, second)``: the header stamp and frame
and the message's values (rate and the Imu bytes; force and torque; a vector; attitude
(w, x, y, z) and position). Bytes that are not a valid message of the topic's type raise one
of :data:`MALFORMED`; the node counts them and goes on.
"""

from __future__ import annotations

from collections.abc import Callable
import struct
from typing import Any

from rigid_body_attitude.bag import cdr
from rigid_body_attitude.bag.errors import BagError

__all__ = ['DECODERS', 'Decoded', 'MALFORMED']

#: What a decoder returns: stamp sec, stamp nanosec, frame id, two values.
Decoded = tuple[int, int, str, Any, Any]

#: The exceptions of a message that cannot be decoded.
MALFORMED: tuple[type[Exception], ...] = (BagError,)


_STAMP = {0: struct.Struct('>iI'), 1: struct.Struct('<iI')}


def _header(data: bytes) -> tuple[int, int, str]:
    """The stamp as sent (not normalised: the session judges it) and the frame id."""
    frame_id = cdr.header_frame_id(data)  # checks the encapsulation and the header's size
    sec, nanosec = _STAMP[data[1] & 1].unpack_from(data, 4)
    return sec, nanosec, frame_id


def imu(data: bytes) -> Decoded:
    """Imu: the body rate [rad/s] and the message bytes (for ``imu/data``)."""
    sec, nanosec, frame_id = _header(data)
    return sec, nanosec, frame_id, cdr.imu_rates(data)[1], data


def angular_velocity(data: bytes) -> Decoded:
    """Vector3Stamped: the body rate [rad/s]."""
    sec, nanosec, frame_id = _header(data)
    return sec, nanosec, frame_id, cdr.vector3_stamped(data)[1], None


def wrench(data: bytes) -> Decoded:
    """WrenchStamped: force [N] and torque [N m], body axes."""
    sec, nanosec, frame_id = _header(data)
    return sec, nanosec, frame_id, cdr.wrench_force(data)[1], cdr.wrench_torque(data)[1]


def pose(data: bytes) -> Decoded:
    """PoseStamped: attitude (w, x, y, z) and position [m]."""
    sec, nanosec, frame_id = _header(data)
    return sec, nanosec, frame_id, cdr.pose_orientation(data)[1], cdr.pose_position(data)[1]


DECODERS: dict[str, Callable[[bytes], Decoded]] = {
    'imu': imu, 'angular_velocity': angular_velocity, 'torque': wrench,
    'rotor_torque': angular_velocity, 'set_pose': pose,
}
