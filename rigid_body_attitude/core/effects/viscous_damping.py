"""viscous_damping: a torque opposing the body rate, ``M = −c ∘ ω`` (per body axis).

Models eddy-current or fluid damping. ``coefficient`` is one number or one per body axis
[N m s/rad], each ≥ 0. The power ``ω·M = −Σ c_i ω_i²`` is never positive, so the kinetic
energy decays monotonically.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.effects.base import (
    REQUIRED, Effect, Parameter, nonnegative, register)


def _coefficient(value: Any) -> NDArray[np.float64]:
    if isinstance(value, (list, tuple)):
        if len(value) != 3:
            raise TypeError('one number or a list of 3 numbers >= 0')
        return np.array([nonnegative(item) for item in value])
    return np.full(3, nonnegative(value))


@register
class ViscousDamping(Effect):
    """Linear rate damping [N m s/rad]."""

    name = 'viscous_damping'
    description = 'torque −c ω opposing the body rate'
    parameters = {'coefficient': Parameter(_coefficient, REQUIRED,
                                           'damping coefficient(s) [N m s/rad]')}
    torque_depends_on_rate = True

    def torque_body(self, t: float, attitude: NDArray[Any],
                    omega_body: NDArray[Any]) -> NDArray[Any]:
        """``−c ∘ ω`` [N m]."""
        return -self.params['coefficient'] * omega_body
