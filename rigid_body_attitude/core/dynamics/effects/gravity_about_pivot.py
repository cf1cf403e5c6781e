"""gravity_about_pivot: the heavy top, a body on a fixed pivot under uniform gravity.

``M = r_c × (m R(q)ᵀ g)`` with ``r_c`` the centre of mass from the pivot in body axes and
``g`` the gravity vector in the world frame (default ENU, ``(0, 0, −9.80665)`` m/s²). The
scene's inertia must be **about the pivot** (parallel-axis theorem applied by the user) and
``mass`` must be given. Assumptions: frictionless fixed pivot, uniform gravity. Energy
``T + m g_z·z_c`` is conserved; the world momentum about the vertical is conserved. Source:
the heavy top with one point fixed (Goldstein, *Classical Mechanics*, §5.7).
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, ConservativeTorque, FloatArray, Parameter, Quat, register,
    REQUIRED, Vec, vector3)

STANDARD_GRAVITY = (0.0, 0.0, -9.80665)


@register
class GravityAboutPivot(ConservativeTorque):
    """Gravity torque about a fixed pivot [N m]."""

    name = 'gravity_about_pivot'
    description = 'gravity torque r_c × m g about a fixed pivot (heavy top)'
    parameters = {
        'centre_of_mass': Parameter(vector3, REQUIRED, 'centre of mass from the pivot, body [m]'),
        'gravity': Parameter(vector3, list(STANDARD_GRAVITY), 'gravity, world frame [m/s²]'),
    }

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Precompute the weight ``m g`` [N]."""
        super().__init__(params, body)
        self.weight_world = body.mass * self.params['gravity']
        self.weight = as_vec(self.weight_world)
        self.centre = as_vec(self.params['centre_of_mass'])

    def potential_energy(self, attitude: FloatArray) -> float:
        """``−m g · R(q) r_c`` [J] (zero with the centre of mass at the pivot's height)."""
        return float(-self.weight_world @ quaternion.rotate(attitude,
                                                            self.params['centre_of_mass']))

    def potential(self, q: Quat) -> float:
        """:meth:`potential_energy` on plain floats [J]."""
        x, y, z = quaternion.rotate_floats(q, self.centre)
        gx, gy, gz = self.weight
        return -(gx * x + gy * y + gz * z)

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """``r_c × R(q)ᵀ (m g)`` [N m]."""
        x, y, z = quaternion.rotate_inverse_floats(q, self.weight)
        cx, cy, cz = self.centre
        return cy * z - cz * y, cz * x - cx * z, cx * y - cy * x

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """Per-body centre of mass and mass (both may be dispersed), shared gravity."""
        gravity = chunk.parameters['gravity']
        x, y, z = quaternion.rotate_rows(q, gravity * chunk.mass, inverse=True)
        cx, cy, cz = chunk.parameters['centre_of_mass']
        out[0] += cy * z - cz * y
        out[1] += cz * x - cx * z
        out[2] += cx * y - cy * x
