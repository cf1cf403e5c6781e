"""constant_torque: a torque of fixed magnitude and direction, in body or world axes.

``M_body = M`` (``frame: body``) or ``M_body = R(q)ᵀ M`` (``frame: world``, e.g. a thruster
fixed in inertial space). Assumption: constant in time.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.effects.base import REQUIRED, Effect, Parameter, register, vector3


def _frame(value: Any) -> str:
    if value not in ('body', 'world'):
        raise ValueError("'body' or 'world'")
    return str(value)


@register
class ConstantTorque(Effect):
    """Constant torque [N m] in body or world axes."""

    name = 'constant_torque'
    description = 'a constant torque in body or world axes'
    parameters = {
        'torque': Parameter(vector3, REQUIRED, 'torque [N m]'),
        'frame': Parameter(_frame, 'body', "'body' or 'world'"),
    }

    def torque_body(self, t: float, attitude: NDArray[Any],
                    omega_body: NDArray[Any]) -> NDArray[Any]:
        """The torque in body axes at ``attitude``."""
        if self.params['frame'] == 'body':
            return self.params['torque']
        return quaternion.rotate_inverse(attitude, self.params['torque'])
