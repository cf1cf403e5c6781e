"""The gyro session of a scene with an ``estimation:`` section: strapdown plus the filter.

:class:`FilteredGyroSession` is :class:`~rigid_body_attitude.session.gyro.GyroSession` (the
same stamps, levelling, mount, calibration and stream rules) whose every integrated step also
goes to the filter (:class:`~rigid_body_attitude.session.estimation.Estimation`): the
attitude an update corrects replaces the propagated one, the gyro bias it estimates is
subtracted from the next samples, and the covariance published with ``imu/data`` and
``pose_with_covariance`` is the filter's. Two more inputs reach it:

* ``imu/mag`` (:meth:`FilteredGyroSession.magnetic_field`): the field [T] in its sensor frame,
  whose mount is the IMU's when the frames match, none in ``body_frame`` (or an empty frame),
  else the static transform the adapter knows (:attr:`FilteredGyroSession.frame_mount`);
* ``attitude_measurement`` (:meth:`FilteredGyroSession.attitude_measurement`): an attitude in
  ``world_frame`` with its covariance, fused at the gyro state of its stamp, in stamp order
  with the gyro samples (:mod:`~rigid_body_attitude.session.attitude_input`; a stamp further
  than ``max_dt`` from the latest gyro sample is refused: ``stale_measurement``); with
  ``estimation: {start: attitude_measurement}`` the first one starts the filter.

Each sample's gravity-free acceleration goes to the sink with the attitude
(:meth:`~rigid_body_attitude.session.base.OutputSink.acceleration`, ``accel/filtered``), and
its attitude and corrected body rate with their covariances
(:meth:`~rigid_body_attitude.session.base.OutputSink.odometry`, ``odom``).
Refusals are counted by reason and warned about like every other input's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from functools import partial
from typing import Any, cast

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.core.estimation.alignment import ALIGNING
from rigid_body_attitude.core.estimation.magnetometer import MagnetometerCalibration
from rigid_body_attitude.core.estimation.magnetometer_file import (
    MagnetometerFile, load_magnetometer_calibration)
from rigid_body_attitude.core.estimation.rest import SPECIFIC_FORCE_LIMIT
from rigid_body_attitude.msgs.untrusted import quoted
from rigid_body_attitude.session.attitude_input import (
    AttitudeInput, AttitudeMeasurements, MEASUREMENT_QUEUE)
from rigid_body_attitude.session.base import OutputSink
from rigid_body_attitude.session.estimation import STANDARD_GRAVITY, build_estimation
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.levelling import FROM_SCENE, AlignmentResult, SampleMap
from rigid_body_attitude.session.reports import DiagnosticReport, LEVEL_WARN
from rigid_body_attitude.session.stream import Outcome
from rigid_body_attitude.session.times import NANOSECONDS_PER_SECOND, split_ns, to_ns
from rigid_body_attitude.session.uncertainty import (
    CALIBRATION_KEYS, attitude_stddev_deg, error_model_from)

__all__ = ['CALIBRATION_SETTINGS', 'FILTER_CALIBRATION_KEYS', 'FILTER_REJECTION_KEYS',
           'FilteredGyroSession', 'mapped_force', 'specific_force_map']

Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]
_FORCE_LIMIT_SQUARED = SPECIFIC_FORCE_LIMIT * SPECIFIC_FORCE_LIMIT
#: Figures of the calibration file that go into the filter's error budget beside
#: :data:`~rigid_body_attitude.session.uncertainty.CALIBRATION_KEYS` (the accelerometer's)...
FILTER_CALIBRATION_KEYS = ('accelerometer_noise_density', 'accelerometer_bias_stddev')
#: ... and those that go into its settings (the accelerometer's full scale, the 1σ of the
#: instant a sample represents).
CALIBRATION_SETTINGS = ('accelerometer_range', 'sample_timing')
_DETAIL = {
    'magnetometer_no_mount': 'a field in a frame without a known mount (publish the '
                             'transform body_frame -> its frame on /tf_static)',
    'magnetometer_stale_stamp': 'a field stamp not newer than the last one',
    'magnetometer_out_of_range': 'a zero field or one above 0.01 T',
    'magnetometer_invalid_stamp': 'a zero or invalid header stamp',
    'non_finite': 'a non-finite value (NaN or Inf)',
    'wrong_frame': 'a frame other than world_frame',
    'invalid_pose': 'a zero quaternion',
    'invalid_covariance': 'an orientation covariance that is not a covariance',
    'not_started': 'the filter has not started (levelling)',
    'stale_measurement': 'a stamp further than max_dt from the latest gyro sample',
    'stale_stamp': 'a stamp not newer than the last measurement',
    'queue_full': f'more than {MEASUREMENT_QUEUE} measurements ahead of the gyro; the oldest '
                  f'dropped',
}


#: The filter's own input rejections, as ``/diagnostics`` lists them (``rejected <key>``).
FILTER_REJECTION_KEYS = (
    'magnetometer_non_finite', 'magnetometer_out_of_range', 'magnetometer_no_mount',
    'magnetometer_invalid_stamp', 'magnetometer_stale_stamp',
    *(f'attitude_measurement_{reason}' for reason in (
        'wrong_frame', 'non_finite', 'invalid_pose', 'invalid_covariance', 'not_started',
        'stale_measurement', 'stale_stamp', 'queue_full')))


class FilteredGyroSession(AttitudeInput, GyroSession):
    """A gyro session with the attitude filter (module docstring)."""

    #: The mount the specific force's map was made for, and the map (12 floats).
    _accel_mount: Quat | None = None
    _accel_affine: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)

    def __init__(self, scene: Scene, values: Mapping[str, Any], sink: OutputSink,
                 clock_ns: Callable[[], int], monotonic: Callable[[], float]) -> None:
        """The gyro session of ``scene`` and its filter (the scene's ``estimation``)."""
        spec = scene.estimation
        assert spec is not None
        path = values['magnetometer_calibration_file']
        magnetometer = load_magnetometer_calibration(path) if path else MagnetometerFile(
            MagnetometerCalibration(), {})
        super().__init__(scene, values, sink, clock_ns, monotonic)
        noise = self.calibration_noise()
        model = error_model_from(values, noise, CALIBRATION_KEYS + FILTER_CALIBRATION_KEYS)
        walk = noise.get('accelerometer_random_walk', values['accelerometer_random_walk'])
        self.estimation = build_estimation(
            spec, {**values, 'accelerometer_random_walk': walk}, model, magnetometer,
            {key: noise[key] for key in CALIBRATION_SETTINGS if key in noise})
        self.uncertainty = None
        self.wants_steps = True
        self.on_aligned = self._filter_aligned
        if self.levelling is not None:
            self.levelling.refine_bias_at_rest = False  # the filter's zero-rate update does
        #: The mount (w, x, y, z) of a frame into ``body_frame`` from the static transforms
        #: (the adapter's; None: unknown).
        self.frame_mount: Callable[[str], Quat | None] = lambda frame: None
        self.estimation_inputs = 0
        self._sample_ns = 0
        self._force: Vec | None = None
        self.measurements = AttitudeMeasurements()
        #: Whether the filter starts at the first attitude measurement (the section's start).
        self.starts_from_attitude = spec.start == 'attitude_measurement'

    def apply(self, values: Mapping[str, Any]) -> None:
        """Take the run-time parameters (and ``set_pose_stddev``, ``tilt_stddev_warn``)."""
        super().apply(values)
        self.measurement_period_ns = round(values['attitude_measurement_period'] * 1e9)
        self.set_pose_stddev: float = values['set_pose_stddev']
        self.tilt_stddev_warn: float = values['tilt_stddev_warn']

    def _update_paths(self) -> None:
        """The hot path's maps: the rate's, and the specific force's ``R N`` and
        ``−R N b_a`` (mount and calibration: recomputed when the mount changes)."""
        super()._update_paths()
        if self._accel_mount != self.sample_map.mount:
            self._accel_mount = self.sample_map.mount
            self._accel_affine = specific_force_map(self.sample_map)

    # -- the gyro samples --------------------------------------------------------------------

    def gyro(self, sec: int, nanosec: int, rate: Sequence[float],
             imu: bytes | None = None, accel: Sequence[float] | None = None) -> bool:
        """:meth:`GyroSession.gyro`, then the sample's gravity-free acceleration; held
        first while its attitude measurement is awaited (``attitude_measurement_period``)."""
        if self.measurement_period_ns and self.estimation.started and self.use_header_stamps:
            stamp_ns = to_ns(sec, nanosec)
            if self._waits(stamp_ns, (stamp_ns, sec, nanosec, rate, imu, accel)):
                return False
        return self._integrated_gyro(sec, nanosec, rate, imu, accel)

    def _integrated_gyro(self, sec: int, nanosec: int, rate: Sequence[float],
                         imu: bytes | None = None,
                         accel: Sequence[float] | None = None) -> bool:
        """The sample after the held measurements stamped before it were fused."""
        self._force = None
        self._sample_ns = (to_ns(sec, nanosec) if self.use_header_stamps
                           else self.clock_ns())
        if not self._special and accel is not None:  # the inline path: the force mapped here
            self._force = mapped_force(self._accel_affine, accel)
        if self.measurements.held:
            self._fuse_due()
        published = super().gyro(sec, nanosec, rate, imu, accel)
        force = self._force
        if published and force is not None and self.estimation.started:
            sec, nanosec = self.output_stamp
            self.sink.acceleration(sec, nanosec, partial(
                self.estimation.acceleration_estimate, self.propagator.state.attitude_tuple(),
                force))
        return published

    def _special_sample(self, sec: int, nanosec: int, rate: Sequence[float],
                        accel: Sequence[float] | None) -> Sequence[float] | None:
        """:meth:`ImuStart._special_sample`; the body specific force kept for the filter when
        it is a real one (finite, not zero, within the accelerometer limit)."""
        self.body_specific_force = None
        if self._aligning and self.starts_from_attitude:
            self._refuse('awaiting_attitude', '')
            return None
        body_rate = super()._special_sample(sec, nanosec, rate, accel)
        force = cast('Vec | None', self.body_specific_force)  # set by the call above
        if body_rate is not None and force is not None:
            fx, fy, fz = force
            if 0.0 < fx * fx + fy * fy + fz * fz <= _FORCE_LIMIT_SQUARED:  # NaN fails too
                self._force = force
        return body_rate

    def _after_step(self, q_before: Quat, rate_body: Vec, dt: float) -> None:
        """One integrated step to the filter; an update's attitude and bias taken."""
        estimation = self.estimation
        if not estimation.started:
            return
        state = self.propagator.state
        q = estimation.step(self._sample_ns, q_before, rate_body, dt, state.attitude_tuple(),
                            self._force)
        if q is None:
            return
        state.set_sample(state.time, q, state.omega_tuple())
        self._corrected()
        if self._force is not None:
            estimation.mark_acceleration_covariance(q, self._force)

    def _corrected(self) -> None:
        """After an update: the gyro's estimates removed from the next samples, the covariance
        published."""
        self._take_gyro_estimates()
        self.sink.attitude_covariance(self.estimation.published)

    def _take_gyro_estimates(self) -> None:
        """The filter's gyro bias and intrinsic errors (scale factors, misalignment) removed
        from the next samples: the error states the filter's covariance describes are what
        is left of them."""
        estimator = self.estimation.estimator
        self.sample_map.set_gyro_bias(estimator.gyro_bias, estimator.intrinsic.tolist())
        self._update_paths()

    def _filter_aligned(self, result: AlignmentResult) -> None:
        """The integration's start is settled: the filter starts from it."""
        levelled = result.source != FROM_SCENE and self.levelling is not None
        gravity = STANDARD_GRAVITY
        if levelled and self.levelling is not None:
            gravity = math.sqrt(sum(value * value
                                    for value in self.levelling.aligner.specific_force))
        window = result.window_seconds if result.at_rest and result.window_seconds > 0 else None
        q = self.estimation.start(result.attitude, result.gyro_bias, window,
                                  gravity if gravity > 0.0 else STANDARD_GRAVITY)
        self.measurements.wait_from_ns = self._sample_ns
        self._take_gyro_estimates()
        if q != result.attitude:
            self.propagator.scene = replace(self.propagator.scene, initial_attitude=np.array(q))
            self.propagator.set_attitude(q)
        self.sink.attitude_covariance(self.estimation.published)

    def _outcome(self, outcome: Outcome, sec: int, nanosec: int, imu: bytes | None) -> bool:
        """:meth:`GyroSession._outcome`, then the sample's ``odom`` (the attitude published and
        the corrected body rate)."""
        published = super()._outcome(outcome, sec, nanosec, imu)
        attitude = self.tracker.previous
        if published and attitude is not None and self.estimation.started:
            self.sink.odometry(sec, nanosec, attitude, self.propagator.state.omega_tuple(),
                               self.estimation.rate_covariance)
        return published

    def _restart_uncertainty(self) -> None:
        """Reset, a jump back: the filter starts again from the settled start, or waits for
        the levelling (or the first attitude measurement)."""
        self.measurements.restart()
        self.estimation.restart()
        if not self._aligning and self.alignment is not None:
            self._filter_aligned(self.alignment)

    def _pose_set(self, orientation_covariance: tuple[float, ...] | None) -> None:
        """``set_pose``: the attitude block of the filter's covariance replaced."""
        if not self.estimation.started:
            return
        block = orientation_covariance or tuple(
            (self.set_pose_stddev ** 2 if row == column else 0.0)
            for row in range(3) for column in range(3))
        self.estimation.reset_attitude_block(block)
        self.sink.attitude_covariance(self.estimation.published)

    # -- the filter's own inputs -------------------------------------------------------------

    def magnetic_field(self, sec: int, nanosec: int, frame: str,
                       field: Sequence[float]) -> None:
        """One ``imu/mag`` sample (module docstring); refused ones counted by reason."""
        if not self.use_header_stamps:
            sec, nanosec = split_ns(self.clock_ns())
        elif nanosec >= NANOSECONDS_PER_SECOND or (sec <= 0 and (sec < 0 or not nanosec)):
            return self._refused('magnetometer_invalid_stamp', 'imu/mag')
        if frame == self.imu_frame:
            mount: Quat | None = self.sample_map.mount
        elif frame in ('', self.body_frame):
            mount = None
        else:
            mount = self.frame_mount(frame)
            if mount is None:
                return self._refused('magnetometer_no_mount', 'imu/mag', frame)
        try:
            x, y, z = (float(value) for value in field)
        except (TypeError, ValueError):
            return self._refused('non_finite', 'imu/mag')
        reason = self.estimation.magnetic_field(to_ns(sec, nanosec),
                                                (x, y, z), mount, self._levelling_window())
        if reason:
            return self._refused(reason, 'imu/mag')
        self.estimation_inputs += 1

    def _levelling_window(self) -> bool:
        """Whether the levelling is averaging a rest window."""
        levelling = self.levelling
        return (self._aligning and levelling is not None
                and levelling.aligner.state == ALIGNING)

    def _refused(self, reason: str, topic: str, frame: str | None = None) -> None:
        """An input of the filter refused: counted by ``reason``, warned about."""
        key = reason if reason.startswith('magnetometer') else f'{topic}_{reason}'
        key = key.replace('imu/mag_', 'magnetometer_')
        self.rejections[key] += 1
        where = f' (frame {quoted(frame)})' if frame is not None else ''
        self.warn(key, f'{topic}: {_DETAIL.get(reason, reason)}{where}; ignored')

    # -- counts and reports ------------------------------------------------------------------

    def accepted_count(self) -> int:
        """Gyro samples, poses, magnetometer samples and attitude measurements used."""
        return super().accepted_count() + self.estimation_inputs

    def bias_text(self) -> str:
        """The gyro bias the filter estimates [rad/s, body frame]."""
        if not self.estimation.started:
            return super().bias_text()
        return ' '.join(f'{value:.9g}' for value in self.estimation.estimator.gyro_bias) + (
            ' (filter)')

    def report(self) -> DiagnosticReport:
        """The gyro session's report with the filter's values; WARN past
        ``tilt_stddev_warn`` (only once the filter runs)."""
        report = super().report()
        rejections = self.rejections
        values = list(report.values) + [(f'rejected {key}', str(rejections[key]))
                                        for key in FILTER_REJECTION_KEYS]
        values += self.estimation.values()
        level, message = report.level, report.message
        if self.estimation.started:
            tilt, yaw = attitude_stddev_deg(self.estimation.published)
            values += [('tilt_stddev [deg]', f'{tilt:.3f}'), ('yaw_stddev [deg]', f'{yaw:.3f}')]
            bound = math.degrees(self.tilt_stddev_warn)
            if self.tilt_stddev_warn > 0.0 and tilt > bound:
                problem = (f'1-sigma tilt {tilt:.2f} deg above {bound:.2f} deg '
                           f'(parameter `tilt_stddev_warn`)')
                level = max(level, LEVEL_WARN)
                message = problem if message == 'propagating' else f'{message}; {problem}'
        return DiagnosticReport(level, message, tuple(values))


def specific_force_map(sample_map: SampleMap) -> tuple[float, ...]:
    """The body specific force's affine map of a sensor-frame one: ``R N`` (row-major) and
    ``−R N b_a``, the mount ``R`` and the accelerometer calibration ``N``, ``b_a``."""
    rotation = quaternion.to_matrix(np.array(sample_map.mount))
    calibration = sample_map.calibration
    matrix = rotation @ calibration.accelerometer_matrix
    offset = -(matrix @ calibration.accelerometer_bias)
    return tuple(matrix.ravel().tolist() + offset.tolist())


def mapped_force(affine: tuple[float, ...], accel: Sequence[float]) -> Vec | None:
    """The body specific force [m/s²] of a sensor-frame one through ``affine``
    (:func:`specific_force_map`); ``None``: none, or not a real one (all zeros: an Imu
    without accelerometer data; non-finite; beyond the accelerometer limit)."""
    try:
        ax, ay, az = accel
    except (TypeError, ValueError):
        return None
    if ax == 0.0 and ay == 0.0 and az == 0.0:
        return None
    a00, a01, a02, a10, a11, a12, a20, a21, a22, c0, c1, c2 = affine
    fx = a00 * ax + a01 * ay + a02 * az + c0
    fy = a10 * ax + a11 * ay + a12 * az + c1
    fz = a20 * ax + a21 * ay + a22 * az + c2
    if 0.0 < fx * fx + fy * fy + fz * fz <= _FORCE_LIMIT_SQUARED:  # NaN fails too
        return fx, fy, fz
    return None
