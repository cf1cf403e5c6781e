"""The sessions' input decoders: CDR bytes → the plain values a session takes.

Shared by the node (:mod:`rigid_body_attitude.ros.node`, by topic: :data:`DECODERS`) and the
replay tool (:mod:`rigid_body_attitude.tools.replay`, by message type: :data:`RATE_DECODERS`),
so both accept and refuse exactly the same bytes, and :func:`input_handler`, the callback of
one input topic (decode, then the session method of the topic), so both hand the same values
to the session. Built on the checked decoders of :mod:`rigid_body_attitude.bag.decoders`;
imports no rclpy.

Each decoder returns ``(sec, nanosec, frame_id, first, second)``: the header stamp as sent
(not normalised: the session judges it) and frame, and the message's values (rate and the
Imu bytes; force and torque; a vector; attitude (w, x, y, z) and position). Bytes that are
not a valid message of the topic's type raise one of :data:`MALFORMED`; the caller hands them
to :meth:`~rigid_body_attitude.session.base.Session.malformed` and goes on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rigid_body_attitude.bag.decoders import (
    GYRO_DECODERS, GyroDecoder, decode_imu_rate, decode_pose_stamped, decode_vector3_stamped,
    decode_wrench_stamped)
from rigid_body_attitude.bag.errors import MalformedMessage
from rigid_body_attitude.bag.msgtypes import IMU
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.settings import AnySession

__all__ = ['DECODERS', 'Decoded', 'MALFORMED', 'RATE_DECODERS', 'input_handler']

#: What a decoder returns: stamp sec, stamp nanosec, frame id, two values.
Decoded = tuple[int, int, str, Any, Any]

#: The exceptions of a message that cannot be decoded.
MALFORMED: tuple[type[Exception], ...] = (MalformedMessage,)


def _rate_decoder(decode_rate: GyroDecoder, keep_bytes: bool) -> Callable[[bytes], Decoded]:
    """A gyro decoder: stamp, frame id and rate (and, for Imu, the message bytes)."""
    def decode(data: bytes) -> Decoded:
        sec, nanosec, frame_id, rate = decode_rate(data)
        return sec, nanosec, frame_id, rate, data if keep_bytes else None
    return decode


#: Imu: the body rate [rad/s] and the message bytes (for ``imu/data``).
imu = _rate_decoder(decode_imu_rate, keep_bytes=True)
#: Vector3Stamped: the body rate [rad/s] (or a rotor torque [N m]).
angular_velocity = _rate_decoder(decode_vector3_stamped, keep_bytes=False)


def wrench(data: bytes) -> Decoded:
    """WrenchStamped: force [N] and torque [N m], body axes."""
    return decode_wrench_stamped(data)


def pose(data: bytes) -> Decoded:
    """PoseStamped: attitude (w, x, y, z) and position [m]."""
    sec, nanosec, frame_id, position, attitude = decode_pose_stamped(data)
    return sec, nanosec, frame_id, attitude, position


#: The node's input topics → decoder.
DECODERS: dict[str, Callable[[bytes], Decoded]] = {
    'imu': imu, 'angular_velocity': angular_velocity, 'torque': wrench,
    'rotor_torque': angular_velocity, 'set_pose': pose,
}
#: Gyro message types → decoder (the replay tool's gyro topic may carry any of them:
#: Imu, Vector3Stamped, TwistStamped's angular part).
RATE_DECODERS: dict[str, Callable[[bytes], Decoded]] = {
    msgtype: _rate_decoder(decode_rate, keep_bytes=msgtype == IMU)
    for msgtype, decode_rate in GYRO_DECODERS.items()
}


def input_handler(session: AnySession, topic: str) -> Callable[[bytes], None]:
    """The callback of the node's input ``topic``: decode the bytes and hand the values to
    the session; malformed bytes and a session's own failure are counted, never raised."""
    decode, deliver = DECODERS[topic], _delivery(session, topic)

    def handle(data: bytes) -> None:
        try:
            values = decode(data)
        except MALFORMED as err:
            session.malformed(topic, str(err)[:200])
            return
        try:
            deliver(values)
        except Exception as err:  # a bug must not end the node (nor the replay): counted
            session.internal_error(topic, err)
    return handle


def _delivery(session: AnySession, topic: str) -> Callable[[Decoded], object]:
    """The session method of ``topic`` applied to the decoded values."""
    if topic == 'set_pose':
        return lambda values: session.set_pose(values[2], values[3], values[4])
    if isinstance(session, GyroSession):
        gyro, sink = session.gyro, session.sink
        if topic == 'imu':
            def imu(values: Decoded) -> None:
                sink.current_imu = values[4]  # for imu/data
                gyro(values[0], values[1], values[3])
                sink.current_imu = None
            return imu
        return lambda values: gyro(values[0], values[1], values[3])
    assert isinstance(session, DynamicsSession), topic  # commands: dynamics scenes only
    if topic == 'torque':
        return lambda values: session.wrench(values[0], values[1], values[3], values[4])
    return lambda values: session.rotor_torque(values[0], values[1], values[3])
