"""constant_torque: a torque of fixed magnitude and direction, in body or world axes.

``M_body = M`` (``frame: body``) or ``M_body = R(q)ᵀ M`` (``frame: world``, e.g. a thruster
fixed in inertial space). Assumption: constant in time. Source: Euler's equations with an
external torque (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36).
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, FloatArray, Parameter, Quat, register, REQUIRED,
    TorqueEffect, Vec, vector3)


def _frame(value: Any) -> str:
    if value not in ('body', 'world'):
        raise ValueError("'body' or 'world'")
    return str(value)


@register
class ConstantTorque(TorqueEffect):
    """Constant torque [N m] in body or world axes."""

    name = 'constant_torque'
    description = 'a constant torque in body or world axes'
    parameters = {
        'torque': Parameter(vector3, REQUIRED, 'torque [N m]'),
        'frame': Parameter(_frame, 'body', "'body' or 'world'"),
    }

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Keep the torque as plain floats."""
        super().__init__(params, body)
        self.vector = as_vec(self.params['torque'])
        self.in_world = self.params['frame'] == 'world'

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The torque in body axes at attitude ``q``."""
        if self.in_world:
            return quaternion.rotate_inverse_floats(q, self.vector)
        return self.vector

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """Per-body torque vectors (``torque`` may be dispersed), rotated when in world axes."""
        vector = chunk.parameters['torque']
        out += quaternion.rotate_rows(q, vector, inverse=True) if self.in_world else vector
