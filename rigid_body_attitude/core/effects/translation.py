"""translation: centre-of-mass motion ``m a = F`` so the published pose position moves.

State: position and velocity of the centre of mass in the world frame. Forces come from the
scene's force effects (``commanded_force``, ``uniform_gravity``), summed by the propagator and
evaluated at both ends of each step; the update

    v⁺ = v + h (a₀ + a₁)/2,   x⁺ = x + h v + h² (2 a₀ + a₁)/6

is exact for a force linear in time over the step (constant gravity, held commands in a
slowly turning body) and third-order otherwise. The work ``h (v₀·F₀ + v₁·F₁)/2`` goes into
the energy balance. Assumption: translation does not act back on the rotation (forces
through the centre of mass).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.effects.base import Parameter, StatefulEffect, register, vector3

FloatArray = NDArray[np.float64]


@register
class Translation(StatefulEffect):
    """Centre-of-mass position [m] and velocity [m/s] in the world frame."""

    name = 'translation'
    description = 'centre-of-mass motion m a = F under the force effects'
    parameters = {
        'initial_position': Parameter(vector3, [0.0, 0.0, 0.0], 'world frame [m]'),
        'initial_velocity': Parameter(vector3, [0.0, 0.0, 0.0], 'world frame [m/s]'),
    }

    def __init__(self, params: dict[str, Any], body: Any) -> None:
        """Start at the initial position and velocity."""
        super().__init__(params, body)
        self.reset()

    def reset(self) -> None:
        """Back to the initial position and velocity."""
        self.position = np.array(self.params['initial_position'])
        self.velocity = np.array(self.params['initial_velocity'])

    def set_position(self, position_world: FloatArray) -> None:
        """Re-initialise the position (velocity kept), e.g. from a ``set_pose`` message."""
        self.position = np.array(position_world, dtype=np.float64)

    def advance(self, t: float, h: float, attitude_start: FloatArray,
                attitude_end: FloatArray,
                force_world: Callable[[float, FloatArray], FloatArray]) -> float:
        """Advance position and velocity over ``h``; return the work of the forces [J]."""
        mass = self.body.mass
        force_start = force_world(t, attitude_start)
        force_end = force_world(t + h, attitude_end)
        velocity_start = self.velocity
        self.position = self.position + h * velocity_start + h * h * (
            2.0 * force_start + force_end) / (6.0 * mass)
        self.velocity = velocity_start + 0.5 * h * (force_start + force_end) / mass
        return 0.5 * h * float(velocity_start @ force_start + self.velocity @ force_end)

    def kinetic_energy(self) -> float:
        """``½ m v²`` [J]."""
        return 0.5 * self.body.mass * float(self.velocity @ self.velocity)

    def outputs(self) -> dict[str, FloatArray]:
        """``position`` and ``velocity`` in the world frame."""
        return {'position': self.position, 'velocity': self.velocity}
