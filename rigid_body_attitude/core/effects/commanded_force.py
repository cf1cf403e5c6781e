"""commanded_force: a force on the centre of mass from the ``force`` input (body axes).

``F_world = R(q) F_cmd``, held from the command's stamp until ``timeout``, then zero (counted
as ``stale``). Needs ``translation`` in the same scene.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.effects.base import CommandedEffect, Parameter, positive, register


@register
class CommandedForce(CommandedEffect):
    """Held commanded force [N], body axes, applied at the centre of mass."""

    name = 'commanded_force'
    description = 'force from the `force` input (body axes), held until `timeout`'
    parameters = {'timeout': Parameter(positive, 0.5, 'seconds a command is held [s]')}
    inputs = {'force': 'force_body [N] (WrenchStamped.wrench.force)'}
    requires = ('translation',)

    def force_world(self, t: float, attitude: NDArray[Any]) -> NDArray[Any]:
        """``R(q) F_cmd`` [N], zero after the timeout."""
        return quaternion.rotate(attitude, self.command.value_at(t))
