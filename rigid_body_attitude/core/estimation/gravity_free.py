"""The gravity-free acceleration and its covariance (``imu/data``'s companion output).

With the estimated attitude ``q`` (body → world), the specific force ``f`` [m/s², body], the
accelerometer bias estimate ``b_a`` and the gravity measured at rest ``g`` along the world's
up, the body's acceleration in the body frame is ``a = f − b_a − g Rᵀ up``. Its error, with
``q_true = exp(δθ) ⊗ q_est``: ``Rᵀ_est up = Rᵀ_true (I + [δθ×]) up``, so
``δa = g Rᵀ [up×] δθ − δb_a − n`` to first order, and::

    cov(a) = g² Rᵀ [up×] P_θθ [up×]ᵀ R + (Rᵀ [up×] g P_θb + ...)  + P_bb + σ_f² I

with ``σ_f² = N_a² · rate`` the accelerometer's per-sample noise (the cross terms between
attitude and accelerometer bias included). The heading error does not enter (``up × up`` is
zero): the gravity-free acceleration needs no magnetometer.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.filter_covariance import ACCEL_BIAS, ATTITUDE

__all__ = ['gravity_free_acceleration']

FloatArray = NDArray[np.float64]


def gravity_free_acceleration(q: Sequence[float], specific_force: Sequence[float],
                              accel_bias: FloatArray, gravity: float, up: FloatArray,
                              p: FloatArray, sample_variance: float
                              ) -> tuple[FloatArray, FloatArray]:
    """``(a, cov(a))``: the body-frame acceleration [m/s²] and its 3×3 covariance (module
    docstring); ``p`` the filter's covariance, ``sample_variance`` ``σ_f²`` [(m/s²)²]."""
    rotation = quaternion.to_matrix(np.array(q, dtype=np.float64))
    up_body = rotation.T @ up
    acceleration = np.asarray(specific_force, dtype=np.float64) - accel_bias - gravity * up_body
    up_cross = np.array([[0.0, -up[2], up[1]], [up[2], 0.0, -up[0]], [-up[1], up[0], 0.0]])
    jacobian = np.zeros((3, p.shape[0]))
    jacobian[:, ATTITUDE] = gravity * rotation.T @ up_cross
    jacobian[:, ACCEL_BIAS] = -np.eye(3)
    covariance = jacobian @ p @ jacobian.T + np.eye(3) * sample_variance
    return acceleration, 0.5 * (covariance + covariance.T)
