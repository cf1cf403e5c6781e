"""The magnetometer: hard- and soft-iron correction, and a measurement of heading only.

**Correction** (sensor frame): ``m = S (m_raw − h)`` with the hard-iron offset ``h`` [T] (a
field carried with the sensor) and the soft-iron matrix ``S`` (the distortion of materials
carried with it), from a calibration (:class:`MagnetometerCalibration`); identity and zero
without one.

**Heading measurement.** The field averaged over an interval in the world frame with the
estimated attitude (:class:`.interval_sums.MagneticInterval`), ``m̄``, has the horizontal
direction ``α(m̄) = atan2(north · m̄, east · m̄)`` (an angle about the world's up: east × north
= up in any right-handed world frame). Magnetic north lies at ``α_ref = atan2(cos D, sin D)``
for the declination ``D``. With ``q_true = exp(δθ) ⊗ q_est`` the estimated field is
``m̄ = m_true + [m_true×] δθ`` to first order, and the true one lies at ``α_ref + d`` (``d``
the disturbance state of :mod:`.filter_covariance`), so the residual is::

    y = α_ref − α(m̄) = −∇α(m̄)ᵀ [m̄×] δθ − d + v,     ∇α(v) = ((e·v) n − (n·v) e) / |v_h|²

(``e``, ``n`` east and north). The row ``−∇αᵀ [m̄×]`` has, besides ``1`` on the vertical
axis, terms on the horizontal ones: a tilt error turns the field's vertical part (the dip,
68° in Berlin) into a heading error of ``tan(dip)`` times the tilt, and the covariance knows.
``v`` is the magnetometer's white noise averaged over the interval's ``k`` samples,
variance ``σ_m²/(k |m̄_h|²)``, plus the error of its timing.

**Timing.** A magnetometer filters its samples and samples at a rate of its own: the field it
reports was the field ``d`` (``magnetometer_delay``, measured by
:mod:`.magnetometer_timing`) before its stamp. Each sample is therefore paired with the
attitude at its own instant: the body's turn ``φ`` over the last ``d`` (plus the sample's age
behind the gyro's) is undone, ``m ← exp(−φ) m`` (:func:`turned_back`), before it enters the
world-frame mean. What remains is the jitter of the instants, 1σ ``δt``
(``magnetometer_timing``: a sample held until the next has an age spread uniformly over the
magnetometer's output period ``P``, ``δt = P/√12``), a heading error of variance
``(|ω̄| δt)²``, and the amplitude the magnetometer's filter takes from a field turning at
``|ω|`` (a first-order filter of delay ``d`` passes ``1/√(1 + (|ω| d)²)`` of it, a direction
error of about ``(|ω| d)²/2``, ``|ω|`` the interval's RMS rate). When their sum exceeds the
disturbance tolerated (``magnetic_disturbance_stddev``) the interval is skipped (outcome
``turning``).

**Heading only.** The update's gain is kept off the tilt: its rows of the world's horizontal
axes are zero, and its gyro-bias rows are projected onto the body's vertical (``u uᵀ`` with
``u = R̄ᵀ up``), so that no correction made from a field, disturbed or not, can tilt the
attitude, at once or later through the bias. The Joseph form
(:func:`~rigid_body_attitude.core.estimation.kalman_update.joseph_update`) keeps the
covariance true under this gain (Laidig and Seel's VQF corrects heading only for the same
reason: Information Fusion 91, 2023, section 3.4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.filter_covariance import (
    ATTITUDE, DISTURBANCE, FILTER_STATE_SIZE, GYRO_BIAS)

__all__ = ['HeadingMeasurement', 'MagnetometerCalibration', 'heading_angle',
           'heading_measurement', 'heading_only_gain', 'turned_back']

FloatArray = NDArray[np.float64]
#: Largest hard-iron offset accepted [T]: 1 mT, twenty times the Earth's field (a magnet
#: on the sensor saturates a magnetometer well before).
MAX_HARD_IRON = 1e-3


@dataclass(frozen=True)
class MagnetometerCalibration:
    """Hard iron ``hard_iron`` [T] (3) and soft iron ``soft_iron`` (3×3, row-major 9 numbers)
    of one magnetometer, sensor frame (module docstring); InputError naming a bad value."""

    hard_iron: tuple[float, float, float] = (0.0, 0.0, 0.0)
    soft_iron: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        """Finite values, the offset within :data:`MAX_HARD_IRON`, ``S`` invertible."""
        if len(self.hard_iron) != 3 or not all(
                math.isfinite(value) and abs(value) <= MAX_HARD_IRON for value in self.hard_iron):
            raise InputError(f'Expected `hard_iron` as 3 finite values of at most '
                             f'{MAX_HARD_IRON:g} T, got {self.hard_iron!r}')
        matrix = np.array(self.soft_iron, dtype=np.float64)
        if matrix.shape != (9,) or not np.all(np.isfinite(matrix)):
            raise InputError(f'Expected `soft_iron` as 9 finite values (3x3 row-major), got '
                             f'{self.soft_iron!r}')
        if not np.linalg.cond(matrix.reshape(3, 3)) < 1e3:
            raise InputError(f'Expected `soft_iron` to be well conditioned (condition number '
                             f'below 1000), got {self.soft_iron!r}')

    def learned(self, offset: NDArray[np.float64]) -> MagnetometerCalibration:
        """This correction with a further hard-iron ``offset`` [T] found in the corrected
        field (:mod:`.hard_iron`): ``S (m − h) − o = S (m − h − S⁻¹ o)``."""
        extra = np.linalg.solve(np.array(self.soft_iron).reshape(3, 3), offset)
        h = self.hard_iron
        return replace(self, hard_iron=(h[0] + float(extra[0]), h[1] + float(extra[1]),
                                        h[2] + float(extra[2])))

    def corrected(self, raw: tuple[float, float, float]) -> tuple[float, float, float]:
        """``S (m_raw − h)`` [T] (plain floats)."""
        hx, hy, hz = self.hard_iron
        s00, s01, s02, s10, s11, s12, s20, s21, s22 = self.soft_iron
        mx, my, mz = raw[0] - hx, raw[1] - hy, raw[2] - hz
        return (s00 * mx + s01 * my + s02 * mz, s10 * mx + s11 * my + s12 * mz,
                s20 * mx + s21 * my + s22 * mz)


class HeadingMeasurement(NamedTuple):
    """``h`` (1, n), the residual (1,) [rad], the white-noise variance ``r`` (1, 1) [rad²]."""

    h: FloatArray
    residual: FloatArray
    r: FloatArray


def heading_angle(vector: FloatArray, east: FloatArray, north: FloatArray) -> float:
    """``α(v) = atan2(north · v, east · v)`` [rad]: the horizontal direction of ``v``."""
    return math.atan2(float(north @ vector), float(east @ vector))


def heading_measurement(mean_field: FloatArray, east: FloatArray, north: FloatArray,
                        declination: float, noise_variance: float,
                        timing_variance: float = 0.0) -> HeadingMeasurement:
    """The measurement of the module docstring from the interval's mean world-frame field
    [T]; ``noise_variance`` the per-axis variance of that mean [T²], ``timing_variance`` the
    heading variance [rad²] of the samples' timing (module docstring)."""
    e, n = float(east @ mean_field), float(north @ mean_field)
    horizontal2 = e * e + n * n
    gradient = (e * north - n * east) / horizontal2
    mx, my, mz = (float(value) for value in mean_field)
    field_cross = np.array([[0.0, -mz, my], [mz, 0.0, -mx], [-my, mx, 0.0]])
    h = np.zeros((1, FILTER_STATE_SIZE))
    h[0, ATTITUDE] = -gradient @ field_cross
    h[0, DISTURBANCE] = -1.0
    reference = math.atan2(math.cos(declination), math.sin(declination))
    residual = math.remainder(reference - math.atan2(n, e), 2.0 * math.pi)
    return HeadingMeasurement(h, np.array([residual]),
                              np.array([[noise_variance / horizontal2 + timing_variance]]))


def heading_only_gain(estimated: NDArray[np.bool_], up_body: FloatArray
                      ) -> tuple[NDArray[np.bool_], FloatArray]:
    """The magnetometer's gain restriction: the rows it may correct (the attitude about the
    world's vertical axis z, vertical in every world frame of
    :data:`~rigid_body_attitude.core.environment.magnetic_field.WORLD_AXES`, and the gyro
    bias; never the intrinsic errors or the accelerometer bias, which would tilt later) and
    the projection ``u uᵀ`` of its gyro-bias rows onto the body's vertical ``u``."""
    rows = np.zeros_like(estimated)
    rows[2] = True
    rows[GYRO_BIAS] = estimated[GYRO_BIAS]
    return rows, np.outer(up_body, up_body)


def turned_back(vector: tuple[float, float, float], turn: tuple[float, float, float]
                ) -> tuple[float, float, float]:
    """``exp(−φ) v``: a body-frame ``vector`` seen before the body turned by the rotation
    vector ``turn`` ``φ`` [rad] (Rodrigues' formula, plain floats): the field sample of a
    delayed magnetometer expressed in the body frame of the gyro's attitude."""
    x, y, z = turn
    angle = math.sqrt(x * x + y * y + z * z)
    if angle < 1e-12:  # guard exact-zero turns
        return vector
    kx, ky, kz = x / angle, y / angle, z / angle
    vx, vy, vz = vector
    c, s = math.cos(angle), -math.sin(angle)
    dot = (kx * vx + ky * vy + kz * vz) * (1.0 - c)
    cx, cy, cz = ky * vz - kz * vy, kz * vx - kx * vz, kx * vy - ky * vx
    return (vx * c + cx * s + kx * dot, vy * c + cy * s + ky * dot, vz * c + cz * s + kz * dot)
