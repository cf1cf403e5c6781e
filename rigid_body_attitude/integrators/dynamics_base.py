"""Shared plumbing of the dynamics integrators: validation, array conversion, step loops.

Each integrator implements ``_advance(q, ω, t, h, model) -> (q, ω)`` on plain float tuples;
this base turns it into the common interface (``step`` on arrays, ``integrate`` for many
equal steps without per-step conversions, used by the study's timings).
"""

from __future__ import annotations

from numpy.typing import ArrayLike

from rigid_body_attitude.errors import IntegratorError
from rigid_body_attitude.integrators.base import (
    as_state, BodyModel, check_step, FloatArray, output, Quat, Vec)

__all__ = ['DynamicsMethod']


class DynamicsMethod:
    """Base of the dynamics integrators (see :class:`integrators.base.DynamicsIntegrator`)."""

    name = ''
    order = 0
    supports_torque = True

    def _advance(self, q: Quat, omega: Vec, t: float, h: float,
                 model: BodyModel) -> tuple[Quat, Vec]:
        raise IntegratorError(f'{type(self).__name__} defines no step')

    def _check_model(self, model: BodyModel) -> None:
        if not self.supports_torque and not model.torque_free:
            from rigid_body_attitude.integrators import torque_integrators  # registry: no cycle
            raise IntegratorError(f'Integrator {self.name!r} handles torque-free bodies only; '
                                  f'this model has a torque or a rotor. Use one of '
                                  f'{", ".join(torque_integrators())}')

    def step(self, attitude: ArrayLike, omega_body: ArrayLike, t: float, h: float,
             model: BodyModel) -> tuple[FloatArray, FloatArray]:
        """Advance ``(attitude, omega_body)`` from ``t`` by ``h`` seconds; returns arrays.

        Raises :class:`IntegratorError` for a non-finite step or result, or a model this
        integrator cannot handle; the inputs are never modified.
        """
        self._check_model(model)
        q, omega = as_state(attitude, omega_body)
        q, omega = self._advance(q, omega, float(t), check_step(h), model)
        return output(q, omega)

    def integrate(self, attitude: ArrayLike, omega_body: ArrayLike, t_start: float, h: float,
                  steps: int, model: BodyModel) -> tuple[FloatArray, FloatArray]:
        """``steps`` equal steps of ``h`` from ``t_start`` (plain floats between steps)."""
        self._check_model(model)
        q, omega = as_state(attitude, omega_body)
        h = check_step(h)
        advance = self._advance
        for k in range(int(steps)):
            q, omega = advance(q, omega, t_start + k * h, h, model)
        return output(q, omega)
