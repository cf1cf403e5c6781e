"""The attitude filter in a gyro session: the scene's ``estimation:`` section at work.

A gyro scene with an ``estimation`` section
(:mod:`~rigid_body_attitude.core.estimation.estimation_section`) runs
:class:`~rigid_body_attitude.core.estimation.estimator.AttitudeEstimator` on the session's own
strapdown steps (:class:`~rigid_body_attitude.session.gyro.GyroSession`, the one loop of the
node, the replay and the studies). :class:`Estimation` is what the session holds of it:

* **start** (:meth:`Estimation.start`): from the levelling (its attitude, gyro bias, rest
  window and the specific force's norm at rest) and the magnetometer's mean over the same
  rest (:func:`~rigid_body_attitude.core.estimation.estimator_start.start_estimator`: heading
  from the field, the field's norm and dip learned). Without a magnetometer sample by then,
  the first ``align_seconds`` of field after the start turn the heading once
  (:meth:`Estimation._late_field`); until then the heading stays propagated;
* **per integrated step** (:meth:`Estimation.step`): the filter's ``sample`` with the step's
  attitudes, body rate and the body specific force; the magnetometer samples whose stamp the
  step reached; at the update times ``update``, whose attitude replaces the propagated one
  and whose gyro bias the session subtracts from the next samples;
* **magnetometer** (:meth:`Estimation.magnetic_field`): corrected for hard and soft iron in
  its sensor frame (the calibration file), turned into the body frame by its mount, held
  until the gyro stream reaches its stamp (then paired with the attitude of that step);
* **external attitude** (:meth:`Estimation.attitude_measurement`): an update at once (the
  session orders it with the gyro samples: :mod:`~rigid_body_attitude.session.attitude_input`).

The covariance the session publishes is the filter's attitude block (about fixed world axes,
REP-145), refreshed at every update (every ``update_interval`` of steps), with the
uncertainty of the instant the samples represent while the body turns (``sample_timing``).
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.estimation_section import EstimationSpec
from rigid_body_attitude.core.estimation.estimator import (
    MAX_FIELD_AGE, AttitudeEstimator, published_covariance)
from rigid_body_attitude.core.estimation.estimator_start import (
    magnetic_start, start_estimator)
from rigid_body_attitude.core.estimation.filter_covariance import GYRO_BIAS
from rigid_body_attitude.core.estimation.gravity_free import gravity_free_acceleration
from rigid_body_attitude.core.estimation.magnetometer import MagnetometerCalibration
from rigid_body_attitude.core.estimation.magnetometer_file import MagnetometerFile

__all__ = ['Estimation', 'FIELD_QUEUE', 'STANDARD_GRAVITY', 'gravity_free_sample']

Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]
#: Magnetometer samples held until the gyro reaches their stamps (the oldest is used at once
#: beyond that: a magnetometer ahead of a stalled gyro).
FIELD_QUEUE = 64
#: The specific force's norm [m/s²] assumed when no rest window measured it.
STANDARD_GRAVITY = 9.80665


class Estimation:
    """The filter of one gyro session (module docstring).

    Args:
        spec: the scene's section.
        estimator: the filter (its magnetometer correction the identity: :attr:`iron`
            corrects in the sensor frame).
        iron: the magnetometer calibration (hard and soft iron, sensor frame).
        late_field_seconds: field averaged to turn the heading when none came at start [s].
    """

    def __init__(self, spec: EstimationSpec, estimator: AttitudeEstimator,
                 iron: MagnetometerCalibration, late_field_seconds: float) -> None:
        self.spec, self.estimator, self.iron = spec, estimator, iron
        self.late_field_seconds = late_field_seconds
        self.started = False
        self.counts: Counter[str] = Counter()
        self._fields: deque[tuple[int, Vec]] = deque()
        self._rest_field = [0.0, 0.0, 0.0, 0.0]  # sum (body) and count while levelling
        self._late = [0.0, 0.0, 0.0, 0.0, 0.0]  # sum (world), count, first stamp [ns]
        self._last_field_ns: int | None = None
        #: Row-major 3×3 attitude covariance [rad²] about fixed world axes, as published.
        self.published: tuple[float, ...] = (0.0,) * 9
        #: Row-major 3×3 covariance [(rad/s)²] of a corrected rate (bias and white noise).
        self.rate_covariance: tuple[float, ...] = (0.0,) * 9
        self._acceleration_covariance: tuple[float, ...] = (0.0,) * 9
        self._acceleration_at: tuple[Quat, Vec] | None = None  # the last update's, not used

    # -- start -------------------------------------------------------------------------------

    def restart(self) -> None:
        """Not started: the next levelling starts the filter again (reset, a jump back)."""
        self.started = False
        self._fields.clear()
        self._last_field_ns = None
        self._rest_field = [0.0, 0.0, 0.0, 0.0]
        self._late = [0.0, 0.0, 0.0, 0.0, 0.0]

    def rest_field(self, aligning: bool, field_body: Vec) -> None:
        """A field sample while levelling: summed while the levelling window runs
        (``aligning``), forgotten when the rest is broken."""
        s = self._rest_field
        if not aligning:
            self._rest_field = [0.0, 0.0, 0.0, 0.0]
            return
        s[0] += field_body[0]
        s[1] += field_body[1]
        s[2] += field_body[2]
        s[3] += 1.0

    def start(self, q: Quat, gyro_bias: Vec, window_seconds: float | None,
              gravity: float) -> Quat:
        """Start from a levelling (or from the scene: no window, standard gravity); returns
        the starting attitude (turned to magnetic north when the rest had a field)."""
        s = self._rest_field
        mean = (s[0] / s[3], s[1] / s[3], s[2] / s[3]) if s[3] and self.spec.magnetometer else None
        try:
            q = start_estimator(self.estimator, q, gyro_bias, window_seconds, gravity, mean,
                                int(s[3]))
        except InputError:  # a field without a horizontal part: the heading from the gyro
            q = start_estimator(self.estimator, q, gyro_bias, window_seconds, gravity)
            self.counts['magnetometer_start_refused'] += 1
        self.started = True
        self._publish()
        return q

    # -- per step ----------------------------------------------------------------------------

    def step(self, stamp_ns: int, q_before: Quat, rate: Vec, dt: float, q_after: Quat,
             specific_force: Vec | None) -> Quat | None:
        """One integrated step ending at ``stamp_ns``; returns the corrected attitude when
        an update ran or the heading was turned (else None)."""
        estimator = self.estimator
        force = specific_force if self.spec.gravity else None
        due = estimator.sample(q_before, rate, dt, q_after, force)
        fields = self._fields
        turned = None
        while fields and fields[0][0] <= stamp_ns:
            field_ns, field = fields.popleft()
            turned = self._field_at(q_after, field_ns, field, stamp_ns) or turned
        if not due:
            return turned
        interval = estimator.interval
        if interval.count and interval.duration > 0.0:
            estimator.sample_rate = interval.count / interval.duration
        q = estimator.update(turned or q_after)
        self._publish(q, rate)
        return q

    def _field_at(self, q: Quat, stamp_ns: int, field_body: Vec, step_ns: int
                  ) -> Quat | None:
        """A field sample stamped ``stamp_ns``, given with the attitude ``q`` of the step
        ending at ``step_ns`` (the filter pairs it with the attitude at its own instant, up to
        :data:`MAX_FIELD_AGE` before); returns the turned attitude when it completed a late
        heading start."""
        if self.estimator.field is None:
            return self._late_field(q, stamp_ns, field_body)
        age = (step_ns - stamp_ns) * 1e-9
        if age > MAX_FIELD_AGE:  # taken too late to be paired: the gyro ran ahead
            self.counts['magnetometer_late'] += 1
            return None
        self.estimator.magnetic_field(q, field_body, age)
        return None

    def _late_field(self, q: Quat, stamp_ns: int, field_body: Vec) -> Quat | None:
        """No field at start: average ``late_field_seconds`` of stamps of it in the world
        frame, then turn the heading once (:func:`magnetic_start` on the attitude of the last
        sample)."""
        late = self._late
        if not late[3]:
            late[4] = float(stamp_ns)
        rotation = _matrix(q)
        world = rotation @ np.array(field_body)
        late[0] += float(world[0])
        late[1] += float(world[1])
        late[2] += float(world[2])
        late[3] += 1.0
        if (stamp_ns - late[4]) * 1e-9 < self.late_field_seconds:
            return None
        mean_body = rotation.T @ (np.array(late[:3]) / late[3])
        covariance = self.estimator.covariance
        assert covariance is not None
        covariance.fold()
        self._late = [0.0, 0.0, 0.0, 0.0, 0.0]
        try:
            q_new, reference = magnetic_start(self.estimator, q, mean_body.tolist(),
                                              int(late[3]), covariance)
        except InputError:
            self.counts['magnetometer_start_refused'] += 1
            return None
        self.estimator.magnetometer_channel.reference = reference
        self._publish()
        return q_new

    def magnetic_field(self, stamp_ns: int, field_sensor: Vec, mount: Quat | None,
                       aligning: bool) -> str:
        """A magnetometer sample [T] in its sensor frame, its mount into the body frame
        (None: identity): before the start summed for the heading (while the levelling
        window runs: ``aligning``), after it held until the gyro's next step at or after its
        stamp; ``''`` when taken, else the reason it is refused."""
        if self._last_field_ns is not None and stamp_ns <= self._last_field_ns:
            return 'magnetometer_stale_stamp'
        mx, my, mz = field_sensor
        if not (math.isfinite(mx) and math.isfinite(my) and math.isfinite(mz)):
            return 'non_finite'
        if not 0.0 < mx * mx + my * my + mz * mz <= _FIELD_LIMIT_SQUARED:
            return 'magnetometer_out_of_range'
        self._last_field_ns = stamp_ns
        field = self.iron.corrected((mx, my, mz))
        if mount is not None:
            field = _rotated(mount, field)
        if not self.started:
            self.rest_field(aligning, field)
            return ''
        fields = self._fields
        fields.append((stamp_ns, field))
        if len(fields) > FIELD_QUEUE:  # a magnetometer far ahead of a stalled gyro
            fields.popleft()
            self.counts['magnetometer_queue_full'] += 1
        return ''

    def attitude_measurement(self, q: Quat, q_measured: Quat,
                             covariance: Sequence[float]) -> Quat:
        """An external attitude (w, x, y, z) with its row-major 3×3 world-frame covariance
        [rad²]; returns the corrected attitude."""
        matrix = np.array(covariance, dtype=np.float64).reshape(3, 3)
        q = self.estimator.attitude_measurement(q, q_measured, matrix)
        self._publish()
        return q

    def reset_attitude_block(self, covariance: Sequence[float]) -> None:
        """A ``set_pose``: the attitude block replaced, its correlations cleared."""
        state = self.estimator.covariance
        if state is not None:
            state.reset_attitude_block(np.array(covariance, dtype=np.float64).reshape(3, 3))
            self._publish()

    # -- outputs -----------------------------------------------------------------------------

    def _publish(self, q: Quat | None = None, rate: Vec | None = None) -> None:
        """The filter's attitude block as published; after an update at ``q`` with the body
        rate ``rate``, widened by the uncertainty of the sample's instant
        (:func:`~rigid_body_attitude.core.estimation.estimator.published_covariance`)."""
        state = self.estimator.covariance
        if state is None:
            return
        block = state.attitude
        if q is not None and rate is not None:
            block = published_covariance(block, q, rate, self.estimator.settings.sample_timing)
        self.published = tuple(block.reshape(9).tolist())
        self._p = state.p
        estimator = self.estimator
        white = estimator.model.gyroscope_noise_density ** 2 * estimator.sample_rate
        self.rate_covariance = tuple((state.p[GYRO_BIAS, GYRO_BIAS] + white * np.eye(3))
                                     .reshape(9).tolist())

    def acceleration_estimate(self, q: Quat, specific_force: Vec
                              ) -> tuple[Vec, tuple[float, ...]]:
        """The body's gravity-free acceleration [m/s², body frame] of a sample at ``q`` and
        its row-major 3×3 covariance [(m/s²)²]: the covariance at the last update's attitude
        and specific force (:meth:`mark_acceleration_covariance`), computed once per update
        when first asked for."""
        at = self._acceleration_at
        if at is not None:
            self._acceleration_at = None
            self._acceleration_covariance = self._covariance_at(*at)
        return gravity_free_sample(self.estimator, q, specific_force), (
            self._acceleration_covariance)

    def mark_acceleration_covariance(self, q: Quat, specific_force: Vec) -> None:
        """An update ran at ``q`` with ``specific_force``: the acceleration's covariance is
        that of this attitude and force (computed when asked for)."""
        self._acceleration_at = (q, specific_force)

    def _covariance_at(self, q: Quat, specific_force: Vec) -> tuple[float, ...]:
        """The gravity-free acceleration's covariance at ``q`` (:mod:`.gravity_free`)."""
        estimator = self.estimator
        state = estimator.covariance
        assert state is not None
        variance = estimator.model.accelerometer_noise_density ** 2 * estimator.sample_rate
        _, covariance = gravity_free_acceleration(q, specific_force, estimator.accel_bias,
                                                  estimator.gravity, estimator.up, state.p,
                                                  variance)
        return tuple(covariance.reshape(9).tolist())

    def values(self) -> list[tuple[str, str]]:
        """The filter in ``/diagnostics``: bias, updates and rejections, field, heading."""
        estimator = self.estimator
        counts = Counter(estimator.counts)
        counts.update(self.counts)
        bias = ' '.join(f'{value:.6g}' for value in estimator.gyro_bias)
        field = estimator.field
        if field is None:
            field_text = 'none (heading propagated: yaw unobservable)'
        else:
            field_text = (f'{field.norm * 1e6:.2f} uT, dip {math.degrees(field.dip):.1f} deg')
        updates = ', '.join(f'{name} {count}' for name, count in sorted(counts.items()))
        return [('estimation', 'on' if self.started else 'waiting for levelling'),
                ('gyro_bias_estimate [rad/s]', bias),
                ('updates and rejections', updates or 'none yet'),
                ('magnetic_field_reference', field_text),
                ('heading_observable', 'yes' if field is not None else 'no')]


_FIELD_LIMIT_SQUARED = 1.0e-2 ** 2


def gravity_free_sample(estimator: AttitudeEstimator, q: Quat, specific_force: Vec) -> Vec:
    """The body's acceleration [m/s², body frame] of one sample at ``q`` (gravity and the
    estimator's accelerometer bias removed; plain floats: per sample)."""
    bias, gravity, up = estimator.accel_bias, estimator.gravity, estimator.up
    w, x, y, z = q
    ux, uy, uz = float(up[0]), float(up[1]), float(up[2])
    # Rᵀ up with R the body → world rotation of q
    bx = (1 - 2 * (y * y + z * z)) * ux + 2 * (x * y + w * z) * uy + 2 * (x * z - w * y) * uz
    by = 2 * (x * y - w * z) * ux + (1 - 2 * (x * x + z * z)) * uy + 2 * (y * z + w * x) * uz
    bz = 2 * (x * z + w * y) * ux + 2 * (y * z - w * x) * uy + (1 - 2 * (x * x + y * y)) * uz
    return (specific_force[0] - float(bias[0]) - gravity * bx,
            specific_force[1] - float(bias[1]) - gravity * by,
            specific_force[2] - float(bias[2]) - gravity * bz)


def _rotated(q: Quat, v: Vec) -> Vec:
    """``q ⊗ v ⊗ q*`` in plain floats."""
    w, x, y, z = q
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


def _matrix(q: Sequence[float]) -> Any:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def build_estimation(spec: EstimationSpec, values: Mapping[str, Any], model: Any,
                     magnetometer: MagnetometerFile,
                     imu_figures: Mapping[str, float] | None = None) -> Estimation:
    """The :class:`Estimation` of a session: the filter with the scene section's settings,
    then the parameters', then the IMU calibration file's figures (``imu_figures``: settings
    field → value), then the magnetometer file's."""
    settings = spec.estimator_settings(**{
        'declination': values['magnetic_declination'],
        'magnetometer_noise_density': values['magnetometer_noise_density'],
        'accelerometer_random_walk': values['accelerometer_random_walk'],
        **(imu_figures or {}), **magnetometer.settings})
    estimator = AttitudeEstimator(model, settings, values['world_axes'])
    return Estimation(spec, estimator, magnetometer.calibration,
                      max(values['align_seconds'], 0.5))
