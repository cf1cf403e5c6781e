"""The attitude filter's settings: sensor figures beyond the gyro's, motion and field models.

The gyro's figures (and the accelerometer's noise density and bias prior) are those of
:class:`~rigid_body_attitude.core.estimation.gyro_error_model.GyroErrorModel`. The rest:

* ``accelerometer_random_walk`` 3.0·10⁻³ m/s³/√Hz: the figure of kalibr's example
  ``imu.yaml`` (ADIS16448), kalibr's name and unit.
* ``magnetometer_noise_density`` 1.5·10⁻⁷ T/√Hz: a consumer magnetometer (Bosch BMM150 data
  sheet, BST-BMM150-DS001: 0.3-0.6 µT rms noise at 10-30 Hz output rates). Measure yours at
  rest (the standard deviation of a still recording over √rate).
* ``magnetometer_delay`` 0 s: how long before its stamp a magnetometer sample was taken
  (its filter's delay and its own sampling); measure it with
  :func:`~rigid_body_attitude.core.estimation.magnetometer_timing.magnetometer_delay`.
* ``magnetometer_timing`` 0.01 s: 1σ of the instants of the magnetometer's samples once the
  delay is taken off (a magnetometer's own output period, 100 Hz for most parts, when the
  delay is not known; ``P/√12`` for a sample held over its period ``P`` when it is).
* ``magnetic_disturbance_stddev`` 2° and ``magnetic_disturbance_time`` 10 s: the heading
  disturbance ``d`` (:mod:`.filter_covariance`) a field that passes the norm and dip checks
  still carries indoors (steel in floors and furniture bends the horizontal field by degrees,
  and a body moving through it sees the bend change over seconds).
* ``field_norm_tolerance`` 0.1 (relative) and ``field_dip_tolerance`` 10°: a field whose norm
  or dip differs more from the learned reference is disturbed (VQF's ``magNormTh`` and
  ``magDipTh``: D. Laidig, T. Seel, "VQF: Highly accurate IMU orientation estimation with bias
  estimation and magnetic disturbance rejection", Information Fusion 91, 2023, section 3.4);
  ``new_field_seconds`` 20 s and ``new_field_min_rate`` 20°/s: a different field steady in
  norm and dip for that long while the body turns at least that fast is the new reference
  (VQF's ``magNewTime``, ``magNewMinGyr``: a magnet carried with the sensor changes norm
  and dip as the body turns, a new homogeneous field does not).
* ``motion_model`` ``'acceleration'``: gravity through the interval's mean specific force
  with the body's acceleration as noise (:mod:`.gravity_update`); ``'velocity'``: through a
  bounded velocity (:mod:`.velocity_update`). On the ten BROAD trials of
  ``studies/broad_estimation.py`` the acceleration model keeps the covariance consistent on
  fast rotation (trial 07: NEES inside its 99 % bound in 100 % of motion samples, against
  29 % for the velocity model), the velocity model tracks slow translation better (trial 11:
  1.13° inclination against 2.28°).
* ``velocity_time`` 0.5 s: ``τ_v``, the time a hand-held or arm-borne body takes to reverse
  its motion, the correlation time of its velocity (:mod:`.velocity_update`; the velocity's
  power is measured, not set).
* ``sample_timing`` 2 ms: 1σ of the instant an IMU sample represents behind its stamp (a
  MEMS gyro's digital low-pass delays its rate by about ``1/(2π f_c)``, 1.4 ms for the
  BMI088's 116 Hz bandwidth); it widens the published covariance of a turning body
  (:func:`~.estimator.published_covariance`), not the filter's.
* ``accelerometer_range`` 16 g: the accelerometer's full scale (±16 g, the widest range of
  the BMI088 and ICM-42688-P); an axis at 98 % of it is clipped.
* ``zero_velocity_stddev`` 0.01 m/s: the velocity's 1σ while the rest test holds (a body
  resting on a table moves by micrometres).
* ``acceleration_time`` 0.3 s (``'acceleration'`` model): the correlation time of the body's
  acceleration. The
  accelerometer measures gravity plus acceleration; a filter whose time constant is seconds
  sees the acceleration as white noise of density ``2 σ_a² τ_a`` (its spectrum at low
  frequency), ``σ_a²`` its power, measured as it happens (:mod:`.gravity_update`). Hand-held
  and robot motions reverse their acceleration within a fraction of a second; sustained
  accelerations (a cornering vehicle) need a longer time.
* ``motion_power_time`` 1 s: the averaging time of that power.
* ``gravity_gate``, ``magnetometer_gate``, ``rest_gate``: chi-square bounds of the innovation
  tests (99.99 % quantiles for 2, 1 and 3 degrees of freedom).
* ``update_interval`` 0.05 s: samples gathered between two updates (20 Hz).
* ``rest_seconds`` 0.25 s, ``rest_noise_factor`` 3, ``max_rest_rate`` 0.05 rad/s,
  ``gravity_tolerance`` 0.5 m/s²: the zero-rate update's rest test on whole update intervals
  (as :class:`~rigid_body_attitude.core.estimation.rest.RestDetector` on samples).
* ``declination`` 0 rad: magnetic north east of true north (a WMM value for the place).
* ``learn_hard_iron`` (true) and ``hard_iron_time`` 10 s: whether the magnetometer's hard
  iron is learned as the body turns, and the forgetting time of that fit (:mod:`.hard_iron`:
  a magnet fixed to a turning body is learned within about two of it).
* ``estimate_intrinsic`` (true) and ``estimate_accelerometer_bias`` (false): whether the
  updates estimate the gyro's scale-factor and misalignment errors and the accelerometer bias,
  or only consider them (:mod:`.filter_covariance`, :mod:`.estimator`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from rigid_body_attitude.core.errors import InputError

__all__ = ['EstimatorSettings', 'MOTION_MODELS']

#: The motion models of the gravity measurement: the velocity's (:mod:`.velocity_update`) or
#: the acceleration's (:mod:`.gravity_update`).
MOTION_MODELS = ('velocity', 'acceleration')

_DEGREE = math.pi / 180.0


@dataclass(frozen=True)
class EstimatorSettings:
    """The filter's settings (module docstring; SI units, angles in rad)."""

    accelerometer_random_walk: float = 3.0e-3
    magnetometer_noise_density: float = 1.5e-7
    magnetometer_timing: float = 0.01
    magnetometer_delay: float = 0.0
    magnetic_disturbance_stddev: float = 2.0 * _DEGREE
    magnetic_disturbance_time: float = 10.0
    field_norm_tolerance: float = 0.1
    field_dip_tolerance: float = 10.0 * _DEGREE
    new_field_seconds: float = 20.0
    new_field_min_rate: float = 20.0 * _DEGREE
    acceleration_time: float = 0.3
    motion_power_time: float = 1.0
    gravity_gate: float = 18.42
    magnetometer_gate: float = 15.13
    rest_gate: float = 21.11
    update_interval: float = 0.05
    rest_seconds: float = 0.25
    rest_noise_factor: float = 3.0
    max_rest_rate: float = 0.05
    gravity_tolerance: float = 0.5
    declination: float = 0.0
    estimate_intrinsic: bool = True
    estimate_accelerometer_bias: bool = False
    learn_hard_iron: bool = True
    hard_iron_time: float = 10.0
    motion_model: str = 'acceleration'
    velocity_time: float = 0.5
    zero_velocity_stddev: float = 0.01
    accelerometer_range: float = 16.0 * 9.80665
    sample_timing: float = 0.002

    def __post_init__(self) -> None:
        """Every number finite and >= 0 (times and gates > 0), the declination in [-π, π]."""
        if self.motion_model not in MOTION_MODELS:
            raise InputError(f'Expected `motion_model` to be one of {", ".join(MOTION_MODELS)}, '
                             f'got {self.motion_model!r}')
        for field in fields(self):
            value = getattr(self, field.name)
            if field.name == 'motion_model':
                continue
            if field.name.startswith(('estimate_', 'learn_')):
                if not isinstance(value, bool):
                    raise InputError(f'Expected `{field.name}` to be true or false, got '
                                     f'{value!r}')
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(f'Expected `{field.name}` to be a number, got {value!r}')
            if field.name == 'declination':
                if not (math.isfinite(value) and abs(value) <= math.pi):
                    raise InputError(f'Expected `declination` in [-pi, pi] rad, got {value!r}')
                continue
            positive = field.name.endswith(('_time', '_gate', '_interval', '_seconds',
                                            'velocity_stddev'))
            if not math.isfinite(value) or value < 0.0 or (positive and value == 0.0):
                bound = '> 0' if positive else '>= 0'
                raise InputError(f'Expected `{field.name}` to be finite and {bound}, got '
                                 f'{value!r}')
