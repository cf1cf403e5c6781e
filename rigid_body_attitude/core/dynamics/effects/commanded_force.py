"""commanded_force: a force on the centre of mass from the ``force`` input (body axes).

``F_world = R(q) F_cmd``, held from the command's stamp until ``timeout``, then zero (counted
as ``stale``). Needs ``translation`` in the same scene. Assumption: the force acts at the
centre of mass (no torque). Source: Newton's second law; Basilisk's ``extForceTorque``.
"""

from __future__ import annotations

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, CommandedEffect, FloatArray, ForceEffect, Parameter, positive, Quat, register,
    Vec)


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

    def add_batch_force(self, t: float, q: FloatArray, chunk: BatchChunk,
                        out: FloatArray) -> None:
        """The same held command on every body, rotated by each body's attitude."""
        out += quaternion.rotate_rows(q, np.array(self.command.vector_at(t))[:, None])
