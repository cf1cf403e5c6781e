"""One chunk of a :class:`~.batch.SceneBatch`: its bodies' inertia, masses and effect views,
and the RK4 step on them, vectorised over the chunk's bodies (structure of arrays)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.dynamics.batch_rows import cross_rows, matrix_rows_product
from rigid_body_attitude.core.dynamics.effects import (
    BatchChunk, ForceEffect, HeldOverStep, RotorEffect, RotorState, SampledTorque, TorqueEffect)

__all__ = ['SceneChunk']

FloatArray = NDArray[np.float64]


class SceneChunk:
    """One chunk of a :class:`SceneBatch`: its bodies' inertia, masses, effect parameters, and
    the RK4 step on them: the single-body kernel's arithmetic, vectorised into work arrays
    allocated once per chunk, with the body-frame angular momentum ``h = J ω`` in place of
    ``ω`` as the state (:meth:`momentum`, :meth:`rate`): ``ḣ = M − ω × h`` then needs one
    product with ``J⁻¹`` per evaluation instead of ``J ω`` and ``J⁻¹ (M − ω × J ω)``. RK4
    commutes with a constant linear change of variables, so the step equals the one in
    ``(q, ω)`` up to round-off."""

    def __init__(self, batch: Any, bodies: slice) -> None:
        """The bodies ``bodies`` of ``batch`` (a :class:`~.batch.SceneBatch`)."""
        shared = batch._tensor.shape[2] == 1 and batch.count > 1
        self.tensor = batch._tensor if shared else batch._tensor[:, :, bodies]
        self.inverse = batch._inverse if shared else batch._inverse[:, :, bodies]
        self.mass = batch._mass[bodies]
        off_diagonal = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]
        self.diagonal = not any(np.any(self.tensor[i, j]) or np.any(self.inverse[i, j])
                                for i, j in off_diagonal)
        n = self.mass.shape[0]
        self.out, self.total, self.stage = np.empty((3, 7, n))
        self.omega, self.half_omega, self.total_momentum = np.empty((3, 3, n))
        self.work, self.norm = np.empty((2, n))
        self.torques: list[tuple[TorqueEffect, BatchChunk]] = []
        self.rotors: list[tuple[RotorEffect, BatchChunk]] = []
        self.forces: list[tuple[ForceEffect, BatchChunk]] = []
        self.sampled: list[tuple[SampledTorque, BatchChunk]] = []
        self.held: list[tuple[HeldOverStep, BatchChunk]] = []
        self.wheels: list[tuple[RotorState, BatchChunk]] = []
        peers: dict[str, BatchChunk] = {}
        states = batch.effect_states
        for effect, (parameters, dispersed), state in zip(batch.effects, batch._parameters,
                                                          states):
            sliced = {name: value[..., bodies] if name in dispersed else value
                      for name, value in parameters.items()}
            view = BatchChunk(self.tensor, self.mass, sliced, self.diagonal,
                              state=np.empty((0, 0)) if state is None else state[:, bodies],
                              peers=peers)
            peers[effect.name] = view
            if isinstance(effect, HeldOverStep):
                self.held.append((effect, view))
            if isinstance(effect, RotorState):
                self.wheels.append((effect, view))
            if isinstance(effect, SampledTorque):
                self.sampled.append((effect, view))
            if isinstance(effect, TorqueEffect):
                self.torques.append((effect, view))
            if isinstance(effect, RotorEffect):
                self.rotors.append((effect, view))
            if isinstance(effect, ForceEffect):
                self.forces.append((effect, view))

    def hold(self, t: float, h: float, y: FloatArray) -> None:
        """The effects held over the step from ``t`` take the state ``y`` (q, J' ω)."""
        omega = self.rate(y[4:], np.empty((3, y.shape[1])))
        for effect, view in self.held:
            effect.batch_hold(t, h, y[:4], omega, view)

    def commit(self, t: float, h: float, y: FloatArray) -> None:
        """The wheels advance to ``t + h`` with the state ``y`` there."""
        omega = self.rate(y[4:], np.empty((3, y.shape[1])))
        for effect, view in self.wheels:
            effect.batch_commit(t, h, omega, omega, view)

    def momentum(self, omega: FloatArray, out: FloatArray) -> FloatArray:
        """``out = J ω`` (3, n)."""
        return matrix_rows_product(self.tensor, omega, out, self.work, self.diagonal)

    def rate(self, momentum: FloatArray, out: FloatArray) -> FloatArray:
        """``out = J⁻¹ h`` (3, n)."""
        return matrix_rows_product(self.inverse, momentum, out, self.work, self.diagonal)

    def force(self, t: float, q: FloatArray) -> FloatArray:
        """Sum of the forces [N, world] on every body, (3, n)."""
        total = np.zeros((3, q.shape[1]))
        for effect, view in self.forces:
            effect.add_batch_force(t, q, view, total)
        return total

    def derivative(self, t: float, y: FloatArray, out: FloatArray) -> FloatArray:
        """``(q̇, ḣ)`` of every body (``y`` holds ``(q, h)``) into ``out`` (7, n): Euler's
        equations with the effects."""
        q, work = y[:4], self.work
        omega = self.rate(y[4:], self.omega)
        momentum = y[4:]
        if self.rotors:
            momentum = self.total_momentum
            momentum[:] = y[4:]
            out[4:] = 0.0
        for rotor_effect, view in self.rotors:
            rotor_momentum, rotor_rate = rotor_effect.batch_rotor(t, view)
            momentum += rotor_momentum
            for row in range(3):
                out[4 + row] -= rotor_rate[row]
        cross_rows(momentum, omega, out[4:], work, accumulate=bool(self.rotors))
        for torque_effect, view in self.torques:
            torque_effect.add_batch_torque(t, q, omega, view, out[4:])
        # q̇ = q ⊗ (0, ω/2) = (−q_v·ω/2, w ω/2 + q_v × ω/2)
        half = self.half_omega
        np.multiply(omega, 0.5, out=half)
        np.multiply(q[1], half[0], out=out[0])
        for row in (2, 3):
            np.multiply(q[row], half[row - 1], out=work)
            out[0] += work
        np.negative(out[0], out=out[0])
        for row in range(3):
            np.multiply(q[0], half[row], out=out[1 + row])
        cross_rows(q[1:], half, out[1:4], work, accumulate=True)
        return out

    def rk4(self, t: float, y: FloatArray, h: float) -> None:
        """One RK4 step of every body in place, ``q`` renormalised."""
        half, total, stage = 0.5 * h, self.total, self.stage
        np.multiply(self.derivative(t, y, total), half, out=stage)
        stage += y
        for step in (half, h):
            k = self.derivative(t + half, stage, self.out)
            np.multiply(k, step, out=stage)
            stage += y
            k *= 2.0
            total += k
        total += self.derivative(t + h, stage, self.out)
        total *= h / 6.0
        y += total
        norm, work = self.norm, self.work
        np.multiply(y[0], y[0], out=norm)
        for row in (1, 2, 3):
            np.multiply(y[row], y[row], out=work)
            norm += work
        np.sqrt(norm, out=norm)
        np.divide(1.0, norm, out=norm)
        y[:4] *= norm
