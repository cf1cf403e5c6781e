"""The magnetometer's delay behind the gyro, measured from a recording without any reference.

A magnetometer filters its samples (a digital low-pass inside the part) and often samples at a
rate of its own, so the field it reports at a stamp was the field some milliseconds earlier.
A field constant in the world frame, seen from a rotating body, obeys (body frame)::

    ṁ(t) = −ω(t) × (m(t) − h)

with ``h`` a hard-iron offset the calibration left (a field carried with the body). If the
magnetometer reports ``m(t − d)`` at ``t``, its samples obey the same equation with the gyro's
rate taken ``d`` earlier. Integrated over a window of :data:`WINDOW` seconds (the noise of a
difference of two samples is then small beside the turn), ``m(t + W) − m(t) =
−∫ ω(τ − d) × (m(τ) − h) dτ`` (trapezoids). :func:`magnetometer_delay` finds ``d`` as the shift
of the gyro (linearly interpolated, on a grid of :data:`DELAY_STEP` samples, refined by a
parabola through the best three) that minimises the mean squared residual of that equation
over the windows that turn, ``h`` solved by least squares at each shift (it enters linearly).
Only the gyro and the magnetometer enter: no attitude, no reference. The constraint is the one
gyro-aided magnetometer calibration rests on (Y. Wu, D. Zou, P. Liu, W. Yu, "Dynamic
magnetometer calibration and alignment to inertial sensors by Kalman filtering", IEEE
Transactions on Control Systems Technology, 2018, arXiv:1612.01044), here applied to the
timing. The recording should turn the
body about several axes (a minute of hand-held motion); :func:`magnetometer_delay` refuses
one that barely turns.

Assumptions and limitations: the field is homogeneous where the body moves (no magnet passes);
the soft iron is calibrated; the delay is constant.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import InputError

__all__ = ['DELAY_STEP', 'MIN_TURNING_SAMPLES', 'MagnetometerDelay', 'WINDOW',
           'magnetometer_delay']

FloatArray = NDArray[np.float64]

#: Grid step of the searched shifts [samples].
DELAY_STEP = 0.25
#: Length of the integration windows [s].
WINDOW = 0.05
#: Fewest samples turning at ``min_rate`` or faster the fit needs.
MIN_TURNING_SAMPLES = 1000


class MagnetometerDelay(NamedTuple):
    """The fit: ``delay`` [s] (positive: the magnetometer lags the gyro), the residual hard
    iron ``hard_iron`` [field unit] at that delay, the RMS residual at the delay and at zero
    [field unit/s], and the number of samples used."""

    delay: float
    hard_iron: tuple[float, float, float]
    residual: float
    residual_at_zero: float
    samples: int


def magnetometer_delay(rates: FloatArray, fields: FloatArray, sample_rate: float,
                       max_delay: float = 0.05, min_rate: float = 0.5) -> MagnetometerDelay:
    """The magnetometer's delay (module docstring): ``rates`` (n, 3) [rad/s] and ``fields``
    (n, 3) [any unit] sampled together at ``sample_rate`` [Hz], the shifts searched within
    ``±max_delay`` [s], the samples used those turning at ``min_rate`` [rad/s] or faster.
    InputError for arrays of the wrong shape, non-finite values, or too little turning."""
    rates = np.asarray(rates, dtype=np.float64)
    fields = np.asarray(fields, dtype=np.float64)
    if rates.ndim != 2 or rates.shape[1] != 3 or fields.shape != rates.shape:
        raise InputError(f'Expected rates and fields of shape (n, 3), got {rates.shape} and '
                         f'{fields.shape}')
    if not (np.all(np.isfinite(rates)) and np.all(np.isfinite(fields))):
        raise InputError('Expected finite rates and fields')
    if not (math.isfinite(sample_rate) and sample_rate > 0.0):
        raise InputError(f'Expected sample_rate > 0 Hz, got {sample_rate!r}')
    width = max(int(round(WINDOW * sample_rate)), 1)
    turning = np.linalg.norm(rates, axis=1) >= min_rate
    starts = np.flatnonzero(turning[:-width])
    if starts.size < MIN_TURNING_SAMPLES:
        raise InputError(f'Expected at least {MIN_TURNING_SAMPLES} samples turning at '
                         f'{min_rate:g} rad/s or faster, got {starts.size}')
    windows = _Windows(rates, fields, sample_rate, starts, width)
    reach = max(int(math.ceil(max_delay * sample_rate / DELAY_STEP)), 1)
    shifts = np.arange(-reach, reach + 1) * DELAY_STEP
    residuals = np.array([windows.fit(shift)[0] for shift in shifts])
    best = int(np.argmin(residuals))
    shift = float(shifts[best])
    if 0 < best < len(shifts) - 1:
        low, mid, high = residuals[best - 1:best + 2]
        curvature = low - 2.0 * mid + high
        if curvature > 0.0:
            shift += 0.5 * (low - high) / curvature * DELAY_STEP
    residual, hard_iron = windows.fit(shift)
    return MagnetometerDelay(float(shift / sample_rate),
                             (float(hard_iron[0]), float(hard_iron[1]), float(hard_iron[2])),
                             math.sqrt(residual), math.sqrt(windows.fit(0.0)[0]),
                             int(starts.size))


class _Windows:
    """The windows' equations for any shift: ``Δm = −Σ ω × m̄ Δt + (Σ ω Δt) × h``."""

    def __init__(self, rates: FloatArray, fields: FloatArray, sample_rate: float,
                 starts: NDArray[np.int_], width: int) -> None:
        self.rates, self.dt = rates, 1.0 / sample_rate
        self.starts, self.width = starts, width
        self.change = fields[starts + width] - fields[starts]
        #: Trapezoid midpoints: step j (from sample j - 1 to j) sees (m[j-1] + m[j]) / 2.
        self.middle = np.concatenate([fields[:1], 0.5 * (fields[1:] + fields[:-1])])

    def fit(self, shift: float) -> tuple[float, FloatArray]:
        """Mean squared residual [field²] with the gyro ``shift`` samples earlier, and ``h``."""
        count = self.rates.shape[0]
        position = np.clip(np.arange(count) - shift, 0.0, count - 1.0)
        lower = np.floor(position).astype(np.int_)
        upper = np.minimum(lower + 1, count - 1)
        weight = (position - lower)[:, None]
        omega = self.rates[lower] * (1.0 - weight) + self.rates[upper] * weight
        turn = np.concatenate([np.zeros((1, 3)), np.cumsum(np.cross(omega, self.middle)
                                                           * self.dt, axis=0)])
        angle = np.concatenate([np.zeros((1, 3)), np.cumsum(omega * self.dt, axis=0)])
        first, last = self.starts + 1, self.starts + self.width + 1
        known = self.change + (turn[last] - turn[first])  # = (Σ ω Δt) × h when d is right
        x, y, z = (angle[last] - angle[first]).T
        zeros = np.zeros_like(x)
        cross = np.stack([np.stack([zeros, -z, y], 1), np.stack([z, zeros, -x], 1),
                          np.stack([-y, x, zeros], 1)], 1)
        hard_iron, *_ = np.linalg.lstsq(cross.reshape(-1, 3), known.reshape(-1), rcond=None)
        residual = known - cross @ hard_iron
        return float(np.mean(np.sum(residual * residual, axis=1))), hard_iron
