"""The gyro bias at rest: a zero-rate pseudo-measurement on whole update intervals.

At rest the true rate is zero, so the bias-corrected rate ``ω_m − b_est`` averaged over an
interval of length ``T`` measures the bias error: ``ω̄ = δb + n̄`` with ``n̄`` the gyro's
white noise averaged (variance ``N²/T`` per axis; the intrinsic errors act on a zero rate).
The pseudo-measurement ``y = ω̄``, ``H = [0 I 0]`` on the bias, corrects the bias and,
through the covariance, nothing else that the rest says nothing about (P. D. Groves,
"Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems", 2nd ed., 2013,
section 15.3.3, the zero angular rate update).

:class:`RestIntervals` decides rest on whole intervals, as
:class:`~rigid_body_attitude.core.estimation.rest.RestDetector` does on samples: within the
interval the rate's and the specific force's total spreads are at most ``rest_noise_factor``
times their white-noise figures (``√3 N √rate``), ``|ω̄|`` at most ``max_rest_rate``,
``||f̄| − g|`` at most ``gravity_tolerance``, and so for ``rest_seconds`` in a row. A slow
steady turn that passes the test is refused by the update's innovation gate (its mean rate
is far outside the bias's uncertainty).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.estimation.filter_covariance import FILTER_STATE_SIZE, GYRO_BIAS
from rigid_body_attitude.core.estimation.interval_sums import ImuInterval

__all__ = ['RestIntervals', 'zero_rate_measurement']

FloatArray = NDArray[np.float64]


def zero_rate_measurement(mean_rate: tuple[float, float, float], gyro_noise_density: float,
                          duration: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(h, y, r)`` of the zero-rate pseudo-measurement (module docstring)."""
    h = np.zeros((3, FILTER_STATE_SIZE))
    h[:, GYRO_BIAS] = np.eye(3)
    return h, np.array(mean_rate), np.eye(3) * gyro_noise_density ** 2 / duration


class RestIntervals:
    """Rest over whole update intervals (module docstring).

    Args:
        rest_seconds: rest needed before the first update [s].
        noise_factor: spreads allowed, in white-noise figures.
        max_rest_rate: [rad/s]; gravity_tolerance: [m/s²].
    """

    def __init__(self, rest_seconds: float, noise_factor: float, max_rest_rate: float,
                 gravity_tolerance: float) -> None:
        self.rest_seconds = rest_seconds
        self.noise_factor = noise_factor
        self.max_rest_rate = max_rest_rate
        self.gravity_tolerance = gravity_tolerance
        self.seconds = 0.0

    def at_rest(self, interval: ImuInterval, gyro_noise: float, accel_noise: float,
                gravity: float) -> bool:
        """Whether the body has rested ``rest_seconds`` up to the end of ``interval``;
        ``gyro_noise`` [rad/s] and ``accel_noise`` [m/s²] the per-sample white noise."""
        gyro_spread, accel_spread = interval.spreads()
        limit = self.noise_factor * math.sqrt(3.0)
        wx, wy, wz = interval.mean_rate()
        quiet = (gyro_spread <= limit * gyro_noise and accel_spread <= limit * accel_noise
                 and wx * wx + wy * wy + wz * wz <= self.max_rest_rate ** 2
                 and abs(interval.mean_force_norm() - gravity) <= self.gravity_tolerance)
        self.seconds = self.seconds + interval.duration if quiet else 0.0
        return quiet and self.seconds >= self.rest_seconds
