"""viscous_damping: a torque opposing the body rate, ``M = −c ∘ ω`` (per body axis).

Models eddy-current or fluid damping. ``coefficient`` is one number or one per body axis
[N m s/rad], each ≥ 0. The power ``ω·M = −Σ c_i ω_i²`` is never positive, so the kinetic
energy decays monotonically. Assumption: linear in the rate (no stiction, no quadratic drag).
Source: the power theorem ``dT/dt = ω·M`` (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, FloatArray, nonnegative, Parameter, Quat, register,
    REQUIRED, TorqueEffect, Vec)


def _coefficient(value: Any) -> FloatArray:
    if isinstance(value, (list, tuple)):
        if len(value) != 3:
            raise TypeError('one number or a list of 3 numbers >= 0')
        return np.array([nonnegative(item) for item in value])
    return np.full(3, nonnegative(value))


@register
class ViscousDamping(TorqueEffect):
    """Linear rate damping [N m s/rad]."""

    name = 'viscous_damping'
    description = 'torque −c ω opposing the body rate'
    parameters = {'coefficient': Parameter(_coefficient, REQUIRED,
                                           'damping coefficient(s) [N m s/rad]')}
    torque_depends_on_rate = True

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Keep the coefficients as plain floats."""
        super().__init__(params, body)
        self.coefficients = as_vec(self.params['coefficient'])

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """``−c ∘ ω`` [N m]."""
        c1, c2, c3 = self.coefficients
        return -c1 * omega[0], -c2 * omega[1], -c3 * omega[2]

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """``−c ∘ ω`` per body (``coefficient`` may be dispersed)."""
        work = chunk.scratch('work', 3)
        np.multiply(chunk.parameters['coefficient'], omega, out=work)
        out -= work
