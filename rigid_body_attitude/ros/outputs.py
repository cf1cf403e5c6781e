"""The node's outputs: a session's :class:`~rigid_body_attitude.session.base.OutputSink` over
rclpy publishers.

Every per-sample and per-tick output (``orientation``, ``pose``, ``imu/data``; dynamics scenes:
``twist``, ``odom``, ``energy``, ``angular_momentum``) is written as CDR bytes with the header
packed once (:mod:`rigid_body_attitude.msgs.cdr`, :mod:`~rigid_body_attitude.msgs.odometry`, the
replay tool's codecs) and only while a subscription is matched (:class:`RawOutput`);
``/diagnostics`` (once a second) is an ordinary message. ``imu/data`` is the input Imu (its
frame, rates and accelerations: the sensor's, REP-145) with the stamp the session used and
the orientation of the sensor frame in ``world_frame``, the body's attitude composed with the
mount (:meth:`RosOutputs.sensor_mount`, only when a subscription is matched); its
``orientation_covariance`` is the session's attitude covariance about fixed world axes
(REP-145; the same for the sensor frame: a constant mount turns no world axis), or all zeros
(REP-145: unknown) with the parameter ``covariance`` off.
``pose_with_covariance`` carries the same attitude block in its 6×6 covariance, the position block
marked unknown (:data:`~rigid_body_attitude.session.uncertainty.UNKNOWN_POSITION_VARIANCE`). With
``publish_tf`` (:meth:`RosOutputs.enable_tf`) the attitude also goes to ``/tf`` as the transform
``world_frame`` -> ``body_frame`` (``tf2_msgs/msg/TFMessage``, CDR bytes too) at the output stamps,
at most ``tf_rate`` transforms per second of stamps. A dynamics scene with simulated sensors
publishes their samples (:meth:`RosOutputs.simulated_sensor`, each on the topic its section
names; encoded by the session only when a subscription is matched,
:meth:`RosOutputs.sensor_wanted`) and their mounts once, in one message, on ``/tf_static``
(transient local, as tf2_ros's static broadcaster: late subscribers get it). Log lines go through a
:class:`~.log_queue.LogQueue`: the session logs from the gyro path, which must never wait for a
slow console.
"""

from __future__ import annotations

import math
import time
from typing import Any

from rclpy.node import Node

from rigid_body_attitude.msgs.cdr import (
    accel_with_covariance_stamped_encoder, encode_float64, imu_with_orientation,
    pose_stamped_encoder,
    pose_with_covariance_stamped_encoder, quaternion_stamped_encoder, stamped_floats_encoder,
    transform_encoder)
from rigid_body_attitude.msgs.odometry import odometry_encoder
from rigid_body_attitude.msgs.sensor_encoders import encode_tf_message
from rigid_body_attitude.ros.diagnostics import DiagnosticsPublisher
from rigid_body_attitude.ros.interface import create_publisher
from rigid_body_attitude.ros.log_queue import LogQueue
from rigid_body_attitude.ros.rclpy_internals import raw_output
from rigid_body_attitude.session.base import AccelerationEstimate
from rigid_body_attitude.session.interface import Endpoint, NODE_INTERFACE, Situation
from rigid_body_attitude.session.outputs import OutputSample, StampRateLimiter
from rigid_body_attitude.session.reports import DiagnosticReport
from rigid_body_attitude.session.sensors import mount_transforms
from rigid_body_attitude.session.uncertainty import pose_covariance

__all__ = ['MATCH_CHECK_PERIOD', 'RawOutput', 'RosOutputs']

#: Wall seconds between two looks at an output's matched subscriptions (:meth:`RawOutput.matched`).
MATCH_CHECK_PERIOD = 0.01
_monotonic = time.monotonic

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]

_ZERO_POSITION = (0.0, 0.0, 0.0)
_UNKNOWN = (0.0,) * 9


class RawOutput:
    """An output's subscription count and CDR-bytes publish, bound once.

    On the fast path both go straight to rclpy's publisher handle, without
    :class:`rclpy.publisher.Publisher`'s per-call wrapper (it enters the handle as a context
    manager, against destruction by another thread, and checks the message type). That is
    safe here because the node's publishers are destroyed only after its raw-take loop has
    returned. Outputs are VOLATILE
    (``qos_overrides`` cannot change durability), so a sample published with no matched
    subscription reaches nobody, ever; Fast DDS would still store it. :meth:`matched` asks
    the middleware at most once every :data:`MATCH_CHECK_PERIOD` seconds (a call into rmw
    per output and message costs more than the rest of a lockstep tick's Python), and at once
    after the publisher's matched event (:meth:`of`): a subscription that matched gets every
    message from the next after the event; for at most that period after the last one left a
    message may still be handed to the middleware.
    """

    __slots__ = ('subscription_count', 'publish', '_matched', '_check_at')

    def __init__(self, publisher: Any) -> None:
        """Bind ``publisher``'s handle on the fast path, else its public methods
        (:func:`~.rclpy_internals.raw_output`)."""
        #: Matched subscriptions at the moment of the call (``int``; call it), and publish
        #: serialized (CDR) ``bytes``.
        self.subscription_count, self.publish = raw_output(publisher)
        self._matched, self._check_at = False, -math.inf

    @classmethod
    def of(cls, node: Node, endpoint: Endpoint, name: str = '') -> RawOutput:
        """The output ``endpoint`` of ``node`` (``name``: the scene's), its publisher created
        with a matched event that makes :meth:`matched` ask again at once."""
        made: list[RawOutput] = []

        def recheck() -> None:
            if made:
                made[0].recheck()
        output = cls(create_publisher(node, endpoint, name, on_matched=recheck))
        made.append(output)
        return output

    def recheck(self) -> None:
        """The next :meth:`matched` asks the middleware (any thread)."""
        self._check_at = -math.inf

    def matched(self) -> bool:
        """Whether a subscription was matched at the last look (at most
        :data:`MATCH_CHECK_PERIOD` s ago)."""
        now = _monotonic()
        if now >= self._check_at:
            self._matched = self.subscription_count() > 0
            self._check_at = now + MATCH_CHECK_PERIOD
        return self._matched

    @classmethod
    def absent(cls) -> RawOutput:
        """An output the scene does not have: no subscription ever, nothing published."""
        output = cls.__new__(cls)
        output.subscription_count, output.publish = _no_subscription, _refuse
        output._matched, output._check_at = False, math.inf
        return output


def _no_subscription() -> int:
    return 0


def _refuse(data: bytes) -> None:
    raise RuntimeError('Expected no message on an output the scene does not have')


class RosOutputs:
    """Publishers of one node and the messages they reuse; the session's sink."""

    def __init__(self, node: Node, situation: Situation) -> None:
        """Create on ``node`` the publishers of the session's outputs present in ``situation``
        (:data:`~rigid_body_attitude.session.interface.NODE_INTERFACE`)."""
        self.node = node
        self.situation = situation
        raw: dict[str, RawOutput] = {}
        for endpoint in NODE_INTERFACE.outputs(situation, ('output',)):
            raw[endpoint.name] = RawOutput.of(node, endpoint)
        #: ``/diagnostics`` (its ``hardware_id``: the scene's name, set by the node).
        self.diagnostics_publisher = DiagnosticsPublisher(node, NODE_INTERFACE)
        absent = RawOutput.absent()
        #: The session's outputs, bound once for the hot path (:meth:`RawOutput.absent` for
        #: those the scene does not have; ``pose_with_covariance``: ``None``).
        self.orientation_raw = raw.get('orientation', absent)
        self.pose_raw = raw.get('pose', absent)
        self.imu_raw = raw.get('imu/data', absent)
        self.pose_covariance_raw = raw.get('pose_with_covariance')
        self.acceleration_raw = raw.get('accel/filtered', absent)
        self.twist_raw = raw.get('twist', absent)
        self.odom_raw = raw.get('odom', absent)
        self.energy_raw = raw.get('energy', absent)
        self.momentum_raw = raw.get('angular_momentum', absent)
        self.wheel_state_raw = raw.get('wheels/state', absent)
        #: Row-major 3×3 ``imu/data`` orientation covariance and 6×6 ``pose_with_covariance``
        #: covariance (:meth:`attitude_covariance`).
        self.orientation_covariance: tuple[float, ...] = _UNKNOWN
        self.pose_covariance = pose_covariance(_UNKNOWN)
        #: The covariances the filtered ``odom`` encoder was made with (:meth:`odometry`).
        self._odom_covariances: tuple[tuple[float, ...], ...] = ()
        #: Rotation (w, x, y, z) of the IMU's frame in the body frame for ``imu/data``
        #: (:meth:`sensor_mount`; ``None``: identity).
        self.imu_mount: Quaternion | None = None
        #: Set by the session: outputs carry the inputs' stamps (else the receive time).
        self.use_header_stamps = True
        #: Frame of ``orientation``, ``pose`` and ``angular_momentum`` (:meth:`set_frames`).
        self.world_frame = ''
        #: Frame of ``twist`` and ``odom``'s child frame (:meth:`set_frames`).
        self.body_frame = ''
        #: ``/tf`` (:meth:`enable_tf`), or None.
        self.tf_raw: RawOutput | None = None
        self.tf_limiter = StampRateLimiter(0.0)
        #: Where :meth:`log` puts its lines (started by the node).
        self.log_queue = LogQueue(node.get_logger())
        #: Simulated sensors' publishers by topic (:meth:`enable_simulated_sensors`).
        self.simulated_sensors: dict[str, RawOutput] = {}

    def enable_simulated_sensors(self, body_frame: str) -> None:
        """Publish the scene's simulated sensors' samples on the topics the scene names and,
        when the interface has it, their mounts as static transforms ``body_frame`` ->
        ``frame_id`` on ``/tf_static`` (one message, once, stamped with the node clock)."""
        scene = self.situation.scene
        for endpoint in NODE_INTERFACE.outputs(self.situation, ('simulated_sensor',)):
            topic = endpoint.topic(scene)
            self.simulated_sensors[topic] = RawOutput.of(self.node, endpoint, topic)
        for endpoint in NODE_INTERFACE.outputs(self.situation, ('tf_static',)):
            self.tf_static = create_publisher(self.node, endpoint)
            sec, nanosec = self.node.get_clock().now().seconds_nanoseconds()
            RawOutput(self.tf_static).publish(
                encode_tf_message(sec, nanosec, mount_transforms(scene, body_frame)))

    def enable_tf(self, tf_rate: float) -> None:
        """Publish ``world_frame`` -> ``body_frame`` on ``/tf`` when the interface has it, at
        most ``tf_rate`` per second of stamps (0: with every output)."""
        for endpoint in NODE_INTERFACE.outputs(self.situation, ('tf',)):
            self.tf_raw = RawOutput.of(self.node, endpoint)
        self.tf_limiter = StampRateLimiter(tf_rate)

    def _publish_tf(self, sec: int, nanosec: int, attitude: Quaternion) -> None:
        """The transform at ``(sec, nanosec)`` if one is due (:class:`StampRateLimiter`)."""
        tf = self.tf_raw
        if (tf is not None and tf.matched()
                and self.tf_limiter.due(sec * 1_000_000_000 + nanosec)):
            tf.publish(self.encode_tf(sec, nanosec, attitude))

    def set_frames(self, world_frame: str, body_frame: str) -> None:
        """Frames of the world-frame outputs and of ``twist``."""
        self.world_frame, self.body_frame = world_frame, body_frame
        self.encode_orientation = quaternion_stamped_encoder(world_frame)
        self.encode_pose = pose_stamped_encoder(world_frame)
        self.encode_pose_covariance = pose_with_covariance_stamped_encoder(world_frame)
        self.encode_momentum = stamped_floats_encoder(world_frame, 3)
        self.encode_twist = stamped_floats_encoder(body_frame, 6)
        self.encode_odom = odometry_encoder(world_frame, body_frame)
        self.encode_tf = transform_encoder(world_frame, body_frame)
        self.encode_acceleration = accel_with_covariance_stamped_encoder(body_frame)

    # -- OutputSink -------------------------------------------------------------------------

    def attitude(self, sec: int, nanosec: int, attitude: Quaternion,
                 imu: bytes | None) -> None:
        """``orientation``, ``pose`` and (Imu input) ``imu/data`` of one gyro sample."""
        orientation, pose = self.orientation_raw, self.pose_raw
        if orientation.matched():
            orientation.publish(self.encode_orientation(sec, nanosec, attitude))
        if pose.matched():
            pose.publish(self.encode_pose(sec, nanosec, _ZERO_POSITION, attitude))
        if imu is not None and self.imu_raw.matched():
            stamp = None if self.use_header_stamps else (sec, nanosec)  # receive time used
            self.imu_raw.publish(imu_with_orientation(imu, attitude, stamp,
                                                      self.orientation_covariance,
                                                      self.imu_mount))
        with_covariance = self.pose_covariance_raw
        if with_covariance is not None and with_covariance.matched():
            with_covariance.publish(self.encode_pose_covariance(
                sec, nanosec, _ZERO_POSITION, attitude, self.pose_covariance))
        if self.tf_raw is not None:
            self._publish_tf(sec, nanosec, attitude)

    def acceleration(self, sec: int, nanosec: int, estimate: AccelerationEstimate) -> None:
        """``accel/filtered`` of one filtered gyro sample (computed when subscribed)."""
        output = self.acceleration_raw
        if output.subscription_count():
            output.publish(self.encode_acceleration(sec, nanosec, *estimate()))

    def odometry(self, sec: int, nanosec: int, attitude: Quaternion, omega_body: Vector,
                 rate_covariance: tuple[float, ...]) -> None:
        """``odom`` of one filtered gyro sample: the pose covariance of
        ``pose_with_covariance``, the twist's angular block ``rate_covariance`` (its linear
        block marked unknown, as the position); the encoder is made again when they change."""
        odom = self.odom_raw
        if not odom.matched():
            return
        covariances = (self.pose_covariance, rate_covariance)
        if covariances != self._odom_covariances:
            self._odom_covariances = covariances
            self._encode_filtered_odom = odometry_encoder(
                self.world_frame, self.body_frame, self.pose_covariance,
                pose_covariance(rate_covariance))
        odom.publish(self._encode_filtered_odom(sec, nanosec, _ZERO_POSITION, attitude,
                                                _ZERO_POSITION, omega_body))

    def sensor_mount(self, q_body_sensor: Quaternion | None) -> None:
        """The IMU's mount: ``imu/data`` carries the sensor frame's attitude, ``orientation``
        and the others the body's (``None``: identity, nothing composed per sample)."""
        self.imu_mount = q_body_sensor

    def attitude_covariance(self, covariance: tuple[float, ...]) -> None:
        """The attitude covariance of the following ``imu/data`` and ``pose_with_covariance``
        messages (row-major 3×3 about fixed world axes [rad²])."""
        self.orientation_covariance = covariance
        self.pose_covariance = pose_covariance(covariance)

    def dynamics(self, sec: int, nanosec: int, sample: OutputSample,
                 velocity_body: Vector) -> None:
        """``orientation``, ``pose``, ``twist`` and ``odom`` of one dynamics tick."""
        orientation, pose, twist = self.orientation_raw, self.pose_raw, self.twist_raw
        odom = self.odom_raw
        if odom.matched():
            odom.publish(self.encode_odom(sec, nanosec, sample.position, sample.attitude,
                                          velocity_body, sample.omega_body))
        if orientation.matched():
            orientation.publish(self.encode_orientation(sec, nanosec, sample.attitude))
        if pose.matched():
            pose.publish(self.encode_pose(sec, nanosec, sample.position, sample.attitude))
        if twist.matched():
            twist.publish(self.encode_twist(sec, nanosec, velocity_body + sample.omega_body))
        if self.tf_raw is not None:
            self._publish_tf(sec, nanosec, sample.attitude)

    def invariants(self, sec: int, nanosec: int, energy: float,
                   world_momentum: Vector) -> None:
        """``energy`` and ``angular_momentum`` of a dynamics tick (stamped like the
        attitude)."""
        if self.energy_raw.matched():
            self.energy_raw.publish(encode_float64(energy))
        if self.momentum_raw.matched():
            self.momentum_raw.publish(self.encode_momentum(sec, nanosec, world_momentum))

    def sensor_wanted(self, topic: str) -> bool:
        """Whether ``topic``, a simulated sensor's, has a matched subscription."""
        output = self.simulated_sensors.get(topic)
        return output is not None and output.matched()

    def simulated_sensor(self, topic: str, data: bytes) -> None:
        """A simulated sensor's serialized sample on ``topic``."""
        output = self.simulated_sensors.get(topic)
        if output is not None:
            output.publish(data)

    def wheel_state(self, data: bytes) -> None:
        """``wheels/state`` of a dynamics tick (a serialized JointState)."""
        if self.wheel_state_raw.matched():
            self.wheel_state_raw.publish(data)

    def diagnostics(self, report: DiagnosticReport) -> None:
        """``/diagnostics``, stamped with the node clock."""
        self.diagnostics_publisher.publish(report)

    def log(self, level: int, text: str) -> None:
        """A line for the node's logger, queued (:class:`~.log_queue.LogQueue`): never
        blocks."""
        self.log_queue.put(level, text)
