"""commanded_force: a force on the centre of mass from the ``force`` input (body axes).

``F_world = R(q) F_cmd``, held from the command's stamp until ``timeout``, then zero (counted
as ``stale``). Needs ``translation`` in the same scene.
"""

from __future__ import annotations

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.effects.base import (
    CommandedEffect, ForceEffect, Parameter, positive, Quat, register, Vec)


@register
class CommandedForce(CommandedEffect, ForceEffect):
    """Held commanded force [N], body axes, applied at the centre of mass."""

    name = 'commanded_force'
    description = 'force from the `force` input (body axes), held until `timeout`'
    parameters = {'timeout': Parameter(positive, 0.5, 'seconds a command is held [s]')}
    inputs = {'force': 'force_body [N] (WrenchStamped.wrench.force)'}
    requires = ('translation',)

    def force(self, t: float, q: Quat) -> Vec:
        """``R(q) F_cmd`` [N], zero after the timeout."""
        return quaternion.rotate_floats(q, self.command.vector_at(t))
