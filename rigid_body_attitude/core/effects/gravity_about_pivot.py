"""gravity_about_pivot: the heavy top, a body on a fixed pivot under uniform gravity.

``M = r_c × (m R(q)ᵀ g)`` with ``r_c`` the centre of mass from the pivot in body axes and
``g`` the gravity vector in the world frame (default ENU, ``(0, 0, −9.80665)`` m/s²). The
scene's inertia must be **about the pivot** (parallel-axis theorem applied by the user) and
``mass`` must be given. Assumptions: frictionless fixed pivot, uniform gravity. Energy
``T + m g_z·z_c`` is conserved; the world momentum about the vertical is conserved.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.effects.base import (
    REQUIRED, BodyProperties, Effect, Parameter, register, vector3)

STANDARD_GRAVITY = (0.0, 0.0, -9.80665)


@register
class GravityAboutPivot(Effect):
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

    def potential_energy(self, attitude: NDArray[Any]) -> float:
        """``−m g · R(q) r_c`` [J] (zero with the centre of mass at the pivot's height)."""
        return float(-self.weight_world @ quaternion.rotate(attitude,
                                                            self.params['centre_of_mass']))

    def torque_body(self, t: float, attitude: NDArray[Any],
                    omega_body: NDArray[Any]) -> NDArray[Any]:
        """``r_c × R(q)ᵀ (m g)`` [N m]."""
        weight_body = quaternion.rotate_inverse(attitude, self.weight_world)
        return np.cross(self.params['centre_of_mass'], weight_body)
