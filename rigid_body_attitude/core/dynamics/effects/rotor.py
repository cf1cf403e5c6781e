"""rotor: a gyrostat rotor (momentum wheel) with constant or commanded momentum.

The rotor's momentum ``h`` relative to the body (body axes) enters Euler's equations as
``J ω̇ + ω × (J ω + h) = M − ḣ`` (Source: Hughes, *Spacecraft Attitude Dynamics*, 1986, §3.4;
Basilisk reaction wheels). With
``commanded: false`` ``h`` is constant and the rotor only adds gyroscopic stiffness. With
``commanded: true`` the ``rotor_torque`` input ``u`` (the motor torque on the rotor, body axes)
drives ``ḣ = u``, held until ``timeout`` (or the next command) and then zero; the body feels
``−u``. ``h(t)`` is piecewise linear in time, so it is evaluated exactly at every integrator
stage, and the propagator ends its steps where ``u`` switches. ``J`` is the
inertia of the whole gyrostat with the rotor locked; the rotor's own spin energy is not in
``T``. In a batch the initial momentum may differ per body; commands are shared.
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, boolean, CommandedEffect, FloatArray, Parameter, positive,
    register, REQUIRED, RotorEffect, Vec, vector3)


@register
class Rotor(CommandedEffect, RotorEffect):
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
        self.initial_momentum = self.params['momentum'].copy()
        self.initial = as_vec(self.initial_momentum)

    @property
    def input_names(self) -> frozenset[str]:
        """``rotor_torque`` only when the rotor is commanded."""
        return frozenset(self.inputs) if self.params['commanded'] else frozenset()

    def rotor(self, t: float) -> tuple[Vec, Vec]:
        """``(h(t), ḣ(t))``: ``h₀ + ∫ u dt`` over the held commands, ``ḣ`` the one in force."""
        command = self.command
        h0 = self.initial
        if command.window is not None:  # inside a step: the command in force is pinned
            start, (x, y, z), rate = command.pinned
            span = t - start
            return (h0[0] + (x + rate[0] * span), h0[1] + (y + rate[1] * span),
                    h0[2] + (z + rate[2] * span)), rate
        if not command.segments:
            return h0, (0.0, 0.0, 0.0)
        ix, iy, iz = command.integral_at(t)
        return (h0[0] + ix, h0[1] + iy, h0[2] + iz), command.vector_at(t)

    def batch_rotor(self, t: float, chunk: BatchChunk) -> tuple[FloatArray, Vec]:
        """``h`` for the bodies of ``chunk`` ((3, n) or (3, 1)) and the shared ``ḣ``."""
        ix, iy, iz = self.command.integral_at(t)
        momentum: FloatArray = chunk.parameters['momentum'] + [[ix], [iy], [iz]]
        return momentum, self.command.vector_at(t)
