"""The sessions' inputs: CDR bytes → the plain values a session takes → the session.

Shared by the node (:mod:`rigid_body_attitude.ros.node`) and the replay tool
(:mod:`rigid_body_attitude.tools.replay`): :func:`input_handler` is the callback of one input
topic of :data:`~rigid_body_attitude.session.interface.NODE_INTERFACE` (decode, then the
session method of what the topic carries) for both, so both accept and refuse exactly the same
bytes and hand the same values to the session. The decoder follows from the message type: a
gyro topic's (``angular_rate``) from the one rate registry
:data:`~rigid_body_attitude.msgs.decoders.RATE_DECODERS` (the replay's gyro topic may carry
any of its types), any other input's from :data:`VALUE_DECODERS`. Built on the checked
decoders of :mod:`rigid_body_attitude.msgs.decoders`; imports no rclpy and no bag library.

Each value decoder returns ``(sec, nanosec, frame_id, first, second)``: the header stamp as
sent (not normalised: the session judges it) and frame, and the message's values (force and
torque; a vector; attitude (w, x, y, z) and position, or attitude and (position,
covariance); a JointState's names and (position, velocity, effort)). A rate decoder returns
``(sec, nanosec, frame_id, rate, accel)``
(:data:`~rigid_body_attitude.msgs.decoders.RateSample`); the handler adds an Imu's own bytes
(for ``imu/data``). Bytes that are not a valid message of the topic's type raise one of
:data:`MALFORMED`; the handler hands them to
:meth:`~rigid_body_attitude.session.base.Session.malformed` and goes on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rigid_body_attitude.msgs.decoders import (
    RATE_DECODERS, RateDecoder, decode_magnetic_field, decode_pose_stamped,
    decode_pose_with_covariance_stamped, decode_vector3_stamped, decode_wrench_stamped)
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.joint_state import decode_joint_state, JOINT_STATE
from rigid_body_attitude.msgs.types import (
    IMU, MAGNETIC_FIELD, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED, VECTOR3_STAMPED,
    WRENCH_STAMPED)
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.filtered_gyro import FilteredGyroSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.imu_start import frame_refused
from rigid_body_attitude.session.interface import Endpoint, NODE_INTERFACE
from rigid_body_attitude.session.settings import AnySession

__all__ = ['ANGULAR_RATE', 'Decoded', 'Handler', 'MALFORMED', 'VALUE_DECODERS', 'decoder',
           'input_handler']

#: What a value decoder returns: stamp sec, stamp nanosec, frame id, two values.
Decoded = tuple[int, int, str, Any, Any]

#: The callback of one input topic: takes the message's CDR bytes.
Handler = Callable[[bytes], None]

#: The exceptions of a message that cannot be decoded.
MALFORMED: tuple[type[Exception], ...] = (MalformedMessage,)

#: The quantity of the gyro inputs (decoded by the rate registry).
ANGULAR_RATE = 'angular_rate'


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


def magnetic_field(data: bytes) -> Decoded:
    """MagneticField: the field [T] and its 9 row-major covariance values."""
    return decode_magnetic_field(data)


def joint_state(data: bytes) -> Decoded:
    """JointState: the names and the (position, velocity, effort) fields."""
    values = decode_joint_state(data)
    return (values.sec, values.nanosec, values.frame_id, values.names,
            (values.position, values.velocity, values.effort))


#: Decoders of the inputs other than the gyro topics, by message type.
VALUE_DECODERS: dict[str, Callable[[bytes], Decoded]] = {
    WRENCH_STAMPED: wrench, VECTOR3_STAMPED: vector, POSE_STAMPED: pose,
    POSE_WITH_COVARIANCE_STAMPED: pose_with_covariance, MAGNETIC_FIELD: magnetic_field,
    JOINT_STATE: joint_state,
}


def decoder(topic: str, msgtype: str = '') -> Callable[[bytes], tuple[Any, ...]]:
    """The decoder of the node's input ``topic`` carrying ``msgtype`` (default: the topic's
    type in the interface)."""
    endpoint = NODE_INTERFACE.endpoint(topic)
    msgtype = msgtype or endpoint.type
    return (RATE_DECODERS if endpoint.quantity == ANGULAR_RATE else VALUE_DECODERS)[msgtype]


def input_handler(session: AnySession, topic: str, msgtype: str = '',
                  reraise: tuple[type[Exception], ...] = ()) -> Handler:
    """The callback of the node's input ``topic``: decode the bytes and hand the values to
    the session; malformed bytes and a session's own failure are counted, never raised.

    ``msgtype`` replaces the topic's message type of the interface (the replay's gyro topic
    may carry any type of :data:`~rigid_body_attitude.msgs.decoders.RATE_DECODERS`);
    exceptions of ``reraise`` (the adapter's own, raised by its sink) propagate instead of
    being counted.
    """
    endpoint = NODE_INTERFACE.endpoint(topic)
    msgtype = msgtype or endpoint.type
    if isinstance(session, GyroSession) and endpoint.quantity == ANGULAR_RATE:
        return _gyro_handler(session, topic, RATE_DECODERS[msgtype], msgtype == IMU, reraise)
    deliver = _delivery(session, endpoint)
    decode_values = VALUE_DECODERS[msgtype]

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


def _gyro_handler(session: GyroSession, topic: str, decode: RateDecoder, keep_bytes: bool,
                  reraise: tuple[type[Exception], ...]) -> Handler:
    """:func:`input_handler` of a gyro topic (the hot path: one decoder call and
    ``session.gyro`` with the Imu bytes (``keep_bytes``), for ``imu/data``, and the specific
    force). Once the session knows its IMU's frame (``imu_frame``), samples in another frame
    are refused (``foreign_frame``: :func:`~.imu_start.frame_refused`)."""
    gyro, malformed, internal_error = session.gyro, session.malformed, session.internal_error
    topic_frames = session.topic_frames

    def handle(data: bytes) -> None:
        try:
            sec, nanosec, frame, rate, accel = decode(data)
        except MALFORMED as err:
            malformed(topic, str(err)[:200])
            return
        if topic_frames.get(topic) != frame and frame_refused(session, topic, frame):
            return
        try:
            gyro(sec, nanosec, rate, data if keep_bytes else None, accel)
        except reraise:
            raise
        except Exception as err:  # a bug must not end the node (nor the replay): counted
            internal_error(topic, err)
    return handle


def _delivery(session: AnySession, endpoint: Endpoint) -> Callable[[Decoded], object]:
    """The session method of what ``endpoint`` carries (other than a gyro rate) applied to the
    values."""
    quantity = endpoint.quantity
    if quantity == 'pose':
        return lambda values: session.set_pose(values[2], values[3], values[4])
    if quantity == 'pose_with_covariance':
        return lambda values: session.set_pose(values[2], values[3], *values[4])
    if quantity == 'magnetic_field':
        assert isinstance(session, FilteredGyroSession), endpoint.name
        return lambda values: session.magnetic_field(*values[:4])
    if quantity == 'attitude_measurement':
        assert isinstance(session, FilteredGyroSession), endpoint.name
        return lambda values: session.attitude_measurement(*values[:4], values[4][1])
    assert isinstance(session, DynamicsSession), endpoint.name  # commands: dynamics scenes
    if quantity == 'wrench':
        return lambda values: session.wrench(values[0], values[1], values[3], values[4])
    if quantity == 'rotor_torque':
        return lambda values: session.rotor_torque(values[0], values[1], values[3])
    if quantity == 'dipole':
        return lambda values: session.dipole(values[0], values[1], values[3])
    if quantity == 'wheel_command':
        return lambda values: session.wheel_command(values[0], values[1], values[3],
                                                    *values[4])
    raise ValueError(f'Expected an input the session takes, got {endpoint.name!r} '
                     f'({quantity!r})')
