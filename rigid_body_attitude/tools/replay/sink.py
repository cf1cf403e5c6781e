"""The replay's :class:`~rigid_body_attitude.session.base.OutputSink`: the session's outputs as
CDR records in the output bag (the replay's counterpart of the node's publishers,
:mod:`rigid_body_attitude.ros.outputs`).

Each record is written at the bag time of the input or tick being handled (:attr:`BagSink.now_ns`,
which the replay sets before it calls the session), with the message the node would publish:
the same topics, types, stamps and frames. Gyro-rate outputs use the per-frame encoders of
:mod:`rigid_body_attitude.msgs.cdr` (one ``struct`` call each); records collect in a buffer that
:meth:`BagSink.flush` hands to :meth:`BagWriter.write_many`.
"""

from __future__ import annotations

import array
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.bag import BagWriter, Record
from rigid_body_attitude.msgs import (
    DiagnosticStatus, encode_diagnostic_array, encode_float64, encode_pose_stamped,
    encode_quaternion_stamped, encode_twist_stamped, encode_vector3_stamped,
    imu_with_orientation, pose_stamped_encoder, pose_with_covariance_stamped_encoder,
    quaternion_stamped_encoder)
from rigid_body_attitude.msgs.cdr import accel_with_covariance_stamped_encoder
from rigid_body_attitude.msgs.odometry import encode_odometry, odometry_encoder
from rigid_body_attitude.session.base import AccelerationEstimate, Session
from rigid_body_attitude.session.outputs import OutputSample
from rigid_body_attitude.session.reports import (
    DiagnosticReport, LEVEL_ERROR, LEVEL_WARN, body_frame_velocity)
from rigid_body_attitude.session.interface import NODE_INTERFACE
from rigid_body_attitude.session.settings import NODE_NAME
from rigid_body_attitude.session.times import NANOSECONDS_PER_SECOND
from rigid_body_attitude.session.uncertainty import pose_covariance
from rigid_body_attitude.tools.replay.truth import GroundTruthStart

__all__ = ['BagSink', 'LogHandler', 'OutputSeries']

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]
FloatArray = NDArray[np.float64]
#: Called with the bag time [ns], the level and the text of each log line of the session.
LogHandler = Callable[[int, int, str], None]

_ZERO = (0.0, 0.0, 0.0)
_DIAGNOSTICS_TOPIC = NODE_INTERFACE.endpoint('/diagnostics', 'out').name
_TF_STATIC_TOPIC = NODE_INTERFACE.endpoint('/tf_static', 'out').name
_LEVEL_NAMES = {LEVEL_WARN: 'warning', LEVEL_ERROR: 'error'}


def _int64() -> array.array[int]:
    return array.array('q')


def _float64() -> array.array[float]:
    return array.array('d')


@dataclass
class OutputSeries:
    """The published values kept in memory (for statistics, CSV and plots).

    ``attitude_*``: one row per ``orientation`` output; ``invariant_*``: one row per
    ``energy``/``angular_momentum`` output (dynamics scenes). Stamps are integer nanoseconds.
    """

    attitude_stamps_ns: array.array[int] = field(default_factory=_int64)
    attitudes: array.array[float] = field(default_factory=_float64)
    positions: array.array[float] = field(default_factory=_float64)
    invariant_stamps_ns: array.array[int] = field(default_factory=_int64)
    energies: array.array[float] = field(default_factory=_float64)
    momenta: array.array[float] = field(default_factory=_float64)

    def attitude_array(self) -> tuple[NDArray[np.int64], FloatArray, FloatArray]:
        """Stamps (ns), attitudes (N, 4) (w, x, y, z) and positions (N, 3) as arrays."""
        return (np.frombuffer(self.attitude_stamps_ns, dtype=np.int64).copy(),
                np.frombuffer(self.attitudes, dtype=np.float64).reshape(-1, 4).copy(),
                np.frombuffer(self.positions, dtype=np.float64).reshape(-1, 3).copy())

    def invariant_array(self) -> tuple[NDArray[np.int64], FloatArray, FloatArray]:
        """Stamps (ns), energies (M,) and world momenta (M, 3) as arrays."""
        return (np.frombuffer(self.invariant_stamps_ns, dtype=np.int64).copy(),
                np.frombuffer(self.energies, dtype=np.float64).copy(),
                np.frombuffer(self.momenta, dtype=np.float64).reshape(-1, 3).copy())


class BagSink:
    """Writes a session's outputs to the output bag (only the ``outputs`` selected)."""

    def __init__(self, writer: BagWriter, outputs: Mapping[str, str], keep_series: bool,
                 hardware_id: str, log: LogHandler | None = None) -> None:
        """Topics ``outputs`` (name → message type) on ``writer``; ``keep_series``: keep the
        values in memory; ``hardware_id``: the diagnostics' (the scene's name); ``log``: gets
        each log line."""
        self.writer = writer
        self.ids = {name: writer.add_topic(name, msgtype).id
                    for name, msgtype in outputs.items()}
        self.records: list[Record] = []
        #: Bag time of the input or tick being handled [ns]: the records' time.
        self.now_ns = 0
        self.use_header_stamps = True
        self.series = OutputSeries() if keep_series else None
        self.hardware_id = hardware_id
        self.log_handler = log
        self.logged: Counter[str] = Counter()
        self.counts = {name: 0 for name in outputs}
        self.attitude_outputs = 0  # gyro outputs, counted apart (the hot path)
        self.last_attitude: Quaternion | None = None
        self.last_stamp_ns: int | None = None
        #: Set with :meth:`start_from`: where and from what the attitude starts.
        self.start: GroundTruthStart | None = None
        self.session: Session | None = None
        self._aligning = False  # until the attitude was set from the ground truth
        self._orientation = self.ids.get('orientation')
        self._pose = self.ids.get('pose')
        self._imu = self.ids.get('imu/data')
        self._pose_covariance = self.ids.get('pose_with_covariance')
        self._acceleration = self.ids.get('accel/filtered')
        #: Rotation (w, x, y, z) of the IMU's frame in the body frame for ``imu/data``
        #: (:meth:`sensor_mount`; ``None``: identity).
        self.imu_mount: Quaternion | None = None
        self.orientation_covariance: tuple[float, ...] = (0.0,) * 9
        self.pose_covariance = pose_covariance(self.orientation_covariance)
        self.set_frames('world', 'base_link')

    def set_frames(self, world_frame: str, body_frame: str) -> None:
        """Frames of the world-frame outputs and of ``twist``."""
        self.world_frame, self.body_frame = world_frame, body_frame
        self.encode_orientation = quaternion_stamped_encoder(world_frame)
        self.encode_pose = pose_stamped_encoder(world_frame)
        self.encode_pose_covariance = pose_with_covariance_stamped_encoder(world_frame)
        self.encode_odom = odometry_encoder(world_frame, body_frame)
        self.encode_acceleration = accel_with_covariance_stamped_encoder(body_frame)

    def start_from(self, start: GroundTruthStart, session: Session) -> None:
        """Set ``session``'s attitude from the ground truth at the first output due."""
        self.start, self.session = start, session
        self._aligning = True

    def flush(self) -> None:
        """Write the buffered records to the bag (the buffer is emptied in place)."""
        self.writer.write_many(self.records)
        self.records.clear()

    def written(self) -> dict[str, int]:
        """Messages written per output topic."""
        counts = dict(self.counts)
        for name in ('orientation', 'pose', 'pose_with_covariance', 'imu/data'):
            if name in counts:
                counts[name] += self.attitude_outputs
        return counts

    def _write(self, topic: str, data: bytes) -> None:
        connection_id = self.ids.get(topic)
        if connection_id is not None:
            self.records.append((connection_id, self.now_ns, data))
            self.counts[topic] += 1

    # -- OutputSink -------------------------------------------------------------------------

    def attitude(self, sec: int, nanosec: int, attitude: Quaternion,
                 imu: bytes | None) -> None:
        """``orientation``, ``pose`` and (Imu input) ``imu/data`` of one gyro sample."""
        if self._aligning:
            attitude = self._started(sec * NANOSECONDS_PER_SECOND + nanosec, attitude)
        now, append = self.now_ns, self.records.append
        if self._orientation is not None:
            append((self._orientation, now, self.encode_orientation(sec, nanosec, attitude)))
        if self._pose is not None:
            append((self._pose, now, self.encode_pose(sec, nanosec, _ZERO, attitude)))
        if self._pose_covariance is not None:
            append((self._pose_covariance, now, self.encode_pose_covariance(
                sec, nanosec, _ZERO, attitude, self.pose_covariance)))
        if imu is not None and self._imu is not None:
            stamp = None if self.use_header_stamps else (sec, nanosec)  # receive time used
            append((self._imu, now, imu_with_orientation(imu, attitude, stamp,
                                                         self.orientation_covariance,
                                                         self.imu_mount)))
        self.attitude_outputs += 1
        self.last_attitude = attitude
        series = self.series
        if series is not None:
            series.attitude_stamps_ns.append(sec * NANOSECONDS_PER_SECOND + nanosec)
            series.attitudes.extend(attitude)
            series.positions.extend(_ZERO)

    def acceleration(self, sec: int, nanosec: int, estimate: AccelerationEstimate) -> None:
        """``accel/filtered`` of one filtered gyro sample (computed when written)."""
        if self._acceleration is not None:
            self.records.append((self._acceleration, self.now_ns, self.encode_acceleration(
                sec, nanosec, *estimate())))
            self.counts['accel/filtered'] += 1

    def odometry(self, sec: int, nanosec: int, attitude: Quaternion, omega_body: Vector,
                 rate_covariance: tuple[float, ...]) -> None:
        """``odom`` of one filtered gyro sample (the node's covariances)."""
        if 'odom' in self.ids:
            self._write('odom', encode_odometry(
                sec * NANOSECONDS_PER_SECOND + nanosec, self.world_frame, self.body_frame,
                _ZERO, attitude, _ZERO, omega_body, self.pose_covariance,
                pose_covariance(rate_covariance)))

    def sensor_mount(self, q_body_sensor: Quaternion | None) -> None:
        """The IMU's mount: ``imu/data`` carries the sensor frame's attitude, ``orientation``
        and the others the body's (``None``: identity, nothing composed per sample)."""
        self.imu_mount = q_body_sensor

    def attitude_covariance(self, covariance: tuple[float, ...]) -> None:
        """The attitude covariance of the following ``imu/data`` and ``pose_with_covariance``
        records (row-major 3×3 about fixed world axes [rad²])."""
        self.orientation_covariance = covariance
        self.pose_covariance = pose_covariance(covariance)

    def _started(self, stamp_ns: int, attitude: Quaternion) -> Quaternion:
        """The attitude of the output at ``stamp_ns``, from the ground truth when it is due."""
        start, session = self.start, self.session
        if start is None or session is None or not start.due(stamp_ns):
            return attitude
        start.apply(session.propagator, stamp_ns)
        self._aligning = False
        return session.tracker.attitude(session.propagator)

    def dynamics(self, sec: int, nanosec: int, sample: OutputSample,
                 velocity_body: Vector) -> None:
        """``orientation``, ``pose``, ``twist`` and ``odom`` of one dynamics tick."""
        stamp_ns = sec * NANOSECONDS_PER_SECOND + nanosec
        session = self.session
        if self._aligning and session is not None and self.start is not None and (
                self.start.due(stamp_ns)):
            self._started(stamp_ns, sample.attitude)
            sample = session.tracker.sample(session.propagator)
            velocity_body = body_frame_velocity(session.propagator)
        self._write('orientation', encode_quaternion_stamped(stamp_ns, self.world_frame,
                                                             sample.attitude))
        self._write('pose', encode_pose_stamped(stamp_ns, self.world_frame, sample.position,
                                                sample.attitude))
        self._write('twist', encode_twist_stamped(stamp_ns, self.body_frame, velocity_body,
                                                  sample.omega_body))
        if 'odom' in self.ids:
            self._write('odom', self.encode_odom(sec, nanosec, sample.position, sample.attitude,
                                                 velocity_body, sample.omega_body))
        self.last_attitude, self.last_stamp_ns = sample.attitude, stamp_ns
        if self.series is not None:
            self.series.attitude_stamps_ns.append(stamp_ns)
            self.series.attitudes.extend(sample.attitude)
            self.series.positions.extend(sample.position)

    def invariants(self, sec: int, nanosec: int, energy: float,
                   world_momentum: Vector) -> None:
        """``energy`` (Float64) and ``angular_momentum`` of a dynamics tick (stamped like the
        attitude)."""
        stamp_ns = sec * NANOSECONDS_PER_SECOND + nanosec
        self._write('energy', encode_float64(energy))
        self._write('angular_momentum', encode_vector3_stamped(stamp_ns, self.world_frame,
                                                               world_momentum))
        if self.series is not None:
            self.series.invariant_stamps_ns.append(stamp_ns)
            self.series.energies.append(energy)
            self.series.momenta.extend(world_momentum)

    def sensor_wanted(self, topic: str) -> bool:
        """Whether ``topic``, a simulated sensor's, is written to the bag."""
        return topic in self.ids

    def simulated_sensor(self, topic: str, data: bytes) -> None:
        """A simulated sensor's serialized sample on ``topic``."""
        self._write(topic, data)

    def static_transforms(self, data: bytes) -> None:
        """The simulated sensors' mounts: a serialized ``tf2_msgs/msg/TFMessage`` for
        ``/tf_static``, written when the outputs hold it (once, as the node publishes it)."""
        self._write(_TF_STATIC_TOPIC, data)

    def wheel_state(self, data: bytes) -> None:
        """``wheels/state`` of a dynamics tick (a serialized JointState)."""
        self._write('wheels/state', data)

    def diagnostics(self, report: DiagnosticReport) -> None:
        """``/diagnostics``, stamped with the bag time (the node's sim-time clock)."""
        status = DiagnosticStatus(level=report.level, name='/' + NODE_NAME,
                                  message=report.message, hardware_id=self.hardware_id,
                                  values=dict(report.values))
        self._write(_DIAGNOSTICS_TOPIC, encode_diagnostic_array(self.now_ns, '', [status]))

    def log(self, level: int, text: str) -> None:
        """Count the line by level; hand it to the log handler, if any."""
        self.logged[_LEVEL_NAMES.get(level, 'info')] += 1
        if self.log_handler is not None:
            self.log_handler(self.now_ns, level, text)
