"""The gyro error budget of the attitude covariance: noise, bias walk, intrinsic errors.

A gyro sample is modelled as (body frame, rad/s)::

    ω_m = (I + E) ω + b + n

with ``ω`` the true rate, ``n`` white noise of density ``gyroscope_noise_density`` N
[rad/s/√Hz] (angle random walk), ``b`` a bias that walks with density
``gyroscope_random_walk`` K [rad/s²/√Hz] (kalibr's names and units), and ``E`` a constant
3×3 matrix of intrinsic errors: scale-factor errors on its diagonal, axis misalignment
(cross-axis sensitivity) off it, each a random constant with a prior standard deviation.

The levelling at start gives the initial uncertainty: roll and pitch from the accelerometer
mean over the window (noise and bias), yaw from ``initial_yaw_stddev``, the bias from the
window's gyro mean.

Defaults for a consumer MEMS gyro when the user gives none, 1σ taken as the datasheet's
typical figure (Bosch Sensortec states its typical values as 1σ of the production spread,
min/max as 3σ):

* ``gyroscope_noise_density`` 2.44·10⁻⁴ rad/s/√Hz: 0.014 °/s/√Hz, Bosch BMI088 data sheet
  (BST-BMI088-DS001), gyroscope rate noise density.
* ``gyroscope_turn_on_bias`` 1.75·10⁻² rad/s: ±1 °/s, BMI088 zero-rate offset (used when no
  rest window estimates the bias).
* ``gyroscope_scale_stddev`` 0.01: ±1 %, BMI088 sensitivity tolerance.
* ``gyroscope_misalignment_stddev`` 0.0125: ±1.25 %, TDK InvenSense ICM-42688-P data sheet
  (DS-000347), gyroscope cross-axis sensitivity.
* ``gyroscope_random_walk`` 4·10⁻⁵ rad/s²/√Hz: consumer data sheets give no bias random walk;
  this is twice the figure of kalibr's own example ``imu.yaml`` (ADIS16448, 1.94·10⁻⁵), as
  OpenVINS and kalibr users inflate it for cheaper parts. Measure yours with ``imu_noise``.
* ``accelerometer_noise_density`` 1.72·10⁻³ m/s²/√Hz: 175 µg/√Hz, BMI088 accelerometer
  output noise density.
* ``accelerometer_bias_stddev`` 0.196 m/s²: ±20 mg, BMI088 and ICM-42688-P zero-g offset.
  The levelled tilt is off by the accelerometer bias over g: 1.15° 1σ per horizontal axis.
* ``initial_yaw_stddev`` π rad: without a magnetometer or ``set_pose`` the heading is unknown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import InputError

__all__ = ['ERROR_STATE_SIZE', 'GRAVITY', 'GyroErrorModel', 'initial_covariance',
           'levelled_tilt_stddev']

FloatArray = NDArray[np.float64]

#: Standard gravity [m/s²], the levelling's reference magnitude.
GRAVITY = 9.80665
#: Error state: world-frame attitude error (3), gyro bias error (3), intrinsic errors E (9,
#: row-major: E[i, j] at 6 + 3 i + j).
ERROR_STATE_SIZE = 15
_DEGREE = math.pi / 180.0


@dataclass(frozen=True)
class GyroErrorModel:
    """Error budget of a gyro (SI units; names as kalibr's ``imu.yaml`` where it has them).

    Attributes:
        gyroscope_noise_density: white-noise density N [rad/s/√Hz] (angle random walk).
        gyroscope_random_walk: bias random-walk density K [rad/s²/√Hz].
        gyroscope_turn_on_bias: prior 1σ of the bias [rad/s] when no rest window estimates it.
        gyroscope_scale_stddev: prior 1σ of each scale-factor error (dimensionless).
        gyroscope_misalignment_stddev: prior 1σ of each off-diagonal (cross-axis) error.
        accelerometer_noise_density: white-noise density [m/s²/√Hz] of the levelling.
        accelerometer_bias_stddev: prior 1σ of the accelerometer bias [m/s²].
        initial_yaw_stddev: 1σ of the initial heading [rad].
    """

    gyroscope_noise_density: float = 0.014 * _DEGREE
    gyroscope_random_walk: float = 4.0e-5
    gyroscope_turn_on_bias: float = 1.0 * _DEGREE
    gyroscope_scale_stddev: float = 0.01
    gyroscope_misalignment_stddev: float = 0.0125
    accelerometer_noise_density: float = 175e-6 * GRAVITY
    accelerometer_bias_stddev: float = 0.020 * GRAVITY
    initial_yaw_stddev: float = math.pi

    def __post_init__(self) -> None:
        """Check every field: finite and not negative."""
        for field in fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(f'Expected `{field.name}` to be a number, got {value!r}')
            if not math.isfinite(value) or value < 0.0:
                raise InputError(f'Expected `{field.name}` to be finite and >= 0, got {value!r}')

    def intrinsic_variances(self) -> FloatArray:
        """Prior variances of the 9 entries of E (row-major): scale on the diagonal."""
        variances = np.full((3, 3), self.gyroscope_misalignment_stddev ** 2)
        np.fill_diagonal(variances, self.gyroscope_scale_stddev ** 2)
        return variances.reshape(9)


def levelled_tilt_stddev(model: GyroErrorModel, window_seconds: float) -> float:
    """1σ [rad] of roll or pitch (about a world horizontal axis) after levelling.

    ``√((N_a/g)²/T + (σ_ba/g)²)``: the accelerometer mean over ``T`` seconds has white-noise
    error ``N_a/√T`` per axis, and a bias tilts the measured gravity by ``σ_ba/g``.
    """
    _check_window(window_seconds)
    noise = model.accelerometer_noise_density / GRAVITY
    bias = model.accelerometer_bias_stddev / GRAVITY
    return math.sqrt(noise * noise / window_seconds + bias * bias)


def initial_covariance(model: GyroErrorModel, window_seconds: float | None,
                       yaw_stddev: float | None = None) -> FloatArray:
    """15×15 initial covariance of the error state (see :data:`ERROR_STATE_SIZE`).

    With ``window_seconds`` (a levelling over that rest window): tilt from
    :func:`levelled_tilt_stddev`, bias 1σ ``N/√T`` (the window's mean gyro rate). Without
    (``None``: no levelling): tilt 1σ ``initial_yaw_stddev`` (as unknown as the heading), bias
    1σ ``gyroscope_turn_on_bias``. Yaw 1σ is ``yaw_stddev`` (a heading given by ``set_pose``)
    or else ``model.initial_yaw_stddev``. Intrinsic errors from the model's priors; all blocks
    uncorrelated.
    """
    yaw = model.initial_yaw_stddev if yaw_stddev is None else float(yaw_stddev)
    if not math.isfinite(yaw) or yaw < 0.0:
        raise InputError(f'Expected `initial_yaw_stddev` to be finite and >= 0, got {yaw!r}')
    if window_seconds is None:
        tilt, bias = model.initial_yaw_stddev, model.gyroscope_turn_on_bias
    else:
        tilt = levelled_tilt_stddev(model, window_seconds)
        bias = model.gyroscope_noise_density / math.sqrt(window_seconds)
    diagonal = np.concatenate([[tilt ** 2, tilt ** 2, yaw ** 2], np.full(3, bias ** 2),
                               model.intrinsic_variances()])
    return np.diag(diagonal)


def _check_window(window_seconds: float) -> None:
    if not math.isfinite(window_seconds) or window_seconds <= 0.0:
        raise InputError(f'Expected `window_seconds` to be finite and > 0, got '
                         f'{window_seconds!r}')
