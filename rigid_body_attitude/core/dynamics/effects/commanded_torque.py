"""commanded_torque: an external torque commanded on the ``torque`` input, held, timed out.

``M(t) = M_cmd`` (body axes) from the command's stamp until ``timeout`` seconds after it (or
until the next command), then zero (counted as ``stale``). Assumptions: the command is
piecewise constant; a command stamped ahead of the propagated time acts from its stamp on. The
propagator ends its steps at the switch times, so the integrator keeps its order across them.
In a batch every body receives the same command. Source: Euler's equations with an external
torque (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36); Basilisk's ``extForceTorque`` effector
holds commands the same way.
"""

from __future__ import annotations

from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, CommandedEffect, FloatArray, Parameter, positive, Quat, register, TorqueEffect,
    Vec)


@register
class CommandedTorque(CommandedEffect, TorqueEffect):
    """Held commanded torque [N m, body axes] with a staleness timeout."""

    name = 'commanded_torque'
    description = 'torque from the `torque` input, held until `timeout`, then zero'
    parameters = {'timeout': Parameter(positive, 0.5, 'seconds a command is held [s]')}
    inputs = {'torque': 'torque_body [N m] (WrenchStamped.wrench.torque)'}

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The torque in force at ``t``, or zero once it is older than ``timeout``."""
        torque: Vec = self.command.vector_at(t)
        return torque

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """The same held command on every body."""
        mx, my, mz = self.command.vector_at(t)
        out[0] += mx
        out[1] += my
        out[2] += mz
