"""Attitude kinematics for a given body rate: ``q̇ = ½ q ⊗ (0, ω_body)``.

Two reference updates (the full strapdown menu lives in :mod:`rigid_body_attitude.integrators`):

* :func:`exp_map_step`: the exact update for a rate held constant over the step,
  ``q ⊗ exp(h ω)``. Keeps ``|q| = 1`` to round-off at any ``h|ω|``.
* :func:`rk4_quaternion_step`: classical RK4 on ``q`` with renormalisation, for a rate given
  as a function of time.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude import quaternion

__all__ = ['exp_map_step', 'quaternion_rate', 'rk4_quaternion_step']

FloatArray = NDArray[np.float64]


def quaternion_rate(attitude: ArrayLike, omega_body: ArrayLike) -> FloatArray:
    """``q̇ = ½ q ⊗ (0, ω_body)`` (batch over leading dimensions)."""
    omega = quaternion.as_vector(omega_body, 'omega_body', finite=False)
    pure = np.concatenate([np.zeros(omega.shape[:-1] + (1,)), omega], axis=-1)
    return 0.5 * quaternion.multiply(attitude, pure)


def exp_map_step(attitude: ArrayLike, omega_body: ArrayLike, h: float) -> FloatArray:
    """``q ⊗ exp(h ω_body)``: exact for a rate held over ``h`` (order 1 for a varying rate).

    Cost: one quaternion exponential and one product. Invariant: ``|q|`` to round-off; the
    result is renormalised so round-off does not accumulate over 10⁷ steps.
    """
    omega = quaternion.as_vector(omega_body, 'omega_body')
    result = quaternion.multiply(attitude, quaternion.exp(h * omega))
    return result / np.linalg.norm(result, axis=-1, keepdims=True)


def rk4_quaternion_step(attitude: ArrayLike, omega_of_time: Callable[[float], ArrayLike],
                        t: float, h: float) -> FloatArray:
    """Classical RK4 on ``q`` for a rate ``ω(t)``, renormalised (order 4, 4 products).

    RK4 does not keep ``|q|`` (it shrinks by about ``(h|ω|)⁶/9216`` per step, physics.md §6);
    the projection restores it.
    """
    q = quaternion.as_quaternion(attitude, 'attitude')
    k1 = quaternion_rate(q, omega_of_time(t))
    k2 = quaternion_rate(q + 0.5 * h * k1, omega_of_time(t + 0.5 * h))
    k3 = quaternion_rate(q + 0.5 * h * k2, omega_of_time(t + 0.5 * h))
    k4 = quaternion_rate(q + h * k3, omega_of_time(t + h))
    result = q + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return result / np.linalg.norm(result, axis=-1, keepdims=True)
