"""The sessions' input decoders: CDR bytes → the plain values a session takes.

Shared by the node (:mod:`rigid_body_attitude.ros.node`, by topic: :data:`DECODERS`) and the
replay tool (:mod:`rigid_body_attitude.tools.replay`, by message type: :data:`RATE_DECODERS`),
so both accept and refuse exactly the same bytes. Imports no rclpy.

Each decoder returns ``(sec, nanosec, frame_id, first, second)``: the header stamp (``nanosec``
normalised into ``[0, 1e9)``) and frame and the message's values (rate and the Imu bytes;
force and torque; a vector; attitude (w, x, y, z) and position). Bytes that are not a valid
message of the topic's type raise one of :data:`MALFORMED`; the caller hands them to
:meth:`~rigid_body_attitude.session.base.Session.malformed` and goes on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rigid_body_attitude.bag import cdr
from rigid_body_attitude.bag.errors import BagError
from rigid_body_attitude.bag.msgtypes import IMU, TWIST_STAMPED, VECTOR3_STAMPED

__all__ = ['DECODERS', 'Decoded', 'MALFORMED', 'RATE_DECODERS']

#: What a decoder returns: stamp sec, stamp nanosec, frame id, two values.
Decoded = tuple[int, int, str, Any, Any]

#: The exceptions of a message that cannot be decoded.
MALFORMED: tuple[type[Exception], ...] = (BagError,)

_NS_PER_S = 1_000_000_000


def _header(data: bytes) -> tuple[int, int, str]:
    sec, nanosec = divmod(cdr.header_stamp_ns(data), _NS_PER_S)
    return sec, nanosec, cdr.header_frame_id(data)


def _rate_decoder(msgtype: str, keep_bytes: bool) -> Callable[[bytes], Decoded]:
    """A gyro decoder: header stamp, size check and rate in one pass, then the frame id."""
    sample, frame_id = cdr.RATE_SAMPLE_DECODERS[msgtype], cdr.header_frame_id

    def decode(data: bytes) -> Decoded:
        sec, nanosec, rate = sample(data)
        if nanosec >= _NS_PER_S:
            sec, nanosec = divmod(sec * _NS_PER_S + nanosec, _NS_PER_S)
        return sec, nanosec, frame_id(data), rate, data if keep_bytes else None
    return decode


#: Imu: the body rate [rad/s] and the message bytes (for ``imu/data``).
imu = _rate_decoder(IMU, keep_bytes=True)
#: Vector3Stamped: the body rate [rad/s] (or a rotor torque [N m]).
angular_velocity = _rate_decoder(VECTOR3_STAMPED, keep_bytes=False)
#: TwistStamped: the angular part as the body rate [rad/s] (replay input only).
twist_rate = _rate_decoder(TWIST_STAMPED, keep_bytes=False)


def wrench(data: bytes) -> Decoded:
    """WrenchStamped: force [N] and torque [N m], body axes."""
    sec, nanosec, frame_id = _header(data)
    return sec, nanosec, frame_id, cdr.wrench_force(data)[1], cdr.wrench_torque(data)[1]


def pose(data: bytes) -> Decoded:
    """PoseStamped: attitude (w, x, y, z) and position [m]."""
    sec, nanosec, frame_id = _header(data)
    return sec, nanosec, frame_id, cdr.pose_orientation(data)[1], cdr.pose_position(data)[1]


#: The node's input topics → decoder.
DECODERS: dict[str, Callable[[bytes], Decoded]] = {
    'imu': imu, 'angular_velocity': angular_velocity, 'torque': wrench,
    'rotor_torque': angular_velocity, 'set_pose': pose,
}
#: Gyro message types → decoder (the replay tool's gyro topic may carry any of them).
RATE_DECODERS: dict[str, Callable[[bytes], Decoded]] = {
    IMU: imu, VECTOR3_STAMPED: angular_velocity, TWIST_STAMPED: twist_rate,
}
