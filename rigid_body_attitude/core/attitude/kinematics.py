"""Attitude kinematics for a given body rate: ``q̇ = ½ q ⊗ (0, ω_body)``.

Two reference updates (the full strapdown menu lives in
:mod:`rigid_body_attitude.core.dynamics.integrators`):
* :func:`exp_map_step`: the exact update for a rate held constant over the step,
  ``q ⊗ exp(h ω)``. Keeps ``|q| = 1`` to round-off at any ``h|ω|``.
* :func:`rk4_quaternion_step`: classical RK4 on ``q`` with renormalisation, for a rate given
  as a function of time.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError

__all__ = ['exp_map_step', 'quaternion_rate', 'rk4_quaternion_step']

FloatArray = NDArray[np.float64]


def quaternion_rate(attitude: ArrayLike, omega_body: ArrayLike) -> FloatArray:
    """``q̇ = ½ q ⊗ (0, ω_body)`` (batch over leading dimensions)."""
    omega = quaternion.as_vector(omega_body, 'omega_body', finite=False)
    pure = np.concatenate([np.zeros(omega.shape[:-1] + (1,)), omega], axis=-1)
    return 0.5 * quaternion.multiply(attitude, pure)


def _checked_attitude(attitude: ArrayLike) -> FloatArray:
    """``attitude`` as a finite, non-zero ``(..., 4)`` array, or :class:`InputError`."""
    q = quaternion.as_quaternion(attitude, 'attitude')
    if np.any(np.linalg.norm(q, axis=-1) == 0.0):
        raise InputError(f'Expected `attitude` to be a non-zero quaternion, got {q.tolist()!r}')
    return q


def _checked_step(h: float) -> float:
    """``h`` as a finite float [s], or :class:`InputError`."""
    try:
        step = float(h)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `h` to be a finite number of seconds, got {h!r}') from err
    if not math.isfinite(step):
        raise InputError(f'Expected `h` to be a finite number of seconds, got {h!r}')
    return step


def exp_map_step(attitude: ArrayLike, omega_body: ArrayLike, h: float) -> FloatArray:
    """``q ⊗ exp(h ω_body)``: exact for a rate held over ``h`` (order 1 for a varying rate).

    Cost: one quaternion exponential and one product. Invariant: ``|q|`` to round-off; the
    result is renormalised so round-off does not accumulate over 10⁷ steps.
    """
    q = _checked_attitude(attitude)
    omega = quaternion.as_vector(omega_body, 'omega_body')
    step = _checked_step(h)
    with np.errstate(over='ignore', invalid='ignore'):  # an overflow is reported just below
        rotation = step * omega
    if not np.all(np.isfinite(rotation)):
        raise InputError(f'Expected a finite rotation `h * omega_body`, got h={h!r}, '
                         f'omega_body={omega.tolist()!r}')
    result = quaternion.multiply(q, quaternion.exp(rotation))
    normalized: FloatArray = result / np.linalg.norm(result, axis=-1, keepdims=True)
    return normalized


def rk4_quaternion_step(attitude: ArrayLike, omega_of_time: Callable[[float], ArrayLike],
                        t: float, h: float) -> FloatArray:
    """Classical RK4 on ``q`` for a rate ``ω(t)``, renormalised (order 4, 4 products).

    RK4 does not keep ``|q|`` (it shrinks by about ``(h|ω|)⁶/9216`` per step: RK4's stability
    function on the imaginary axis); the projection restores it.
    """
    q = _checked_attitude(attitude)
    h = _checked_step(h)

    def rate(time: float) -> FloatArray:
        return quaternion.as_vector(omega_of_time(time), 'omega_body')

    k1 = quaternion_rate(q, rate(t))
    k2 = quaternion_rate(q + 0.5 * h * k1, rate(t + 0.5 * h))
    k3 = quaternion_rate(q + 0.5 * h * k2, rate(t + 0.5 * h))
    k4 = quaternion_rate(q + h * k3, rate(t + h))
    result = q + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    normalized: FloatArray = result / np.linalg.norm(result, axis=-1, keepdims=True)
    return normalized
