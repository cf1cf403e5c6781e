"""uniform_gravity: the weight ``m g`` on the centre of mass (world frame, ENU by default).

Needs ``translation`` in the same scene. Assumption: uniform field (no gradient, no torque
about the centre of mass).
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from rigid_body_attitude.core.effects.base import Effect, Parameter, register, vector3

STANDARD_GRAVITY = [0.0, 0.0, -9.80665]


@register
class UniformGravity(Effect):
    """Weight [N] in the world frame."""

    name = 'uniform_gravity'
    description = 'weight m g on the centre of mass'
    parameters = {'gravity': Parameter(vector3, STANDARD_GRAVITY, 'world frame [m/s²]')}
    requires = ('translation',)

    def force_world(self, t: float, attitude: NDArray[Any]) -> NDArray[Any]:
        """``m g`` [N]."""
        return self.body.mass * self.params['gravity']
