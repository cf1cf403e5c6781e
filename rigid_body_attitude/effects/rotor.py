"""rotor: a gyrostat rotor (momentum wheel) with constant or commanded momentum.

The rotor's momentum ``h`` relative to the body (body axes) enters Euler's equations as
``J ω̇ + ω × (J ω + h) = M − ḣ`` (physics.md §1; Hughes §3.4; Basilisk reaction wheels). With
``commanded: false`` ``h`` is constant and the rotor only adds gyroscopic stiffness. With
``commanded: true`` the ``rotor_torque`` input ``u`` (the motor torque on the rotor, body axes)
drives ``ḣ = u``, held until ``timeout`` and then zero; the body feels ``−u``. ``h(t)`` is
piecewise linear in time, so it is evaluated exactly at every integrator stage. ``J`` is the
inertia of the whole gyrostat with the rotor locked; the rotor's own spin energy is not in
``T``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.effects.base import (
    REQUIRED, BodyProperties, Effect, HeldInput, Parameter, boolean, positive, register,
    vector3)


@register
class Rotor(Effect):
    """Gyrostat rotor momentum ``h`` [N m s] and its rate ``ḣ`` [N m], body axes."""

    name = 'rotor'
    description = 'gyrostat rotor: constant momentum, or driven by the rotor_torque input'
    parameters = {
        'momentum': Parameter(vector3, REQUIRED, 'initial rotor momentum, body [N m s]'),
        'commanded': Parameter(boolean, False, 'drive ḣ from the rotor_torque input'),
        'timeout': Parameter(positive, 0.5, 'seconds a rotor torque command is held [s]'),
    }
    inputs = {'rotor_torque': 'motor torque on the rotor, body [N m]'}

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Start at the initial momentum with no motor torque."""
        super().__init__(params, body)
        self.command = HeldInput(self, self.params['timeout'])
        self.reset()

    @property
    def input_names(self) -> frozenset[str]:
        """``rotor_torque`` only when the rotor is commanded."""
        return frozenset(self.inputs) if self.params['commanded'] else frozenset()

    def reset(self) -> None:
        """Back to the initial momentum, no motor torque."""
        self.command.reset()
        self.momentum_at_command = np.array(self.params['momentum'])
        self.command_time = 0.0

    def accept_input(self, input_name: str, t: float, value: NDArray[Any]) -> None:
        """Start applying motor torque ``value`` at ``t`` (momentum continuous at ``t``)."""
        self.momentum_at_command = self.rotor_momentum(t)[0]
        self.command_time = float(t)
        self.command.set(t, value)

    def rotor_momentum(self, t: float) -> tuple[NDArray[Any], NDArray[Any]]:
        """``(h(t), ḣ(t))``: linear growth while the command is held, constant after."""
        if not np.isfinite(self.command.stamp):
            return self.momentum_at_command, np.zeros(3)
        held_until = self.command.stamp + self.command.timeout
        elapsed = max(0.0, min(t, held_until) - self.command_time)
        momentum = self.momentum_at_command + self.command.value * elapsed
        rate = self.command.value if self.command.active(t) else np.zeros(3)
        return momentum, rate
