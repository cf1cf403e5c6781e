"""The sessions' inputs: CDR bytes → the plain values a session takes → the session.

Shared by the node (:mod:`rigid_body_attitude.ros.node`) and the replay tool
(:mod:`rigid_body_attitude.tools.replay`): :func:`input_handler` is the callback of one input
topic (decode, then the session method of the topic) for both, so both accept and refuse exactly
the same bytes and hand the same values to the session. Decoders by topic: :data:`DECODERS`;
by gyro message type (the replay's gyro topic may carry any of them): :data:`RATE_DECODERS`.
Built on the checked decoders of :mod:`rigid_body_attitude.msgs.decoders`; imports no rclpy
and no bag library.

Each decoder returns ``(sec, nanosec, frame_id, first, second)``: the header stamp as sent
(not normalised: the session judges it) and frame, and the message's values (force and
torque; a vector; attitude (w, x, y, z) and position, or attitude and (position,
covariance)). The gyro decoders return
``(sec, nanosec, frame_id, rate, imu, accel)`` (:data:`GyroDecoded`): the rate [rad/s], the
Imu bytes (for ``imu/data``; ``None`` for other types) and the specific force [m/s²] (``None``
unless an Imu provides it), sensor frame. Bytes that are not a valid message of the topic's
type raise one of :data:`MALFORMED`; the handler hands them to
:meth:`~rigid_body_attitude.session.base.Session.malformed` and goes on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rigid_body_attitude.msgs.decoders import (
    GYRO_DECODERS, Floats, GyroDecoder, decode_imu_motion, decode_pose_stamped,
    decode_pose_with_covariance_stamped, decode_vector3_stamped, decode_wrench_stamped)
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.types import IMU
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.imu_start import frame_refused
from rigid_body_attitude.session.settings import GYRO_TOPICS, AnySession

__all__ = ['DECODERS', 'Decoded', 'GyroDecoded', 'Handler', 'MALFORMED', 'RATE_DECODERS',
           'input_handler']

#: What a decoder returns: stamp sec, stamp nanosec, frame id, two values.
Decoded = tuple[int, int, str, Any, Any]
#: What a gyro decoder returns: stamp sec, nanosec, frame id, rate, Imu bytes, specific force.
GyroDecoded = tuple[int, int, str, Floats, bytes | None, Floats | None]

#: The callback of one input topic: takes the message's CDR bytes.
Handler = Callable[[bytes], None]

#: The exceptions of a message that cannot be decoded.
MALFORMED: tuple[type[Exception], ...] = (MalformedMessage,)


def _rate_decoder(decode_rate: GyroDecoder) -> Callable[[bytes], GyroDecoded]:
    """A gyro decoder of a type without bytes to keep or acceleration: stamp, frame, rate."""
    def decode(data: bytes) -> GyroDecoded:
        sec, nanosec, frame_id, rate = decode_rate(data)
        return sec, nanosec, frame_id, rate, None, None
    return decode


def imu(data: bytes) -> GyroDecoded:
    """Imu: the rate [rad/s], the message bytes (for ``imu/data``), the specific force."""
    sec, nanosec, frame_id, rate, accel = decode_imu_motion(data)
    return sec, nanosec, frame_id, rate, data, accel


#: Vector3Stamped: the body rate [rad/s].
angular_velocity = _rate_decoder(decode_vector3_stamped)


def vector(data: bytes) -> Decoded:
    """Vector3Stamped: a vector (a rotor torque [N m])."""
    sec, nanosec, frame_id, value = decode_vector3_stamped(data)
    return sec, nanosec, frame_id, value, None


def wrench(data: bytes) -> Decoded:
    """WrenchStamped: force [N] and torque [N m], body axes."""
    return decode_wrench_stamped(data)


def pose(data: bytes) -> Decoded:
    """PoseStamped: attitude (w, x, y, z) and position [m]."""
    sec, nanosec, frame_id, position, attitude = decode_pose_stamped(data)
    return sec, nanosec, frame_id, attitude, position


def pose_with_covariance(data: bytes) -> Decoded:
    """PoseWithCovarianceStamped: attitude (w, x, y, z) and (position [m], the 36 row-major
    covariance values)."""
    sec, nanosec, frame_id, position, attitude, covariance = (
        decode_pose_with_covariance_stamped(data))
    return sec, nanosec, frame_id, attitude, (position, covariance)


#: The node's input topics → decoder (the gyro topics': :data:`GyroDecoded`).
DECODERS: dict[str, Callable[[bytes], tuple[Any, ...]]] = {
    'imu': imu, 'angular_velocity': angular_velocity, 'torque': wrench,
    'rotor_torque': vector, 'set_pose': pose,
    'set_pose_with_covariance': pose_with_covariance,
}
#: Gyro message types → decoder (the replay tool's gyro topic may carry any of them:
#: Imu, Vector3Stamped, TwistStamped's angular part).
RATE_DECODERS: dict[str, Callable[[bytes], GyroDecoded]] = {
    msgtype: imu if msgtype == IMU else _rate_decoder(decode_rate)
    for msgtype, decode_rate in GYRO_DECODERS.items()
}


def input_handler(session: AnySession, topic: str,
                  decode: Callable[[bytes], tuple[Any, ...]] | None = None,
                  reraise: tuple[type[Exception], ...] = ()) -> Handler:
    """The callback of the node's input ``topic``: decode the bytes and hand the values to
    the session; malformed bytes and a session's own failure are counted, never raised.

    ``decode`` replaces the topic's decoder (:data:`DECODERS`) with another of the same values
    (the replay's gyro topic may carry any type of :data:`RATE_DECODERS`); exceptions of
    ``reraise`` (the adapter's own, raised by its sink) propagate instead of being counted.
    """
    if decode is None:
        decode = DECODERS[topic]
    if isinstance(session, GyroSession) and topic in GYRO_TOPICS:
        return _gyro_handler(session, topic, decode, reraise)
    deliver = _delivery(session, topic)
    decode_values = decode

    def handle(data: bytes) -> None:
        try:
            values = decode_values(data)
        except MALFORMED as err:
            session.malformed(topic, str(err)[:200])
            return
        try:
            deliver(values)
        except reraise:
            raise
        except Exception as err:  # a bug must not end the node (nor the replay): counted
            session.internal_error(topic, err)
    return handle


def _gyro_handler(session: GyroSession, topic: str, decode: Callable[[bytes], Any],
                  reraise: tuple[type[Exception], ...]) -> Handler:
    """:func:`input_handler` of a gyro topic (the hot path: one decoder call and
    ``session.gyro`` with the Imu bytes, if any, for ``imu/data``, and the specific force).
    Once the session knows its IMU's frame (``imu_frame``), samples in another frame are
    refused (``foreign_frame``: :func:`~.imu_start.frame_refused`)."""
    gyro, malformed, internal_error = session.gyro, session.malformed, session.internal_error
    topic_frames = session.topic_frames

    def handle(data: bytes) -> None:
        try:
            sec, nanosec, frame, rate, imu, accel = decode(data)
        except MALFORMED as err:
            malformed(topic, str(err)[:200])
            return
        if topic_frames.get(topic) != frame and frame_refused(session, topic, frame):
            return
        try:
            gyro(sec, nanosec, rate, imu, accel)
        except reraise:
            raise
        except Exception as err:  # a bug must not end the node (nor the replay): counted
            internal_error(topic, err)
    return handle


def _delivery(session: AnySession, topic: str) -> Callable[[Decoded], object]:
    """The session method of ``topic`` (other than the gyro topics) applied to the values."""
    if topic == 'set_pose':
        return lambda values: session.set_pose(values[2], values[3], values[4])
    if topic == 'set_pose_with_covariance':
        return lambda values: session.set_pose(values[2], values[3], *values[4])
    assert isinstance(session, DynamicsSession), topic  # commands: dynamics scenes only
    if topic == 'torque':
        return lambda values: session.wrench(values[0], values[1], values[3], values[4])
    return lambda values: session.rotor_torque(values[0], values[1], values[3])
