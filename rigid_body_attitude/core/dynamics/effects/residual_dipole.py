"""residual_dipole: the torque of the spacecraft's own residual magnetic dipole.

``M = m_res × B_b``, ``m_res`` a constant dipole in body axes [A m²] (currents in harnesses and
panels, magnetised parts), ``B_b = R(q)ᵀ B_w(t)`` the scene's field (``magnetic_field:``
section) in body axes (Source: J. R. Wertz (ed.), *Spacecraft Attitude Determination and
Control*, 1978, sec. 17.2, the magnetic disturbance torque; Markley and Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, 2014, sec. 3.3). Typical
small satellites: 0.01 to 0.1 A m². Assumptions: a constant dipole (no induced part). In a
batch the dipole may be dispersed per body.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.batch_rows import cross_rows
from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, FloatArray, Parameter, Quat, register, REQUIRED,
    TorqueEffect, Vec, vector3)


@register
class ResidualDipole(TorqueEffect):
    """Residual-dipole torque ``m_res × B_b`` [N m]."""

    name = 'residual_dipole'
    description = 'torque of a constant residual magnetic dipole in the scene\'s field'
    parameters = {'dipole': Parameter(vector3, REQUIRED, 'residual dipole, body [A m²]')}

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Check the scene's field."""
        super().__init__(params, body)
        self.model = body.environment.required_field(self.name)
        self.dipole = as_vec(self.params['dipole'])

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """``m_res × R(q)ᵀ B_w(t)``."""
        bx, by, bz = quaternion.rotate_inverse_floats(q, self.model.field_world(t))
        x, y, z = self.dipole
        return y * bz - z * by, z * bx - x * bz, x * by - y * bx

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """Each body's dipole in its own attitude."""
        field = quaternion.rotate_rows(q, np.array(self.model.field_world(t))[:, None],
                                       inverse=True)
        dipole = np.broadcast_to(chunk.parameters['dipole'], field.shape)
        cross_rows(dipole, field, out, chunk.scratch('residual', 1)[0], accumulate=True)
