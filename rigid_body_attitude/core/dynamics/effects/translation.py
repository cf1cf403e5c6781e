"""translation: centre-of-mass motion ``m a = F`` so the published pose position moves.

State: position and velocity of the centre of mass in the world frame. Forces come from the
scene's force effects (``commanded_force``, ``uniform_gravity``), summed by the propagator and
evaluated at both ends of each step; the update

    v⁺ = v + h (a₀ + a₁)/2,   x⁺ = x + h v + h² (2 a₀ + a₁)/6

is exact for a force linear in time over the step (constant gravity, held commands in a
slowly turning body) and third-order otherwise. The work ``h (v₀·F₀ + v₁·F₁)/2`` goes into
the energy balance. Assumption: translation does not act back on the rotation (forces
through the centre of mass). Source: Newton's second law; the velocity update is the
trapezoidal rule, the position update its exact integral for a linear force.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BodyProperties, FloatArray, ForceSum, Parameter, Quat, register, StatefulEffect,
    vector3)


@register
class Translation(StatefulEffect):
    """Centre-of-mass position [m] and velocity [m/s] in the world frame."""

    name = 'translation'
    description = 'centre-of-mass motion m a = F under the force effects'
    parameters = {
        'initial_position': Parameter(vector3, [0.0, 0.0, 0.0], 'world frame [m]'),
        'initial_velocity': Parameter(vector3, [0.0, 0.0, 0.0], 'world frame [m/s]'),
    }
    carries_position = True

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Start at the initial position and velocity."""
        super().__init__(params, body)
        self.reset()

    def reset(self) -> None:
        """Back to the initial position and velocity."""
        self.position_floats = as_vec(self.params['initial_position'])
        self.velocity_floats = as_vec(self.params['initial_velocity'])

    @property
    def position(self) -> FloatArray:
        """Centre of mass [m, world]."""
        return np.array(self.position_floats)

    @property
    def velocity(self) -> FloatArray:
        """Velocity of the centre of mass [m/s, world]."""
        return np.array(self.velocity_floats)

    def set_position(self, position_world: FloatArray) -> None:
        """Re-initialise the position (velocity kept), e.g. from a ``set_pose`` message."""
        self.position_floats = as_vec(position_world)

    def advance(self, t: float, h: float, attitude_start: Quat, attitude_end: Quat,
                force_world: ForceSum) -> float:
        """Advance position and velocity over ``h``; return the work of the forces [J]."""
        mass = self.body.mass
        f0 = force_world(t, attitude_start)
        f1 = force_world(t + h, attitude_end)
        (x0, x1, x2), (v0, v1, v2) = self.position_floats, self.velocity_floats
        scale = h * h / (6.0 * mass)
        half = 0.5 * h / mass
        self.position_floats = (x0 + h * v0 + scale * (2.0 * f0[0] + f1[0]),
                                x1 + h * v1 + scale * (2.0 * f0[1] + f1[1]),
                                x2 + h * v2 + scale * (2.0 * f0[2] + f1[2]))
        u0, u1, u2 = v0 + half * (f0[0] + f1[0]), v1 + half * (f0[1] + f1[1]), v2 + half * (
            f0[2] + f1[2])
        self.velocity_floats = (u0, u1, u2)
        return 0.5 * h * (v0 * f0[0] + v1 * f0[1] + v2 * f0[2]
                          + u0 * f1[0] + u1 * f1[1] + u2 * f1[2])

    def kinetic_energy(self) -> float:
        """``½ m v²`` [J]."""
        vx, vy, vz = self.velocity_floats
        return 0.5 * self.body.mass * (vx * vx + vy * vy + vz * vz)

    def outputs(self) -> dict[str, FloatArray]:
        """``position`` and ``velocity`` in the world frame."""
        return {'position': self.position, 'velocity': self.velocity}

    @staticmethod
    def batch_advance(h: float, mass: FloatArray, position: FloatArray, velocity: FloatArray,
                      force_start: FloatArray, force_end: FloatArray) -> None:
        """:meth:`advance` for many bodies, in place: ``position`` and ``velocity`` (3, n),
        forces (3, n) at both ends of the step, ``mass`` (n,) or a float."""
        position += h * velocity
        position += h * h / (6.0 * mass) * (2.0 * force_start + force_end)
        velocity += 0.5 * h / mass * (force_start + force_end)
