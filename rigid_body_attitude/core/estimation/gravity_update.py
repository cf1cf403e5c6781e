"""Gravity from the accelerometer: a measurement of the world vertical (tilt only).

Over an update interval of length ``T`` the accelerometer's specific force, rotated into the
world frame with the estimated attitude and averaged (:class:`.interval_sums.ImuInterval`),
is ``f̄ = f_true + [f_true×] δθ + R̄ δb_a + n̄`` to first order (``q_true = exp(δθ) ⊗ q_est``,
``R̄`` the interval's mean body → world rotation). Its true value is ``g_v up + ā`` with
``ā`` the body's mean acceleration. The measurement is the horizontal part, in the basis
``E = [east, north]`` of the world axes::

    y = Eᵀ f̄ = g_v Eᵀ [up×] δθ + Eᵀ R̄ δb_a + Eᵀ ā + Eᵀ n̄,

``g_v = up · f̄`` the measured vertical specific force. It carries no heading (``up × up``
is zero); the vertical part ``g_v − g`` is no tilt to first order and serves only to measure
the motion.

**Noise model.** ``n̄`` is the accelerometer's white noise averaged over ``T``: variance
``N_a²/T`` per axis. The acceleration ``ā`` is not white, but a filter whose time constant
is seconds sees it through its low-frequency spectrum, ``2 σ_a² τ_a`` for a first-order
Markov acceleration of power ``σ_a²`` and correlation time ``τ_a`` (Gelb, "Applied Optimal
Estimation", 1974, table 3.8-1): an interval's average then has variance ``2 σ_a² τ_a / T``.
For a motion whose velocity stays bounded (a hand, a robot arm, a vehicle that stops) the
true low-frequency spectrum is smaller still, so the model errs on the safe side. The power
``σ_a²`` is measured as it happens, never assumed: an exponential average over
``motion_power_time`` of the larger of the horizontal innovation's excess over what the
attitude uncertainty and the noise explain (``(|y|² − tr(H P Hᵀ) − 2 N_a²/T)/2``) and the
vertical one (``(|f̄| − g)² − N_a²/T``, free of any tilt error), with ``g`` the specific
force measured at rest during levelling. This is *inflated noise*, not a cut on ``|f|``: a
translation, a vibration or a centripetal acceleration raises ``σ_a²`` within
``motion_power_time``, and the update's weight falls as ``1/σ_a²`` smoothly, so tilt is
never dragged by the acceleration and never blind while the motion is mild.

**Gating.** An innovation whose ``yᵀ S⁻¹ y`` exceeds ``gravity_gate`` (chi-square, 2 dof)
with the power measured *before* the interval is rejected: a tap (a spike of tens of m/s²
for a few milliseconds) is refused while the power catches up.

Assumption and limitation: a sustained acceleration far longer than ``τ_a`` (a long
constant-radius turn of a vehicle, a lift) is partly taken for gravity.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.estimation.filter_covariance import (
    ACCEL_BIAS, ATTITUDE, FILTER_STATE_SIZE)

__all__ = ['GravityMeasurement', 'MotionPower', 'gravity_measurement']

FloatArray = NDArray[np.float64]


class GravityMeasurement(NamedTuple):
    """``h`` (2, n), the residual ``y`` (2,) [m/s²], the noise ``r`` (2, 2) [(m/s²)²]."""

    h: FloatArray
    residual: FloatArray
    r: FloatArray


def gravity_measurement(mean_world_force: FloatArray, mean_rotation: FloatArray,
                        horizontal: FloatArray, up: FloatArray,
                        noise_variance: float) -> GravityMeasurement:
    """The measurement of the module docstring: ``horizontal`` the (3, 2) basis ``E``,
    ``up`` the world's up, ``noise_variance`` the per-axis variance of ``y`` [(m/s²)²]."""
    vertical = float(up @ mean_world_force)
    up_cross = np.array([[0.0, -up[2], up[1]], [up[2], 0.0, -up[0]], [-up[1], up[0], 0.0]])
    h = np.zeros((2, FILTER_STATE_SIZE))
    h[:, ATTITUDE] = vertical * horizontal.T @ up_cross
    h[:, ACCEL_BIAS] = horizontal.T @ mean_rotation
    return GravityMeasurement(h, horizontal.T @ mean_world_force, np.eye(2) * noise_variance)


class MotionPower:
    """The measured acceleration power ``σ_a²`` [(m/s²)²] per axis (module docstring).

    Args:
        averaging_time: ``motion_power_time`` [s].
        correlation_time: ``τ_a`` [s].
    """

    def __init__(self, averaging_time: float, correlation_time: float) -> None:
        self.averaging_time = averaging_time
        self.correlation_time = correlation_time
        self.power = 0.0

    def variance(self, duration: float) -> float:
        """The acceleration's share of the per-axis variance of an interval's mean
        [(m/s²)²]: ``2 σ_a² τ_a / T``."""
        return 2.0 * self.power * self.correlation_time / duration

    def observe(self, measurement: GravityMeasurement, p: FloatArray, force_excess: float,
                white_variance: float, duration: float) -> None:
        """Fold one interval's evidence of motion into the power: the innovation
        ``measurement`` with the covariance ``p`` before the update, ``force_excess`` =
        ``|f̄| − g`` [m/s²], ``white_variance`` = ``N_a²/T`` [(m/s²)²]."""
        h, y = measurement.h, measurement.residual
        explained = float(np.einsum('ij,jk,ik->', h, p, h)) + 2.0 * white_variance
        horizontal = 0.5 * (float(y @ y) - explained)
        vertical = force_excess * force_excess - white_variance
        sample = max(horizontal, vertical, 0.0)
        if not math.isfinite(sample):
            return
        weight = min(duration / self.averaging_time, 1.0)
        self.power += weight * (sample - self.power)
