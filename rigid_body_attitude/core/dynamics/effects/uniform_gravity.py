"""uniform_gravity: the weight ``m g`` on the centre of mass (world frame, ENU by default).

Needs ``translation`` in the same scene. Assumption: uniform field (no gradient, no torque
about the centre of mass). Source: Newton's second law.
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, FloatArray, ForceEffect, Parameter, Quat, register, Vec,
    vector3)

STANDARD_GRAVITY = [0.0, 0.0, -9.80665]


@register
class UniformGravity(ForceEffect):
    """Weight [N] in the world frame."""

    name = 'uniform_gravity'
    description = 'weight m g on the centre of mass'
    parameters = {'gravity': Parameter(vector3, STANDARD_GRAVITY, 'world frame [m/s²]')}
    requires = ('translation',)

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Precompute the weight [N]."""
        super().__init__(params, body)
        self.weight = as_vec(body.mass * self.params['gravity'])

    def force(self, t: float, q: Quat) -> Vec:
        """``m g`` [N]."""
        return self.weight

    def add_batch_force(self, t: float, q: FloatArray, chunk: BatchChunk,
                        out: FloatArray) -> None:
        """``m g`` per body (mass and gravity may be dispersed)."""
        out += chunk.parameters['gravity'] * chunk.mass
