"""commanded_force: a force on the centre of mass from the ``force`` input (body axes).

``F_world = R(q) F_cmd``, held from the command's stamp until ``timeout``, then zero (counted
as ``stale``). Needs ``translation`` in the same scene.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from rigid_body_attitude import quaternion
from rigid_body_attitude.effects.base import (
    BodyProperties, Effect, HeldInput, Parameter, positive, register)


@register
class CommandedForce(Effect):
    """Held commanded force [N], body axes, applied at the centre of mass."""

    name = 'commanded_force'
    description = 'force from the `force` input (body axes), held until `timeout`'
    parameters = {'timeout': Parameter(positive, 0.5, 'seconds a command is held [s]')}
    inputs = {'force': 'force_body [N] (WrenchStamped.wrench.force)'}
    requires = ('translation',)

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """No command is held initially."""
        super().__init__(params, body)
        self.command = HeldInput(self, self.params['timeout'])

    def reset(self) -> None:
        """Drop the held command."""
        self.command.reset()

    def accept_input(self, input_name: str, t: float, value: NDArray[Any]) -> None:
        """Hold the commanded force ``value`` from ``t``."""
        self.command.set(t, value)

    def force_world(self, t: float, attitude: NDArray[Any]) -> NDArray[Any]:
        """``R(q) F_cmd`` [N], zero after the timeout."""
        return quaternion.rotate(attitude, self.command.value_at(t))
