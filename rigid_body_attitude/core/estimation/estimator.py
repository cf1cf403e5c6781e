"""The attitude filter: an error-state (multiplicative) Kalman filter over the gyro's attitude.

The gyro propagates the attitude (the session's strapdown step) and
:class:`~rigid_body_attitude.core.estimation.filter_covariance.FilterCovariance` its error
covariance; this class adds the measurement updates (F. L. Markley, "Attitude error
representations for Kalman filtering", JGCD 26(2), 2003; J. Solà, "Quaternion kinematics for
the error-state Kalman filter", 2017, chapter 7), in order, once per update interval:

1. **gravity**: tilt from the accelerometer, through the velocity (:mod:`.velocity_update`:
   the interval's velocity change against a bounded velocity; the default) or through the
   interval's mean specific force with the acceleration as noise (:mod:`.gravity_update`);
2. **rest** (:mod:`.zero_rate_update`, :mod:`.velocity_update`): zero rate (the gyro bias)
   and zero velocity while the body rests;
3. **magnetometer** (:mod:`.magnetometer`): heading only, each sample paired with the
   attitude at its own instant, when the interval's field passes the norm and dip checks of
   :mod:`.field_reference`.

Each accepted update is injected at once (:mod:`.kalman_update`): ``q ← exp(δθ) ⊗ q``, the
gyro bias (and, when estimated, the intrinsic errors and the accelerometer bias) corrected,
the covariance kept (no reset Jacobian: :mod:`.kalman_update`); the sums of the next
measurement are rotated by the same ``δθ``. An external attitude
(:meth:`AttitudeEstimator.attitude_measurement`) is one more update.

Per sample (:meth:`AttitudeEstimator.sample`, :meth:`AttitudeEstimator.magnetic_field`) the
work is a few plain-float operations (:mod:`.interval_sums`); the NumPy work happens at the
update rate. Gyro bias in motion: every update corrects it through the covariance (its
correlation with the attitude error), at rest the zero-rate update does.

Which states are estimated (:mod:`.filter_covariance`): the gyro's intrinsic errors are by
default, because they matter exactly when the body turns fast and that is when the gravity
and heading updates make them observable (a 1 % scale error at 10 rad/s is 6°/s of drift);
the accelerometer bias is considered by default: over minutes of hand-held motion it is not
separable from the acceleration the gravity update treats as noise, so estimating it lets
that noise leak into it, while considering it keeps its effect in every gain and in the
published covariance. The magnetometer's hard iron is learned beside the filter
(:mod:`.hard_iron`: a sphere fit of the sensor-frame field as the body turns, learned only when
the field lies on a sphere of the local field's norm and the same offset is found again
``hard_iron_time`` later); a field it cannot explain fails the norm and dip checks
(:mod:`.field_reference`) or stays within the heading disturbance ``d``.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.environment.magnetic_field import WORLD_AXES
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.attitude_update import attitude_measurement
from rigid_body_attitude.core.estimation.estimator_settings import EstimatorSettings
from rigid_body_attitude.core.estimation.field_reference import FieldReference
from rigid_body_attitude.core.estimation.filter_covariance import (
    FILTER_STATE_SIZE, FilterCovariance, estimated_mask)
from rigid_body_attitude.core.estimation.gravity_update import MotionPower, gravity_measurement
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel
from rigid_body_attitude.core.estimation.interval_sums import ImuInterval
from rigid_body_attitude.core.estimation.kalman_update import (
    UpdateResult, injected_attitude, joseph_update)
from rigid_body_attitude.core.estimation.magnetometer import (
    MagnetometerCalibration, heading_only_gain)
from rigid_body_attitude.core.estimation.magnetometer_channel import (
    FIELD_LIMIT, MAX_FIELD_AGE, MagnetometerChannel)
from rigid_body_attitude.core.estimation.velocity_update import BoundedVelocity
from rigid_body_attitude.core.estimation.zero_rate_update import (
    RestIntervals, zero_rate_measurement)

__all__ = ['AttitudeEstimator', 'FIELD_LIMIT', 'MAX_FIELD_AGE', 'SPECIFIC_FORCE_LIMIT']

FloatArray = NDArray[np.float64]
Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]
#: Largest specific force magnitude [m/s²] a sample may have.
SPECIFIC_FORCE_LIMIT = 1.0e4


class AttitudeEstimator:
    """The filter (module docstring). Start it with :meth:`start`, then per IMU sample call
    :meth:`sample` and, when it returns true, :meth:`update`.

    Args:
        model: the gyro error budget (with the accelerometer's noise density and bias prior).
        settings: the filter's settings.
        world_axes: ``'enu'``, ``'ned'`` or ``'nwu'``.
        magnetometer: the hard- and soft-iron correction (none: identity).
        sample_rate: the IMU's rate [Hz] (per-sample noise of the rest test).
    """

    def __init__(self, model: GyroErrorModel, settings: EstimatorSettings,
                 world_axes: str = 'enu', magnetometer: MagnetometerCalibration | None = None,
                 sample_rate: float = 100.0) -> None:
        if world_axes not in WORLD_AXES:
            raise InputError(f'Expected world_axes to be one of {", ".join(sorted(WORLD_AXES))}'
                             f', got {world_axes!r}')
        if not (math.isfinite(sample_rate) and sample_rate > 0.0):
            raise InputError(f'Expected `sample_rate` > 0 Hz, got {sample_rate!r}')
        axes = WORLD_AXES[world_axes]
        self.up, self.east, self.north = (np.array(v) for v in (axes.up, axes.east, axes.north))
        self.horizontal = np.stack([self.east, self.north], axis=1)
        self.model, self.settings = model, settings
        self.sample_rate = float(sample_rate)
        self.estimated = estimated_mask(settings.estimate_intrinsic,
                                        settings.estimate_accelerometer_bias)
        self.interval = ImuInterval()
        self.counts: Counter[str] = Counter()
        #: The magnetometer's side (:mod:`.magnetometer_channel`).
        self.magnetometer_channel = MagnetometerChannel(
            settings, magnetometer or MagnetometerCalibration(), self.sample_rate,
            (self.east, self.north, self.up), self.counts)
        self.motion = MotionPower(settings.motion_power_time, settings.acceleration_time)
        #: The velocity channel (:mod:`.velocity_update`).
        self.velocity = BoundedVelocity(settings.velocity_time, settings.motion_power_time,
                                        model.accelerometer_noise_density,
                                        settings.zero_velocity_stddev)
        self.rest = RestIntervals(settings.rest_seconds, settings.rest_noise_factor,
                                  settings.max_rest_rate, settings.gravity_tolerance)
        self.covariance: FilterCovariance | None = None
        self.gyro_bias: Vec = (0.0, 0.0, 0.0)
        self.accel_bias = np.zeros(3)
        self.intrinsic = np.zeros(9)
        self.gravity = 9.80665

    def start(self, covariance: FilterCovariance, gyro_bias: Sequence[float], gravity: float,
              field: FieldReference | None) -> None:
        """Begin from a levelled start (:mod:`.estimator_start`): its covariance, gyro bias
        [rad/s], the specific force's norm at rest [m/s²], the field's reference (or None:
        no magnetometer, the heading stays propagated)."""
        self.covariance, self.gravity = covariance, float(gravity)
        self.magnetometer_channel.reference = field
        self.gyro_bias = (float(gyro_bias[0]), float(gyro_bias[1]), float(gyro_bias[2]))
        self.intrinsic = np.zeros(9)  # the prior's mean, as the covariance's
        self.accel_bias = np.zeros(3)
        self.velocity.restart(covariance)
        self.interval.clear()
        self.magnetometer_channel.interval.clear()

    @property
    def magnetometer(self) -> MagnetometerCalibration:
        """The magnetometer's correction (extended by the hard iron learned)."""
        return self.magnetometer_channel.calibration

    @property
    def field(self) -> FieldReference | None:
        """The local field's reference (None: no magnetometer)."""
        return self.magnetometer_channel.reference

    def sample(self, q_before: Quat, rate: Vec, dt: float, q_after: Quat,
               specific_force: Vec | None) -> bool:
        """One integrated step: attitude at its start, the bias-corrected body rate held over
        it [rad/s], its length [s], the attitude after it, the body specific force [m/s²] at
        its end (None: none). Returns whether an update is due. InputError for a non-finite
        or out-of-range value (naming it)."""
        covariance = self.covariance
        if covariance is None:
            raise InputError('Expected start() before the first sample')
        covariance.add_sample(q_before, rate, dt)
        self.magnetometer_channel.recent.add(rate, dt)
        if specific_force is not None:
            fx, fy, fz = specific_force
            if not 0.0 < fx * fx + fy * fy + fz * fz <= SPECIFIC_FORCE_LIMIT ** 2:
                raise InputError(f'Expected a finite, non-zero specific force of at most '
                                 f'{SPECIFIC_FORCE_LIMIT:g} m/s^2, got {tuple(specific_force)!r}')
            b = self.accel_bias
            self.interval.add(q_after, rate, (fx - b[0], fy - b[1], fz - b[2]), dt)
        else:
            self.interval.duration += dt
        return self.interval.duration >= self.settings.update_interval

    def magnetic_field(self, q: Quat, field: Vec, age: float = 0.0) -> None:
        """One magnetometer sample [T], body frame, uncorrected, stamped ``age`` [s] before
        the attitude ``q`` (the last sample's); it is paired with the attitude at its own
        instant, ``magnetometer_delay + age`` before ``q`` (:mod:`.magnetometer`). InputError
        for a non-finite, zero or out-of-range field or age (naming it)."""
        self.magnetometer_channel.add(q, field, age)

    def update(self, q: Quat) -> Quat:
        """The updates of the interval ending at attitude ``q``; returns the corrected
        attitude (:attr:`gyro_bias` and the other estimates are corrected in place)."""
        self._fold()
        interval, rotation = self.interval, np.eye(3)
        velocity_model = self.settings.motion_model == 'velocity'
        if interval.count:
            if velocity_model:
                q, rotation = self._velocity_change(q, rotation)
            else:
                q, rotation = self._gravity(q, rotation)
            if self.rest.at_rest(interval, self._gyro_noise(), self._accel_noise(),
                                 self.gravity):
                q, rotation = self._zero_rate(q, rotation)
                if velocity_model:
                    q, rotation = self._zero_velocity(q, rotation)
        elif interval.duration > 0.0:  # no specific force: the velocity is not seen
            self.velocity.unseen(self._state(), interval.duration)
        q = self._heading(q, rotation, interval.mean_rate() if interval.count else None,
                          interval.rms_rate() if interval.count else 0.0)
        self.velocity.clone(self._state())
        interval.clear()
        self.magnetometer_channel.interval.clear()
        return q

    def _fold(self) -> None:
        """The covariance folded over the recorded steps."""
        covariance = self.covariance
        assert covariance is not None
        covariance.fold()

    def _state(self) -> FilterCovariance:
        covariance = self.covariance
        assert covariance is not None
        return covariance

    def _velocity_change(self, q: Quat, rotation: FloatArray) -> tuple[Quat, FloatArray]:
        covariance, duration = self._state(), self.interval.count / self.sample_rate
        force_sum = np.array(self.interval.mean_world_force()) * duration
        h, y, r = self.velocity.change(covariance, force_sum, duration, self.gravity, self.up)
        result = joseph_update(covariance.p, h, y, r, self.estimated)
        return self._injected('velocity_change', result, q, rotation)

    def _zero_velocity(self, q: Quat, rotation: FloatArray) -> tuple[Quat, FloatArray]:
        h, y, r = self.velocity.at_rest()
        result = joseph_update(self._state().p, h, y, r, self.estimated)
        return self._injected('zero_velocity', result, q, rotation)

    def _gyro_noise(self) -> float:
        return self.model.gyroscope_noise_density * math.sqrt(self.sample_rate)

    def _accel_noise(self) -> float:
        return self.model.accelerometer_noise_density * math.sqrt(self.sample_rate)

    def _gravity(self, q: Quat, rotation: FloatArray) -> tuple[Quat, FloatArray]:
        interval, covariance = self.interval, self.covariance
        assert covariance is not None
        duration = max(interval.count / self.sample_rate, 1e-9)
        white = self.model.accelerometer_noise_density ** 2 / duration
        mean_force = np.array(interval.mean_world_force())
        measurement = gravity_measurement(mean_force, covariance.mean_rotation,
                                          self.horizontal, self.up,
                                          white + self.motion.variance(duration))
        prior = covariance.p
        result = joseph_update(prior, measurement.h, measurement.residual, measurement.r,
                               self.estimated, self.settings.gravity_gate)
        self.motion.observe(measurement, prior, interval.mean_force_norm() - self.gravity,
                            white, duration)
        return self._injected('gravity', result, q, rotation)

    def _zero_rate(self, q: Quat, rotation: FloatArray) -> tuple[Quat, FloatArray]:
        covariance = self.covariance
        assert covariance is not None
        duration = max(self.interval.count / self.sample_rate, 1e-9)
        h, y, r = zero_rate_measurement(self.interval.mean_rate(),
                                        self.model.gyroscope_noise_density, duration)
        result = joseph_update(covariance.p, h, y, r, self.estimated, self.settings.rest_gate)
        return self._injected('zero_rate', result, q, rotation)

    def _heading(self, q: Quat, rotation: FloatArray, rate: Vec | None,
                 rms_rate: float) -> Quat:
        speed = math.sqrt(sum(value * value for value in rate)) if rate else 0.0
        measurement = self.magnetometer_channel.measurement(rotation, speed, rms_rate)
        if measurement is None:
            return q
        covariance = self._state()
        rows, projection = heading_only_gain(self.estimated,
                                             covariance.mean_rotation.T @ self.up)
        result = joseph_update(covariance.p, measurement.h, measurement.residual,
                               measurement.r, rows, self.settings.magnetometer_gate, projection)
        return self._injected('magnetometer', result, q, rotation)[0]

    def attitude_measurement(self, q: Quat, q_measured: Sequence[float],
                             covariance: FloatArray) -> Quat:
        """An external attitude ``q_measured`` (w, x, y, z) with its 3×3 world-frame
        covariance [rad²] (:mod:`.attitude_update`); returns the corrected attitude."""
        state = self.covariance
        assert state is not None
        h, y, r = attitude_measurement(q, q_measured, covariance)
        self._fold()
        result = joseph_update(state.p, h, y, r, self.estimated, math.inf)
        return self._injected('attitude', result, q, np.eye(3))[0]

    def _injected(self, name: str, result: UpdateResult, q: Quat, rotation: FloatArray
                  ) -> tuple[Quat, FloatArray]:
        """Inject an update's correction (module docstring); count it."""
        covariance = self.covariance
        assert covariance is not None
        accepted, dx, updated = result.accepted, result.dx, result.covariance
        if not accepted:
            self.counts[f'{name}_gated'] += 1
            return q, rotation
        self.counts[name] += 1
        dtheta = dx[:3]
        q = injected_attitude(q, dtheta)
        b = self.gyro_bias
        self.gyro_bias = (b[0] + float(dx[3]), b[1] + float(dx[4]), b[2] + float(dx[5]))
        self.intrinsic += dx[6:15]
        self.accel_bias += dx[15:18]
        self.velocity.inject(dx)
        covariance.set(updated)
        angle = float(np.linalg.norm(dtheta))
        if angle > 0.0:
            axis = dtheta / angle
            cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                              [-axis[1], axis[0], 0.0]])
            turn = np.eye(3) + math.sin(angle) * cross + (1.0 - math.cos(angle)) * cross @ cross
            rotation = turn @ rotation
        return q, rotation

    @property
    def state_size(self) -> int:
        """:data:`~rigid_body_attitude.core.estimation.filter_covariance.FILTER_STATE_SIZE`."""
        return FILTER_STATE_SIZE
