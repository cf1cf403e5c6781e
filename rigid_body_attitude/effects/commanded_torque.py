"""commanded_torque: an external torque commanded on the ``torque`` input, held, timed out.

``M(t) = M_cmd`` (body axes) from the command's stamp until ``timeout`` seconds after it,
then zero (counted as ``stale``). Assumptions: the command is piecewise constant; a command
stamped in the future of the propagated time acts from that time on.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from rigid_body_attitude.effects.base import (
    BodyProperties, Effect, HeldInput, Parameter, positive, register)


@register
class CommandedTorque(Effect):
    """Held commanded torque [N m, body axes] with a staleness timeout."""

    name = 'commanded_torque'
    description = 'torque from the `torque` input, held until `timeout`, then zero'
    parameters = {'timeout': Parameter(positive, 0.5, 'seconds a command is held [s]')}
    inputs = {'torque': 'torque_body [N m] (WrenchStamped.wrench.torque)'}

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Validate ``timeout``; no command is held initially."""
        super().__init__(params, body)
        self.command = HeldInput(self, self.params['timeout'])

    def reset(self) -> None:
        """Drop the held command."""
        self.command.reset()

    def accept_input(self, input_name: str, t: float, value: NDArray[Any]) -> None:
        """Hold the commanded torque ``value`` from ``t``."""
        self.command.set(t, value)

    def torque_body(self, t: float, attitude: NDArray[Any],
                    omega_body: NDArray[Any]) -> NDArray[Any]:
        """The held torque, or zero once it is older than ``timeout``."""
        return self.command.value_at(t)
