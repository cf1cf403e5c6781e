"""commanded_torque: an external torque commanded on the ``torque`` input, held, timed out.

``M(t) = M_cmd`` (body axes) from the command's stamp until ``timeout`` seconds after it (or
until the next command), then zero (counted as ``stale``). Assumptions: the command is
piecewise constant; a command stamped ahead of the propagated time acts from its stamp on. The
propagator ends its steps at the switch times, so the integrator keeps its order across them.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from rigid_body_attitude.core.effects.base import CommandedEffect, Parameter, positive, register


@register
class CommandedTorque(CommandedEffect):
    """Held commanded torque [N m, body axes] with a staleness timeout."""

    name = 'commanded_torque'
    description = 'torque from the `torque` input, held until `timeout`, then zero'
    parameters = {'timeout': Parameter(positive, 0.5, 'seconds a command is held [s]')}
    inputs = {'torque': 'torque_body [N m] (WrenchStamped.wrench.torque)'}

    def torque_body(self, t: float, attitude: NDArray[Any],
                    omega_body: NDArray[Any]) -> NDArray[Any]:
        """The torque in force at ``t``, or zero once it is older than ``timeout``."""
        return self.command.value_at(t)
