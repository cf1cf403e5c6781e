"""The filter's start: the levelled attitude, its heading from the magnetometer, the covariance.

The levelling (:class:`~rigid_body_attitude.core.estimation.alignment.GravityAligner`)
averages a rest window and gives roll, pitch and the gyro bias. :func:`magnetic_start` extends
the idea to heading: the magnetometer's mean over the same window, rotated into the world
frame with the levelled attitude, has a horizontal direction ``α(m̄)``; turning the attitude
about the world's up by ``α_ref − α(m̄)`` puts magnetic north where the field points
(:mod:`.magnetometer`). The window's field also gives the reference norm and dip
(:mod:`.field_reference`).

The covariance (:func:`start_covariance`) is the levelled one
(:func:`~rigid_body_attitude.core.estimation.gyro_error_model.initial_covariance`: tilt from
the accelerometer's noise and bias prior, gyro bias from the window, heading unknown with
``initial_yaw_stddev``) extended by the accelerometer bias and the heading disturbance
(:mod:`.filter_covariance`); with a magnetometer, one heading update with the window's field
then gives the heading its uncertainty (its noise, the disturbance ``σ_d`` and the tilt's
share through the dip) and the tilt-heading correlation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude.float_quaternion import q_exp, q_multiply, q_normalize
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.estimator import AttitudeEstimator
from rigid_body_attitude.core.estimation.field_reference import FieldReference, field_dip
from rigid_body_attitude.core.estimation.filter_covariance import FilterCovariance
from rigid_body_attitude.core.estimation.gyro_error_model import initial_covariance
from rigid_body_attitude.core.estimation.kalman_update import joseph_update
from rigid_body_attitude.core.estimation.magnetometer import heading_measurement

__all__ = ['magnetic_start', 'start_covariance', 'start_estimator']

FloatArray = NDArray[np.float64]
Quat = tuple[float, float, float, float]


def start_covariance(estimator: AttitudeEstimator, window_seconds: float | None
                     ) -> FilterCovariance:
    """The covariance at start (module docstring), heading unknown."""
    model, settings = estimator.model, estimator.settings
    at_rest = window_seconds is not None
    return FilterCovariance(model, initial_covariance(model, window_seconds),
                            model.accelerometer_bias_stddev, settings.accelerometer_random_walk,
                            settings.magnetic_disturbance_stddev,
                            settings.magnetic_disturbance_time,
                            settings.zero_velocity_stddev if at_rest else 1.0)


def magnetic_start(estimator: AttitudeEstimator, q: Quat, mean_field_body: Sequence[float],
                   samples: int, covariance: FilterCovariance) -> tuple[Quat, FieldReference]:
    """The levelled attitude ``q`` turned to magnetic north by the window's mean field [T]
    (body frame, uncorrected; ``samples`` of them), the field's reference, and the heading
    update on ``covariance`` (module docstring). InputError for a field without a
    horizontal part or a non-positive count."""
    field_body = np.array(estimator.magnetometer.corrected(
        (float(mean_field_body[0]), float(mean_field_body[1]), float(mean_field_body[2]))))
    w, x, y, z = q
    rotation = _matrix(q)
    field = rotation @ field_body
    east, north, up = estimator.east, estimator.north, estimator.up
    horizontal = math.hypot(float(east @ field), float(north @ field))
    if not (samples > 0 and math.isfinite(horizontal)
            and horizontal > 1e-3 * float(np.linalg.norm(field))):
        raise InputError(f'Expected a mean magnetic field with a horizontal part over at '
                         f'least one sample, got {tuple(mean_field_body)!r} over {samples!r}')
    declination = estimator.settings.declination
    turn = math.remainder(math.atan2(math.cos(declination), math.sin(declination))
                          - math.atan2(float(north @ field), float(east @ field)), 2 * math.pi)
    q = q_normalize(q_multiply(q_exp(*(turn * up).tolist()), (w, x, y, z)))
    field = _matrix(q) @ field_body
    settings = estimator.settings
    reference = FieldReference(float(np.linalg.norm(field)), field_dip(field, up),
                               settings.field_norm_tolerance, settings.field_dip_tolerance,
                               settings.new_field_seconds, settings.new_field_min_rate)
    noise = settings.magnetometer_noise_density ** 2 * estimator.sample_rate / samples
    measurement = heading_measurement(field, east, north, declination, noise)
    rows = np.zeros_like(estimator.estimated)
    rows[2] = True
    result = joseph_update(covariance.p, measurement.h, np.zeros(1), measurement.r, rows)
    covariance.set(result.covariance)
    return q, reference


def start_estimator(estimator: AttitudeEstimator, q: Quat, gyro_bias: Sequence[float],
                    window_seconds: float | None, gravity: float,
                    mean_field_body: Sequence[float] | None = None, field_samples: int = 0
                    ) -> Quat:
    """Start ``estimator`` from a levelling (attitude ``q``, ``gyro_bias`` [rad/s], the rest
    ``window_seconds`` or None, the specific force's norm at rest ``gravity`` [m/s²]) and,
    when given, the window's mean magnetic field; returns the starting attitude."""
    if not (math.isfinite(gravity) and gravity > 0.0):
        raise InputError(f'Expected the specific force at rest to be > 0 m/s^2, got {gravity!r}')
    covariance = start_covariance(estimator, window_seconds)
    reference = None
    if mean_field_body is not None:
        q, reference = magnetic_start(estimator, q, mean_field_body, field_samples, covariance)
    estimator.start(covariance, gyro_bias, gravity, reference)
    return q


def _matrix(q: Quat) -> FloatArray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
