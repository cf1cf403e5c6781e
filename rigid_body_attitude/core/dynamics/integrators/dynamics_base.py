"""Shared plumbing of the dynamics integrators: validation, array conversion, step loops.

Each integrator implements ``_advance(q, ω, t, h, model) -> (q, ω)`` on plain float tuples;
this base turns it into the common interface (``step`` on arrays, ``integrate`` for many
equal steps without per-step conversions, used by the study's timings).

An explicit method that is only conditionally stable declares ``max_rotation_per_step``
(``h·|ω|`` in rad; RK4 and RKMK4: 2.0, below RK4's imaginary-axis limit 2√2): the limit lives
only there. ``step`` and ``integrate`` refuse a step above it with an
:class:`IntegratorError` instead of diverging silently until the state overflows;
``DynamicsPropagator`` asks :meth:`DynamicsMethod.substeps_needed` and splits such steps into
substeps before stepping.

``advance_with_work`` is the propagator's per-step entry: plain floats in and out, and the
work ``∫ ω·(M − ḣ) dt`` [J] of the torques over the step for the energy balance.
"""

from __future__ import annotations

import math
from typing import ClassVar

from numpy.typing import ArrayLike

from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.registry import Registry
from rigid_body_attitude.core.dynamics.integrators.base import (
    as_state, body_derivative_power, BodyModel, check_step, FloatArray, output, q_exp,
    q_multiply, Quat, Vec)

__all__ = ['DYNAMICS_INTEGRATORS', 'DynamicsMethod', 'torque_integrators']

#: Relative slack on ``max_rotation_per_step``, so that a step at the limit up to round-off
#: (the propagator's equal substeps, ``h·|ω|`` computed as 2·(1 + 2ε)) passes and is not
#: split into one substep more; the true stability limit (RK4: 2√2) is 41 % higher.
ROTATION_LIMIT_SLACK = 1.0 + 1e-6


class DynamicsMethod:
    """Base of the dynamics integrators (see :class:`integrators.base.DynamicsIntegrator`)."""

    name: ClassVar[str] = ''
    order: ClassVar[int] = 0
    supports_torque: ClassVar[bool] = True
    #: Largest ``h·|ω|`` [rad] this method accepts per step (``inf``: unconditionally stable).
    max_rotation_per_step: ClassVar[float] = math.inf

    def _advance(self, q: Quat, omega: Vec, t: float, h: float,
                 model: BodyModel) -> tuple[Quat, Vec]:
        raise IntegratorError(f'{type(self).__name__} defines no step')

    def advance_floats(self, q: Quat, omega: Vec, t: float, h: float,
                       model: BodyModel) -> tuple[Quat, Vec]:
        """One step on plain floats, no checks (the propagator's hot path)."""
        return self._advance(q, omega, t, h, model)

    def advance_with_work(self, q: Quat, omega: Vec, t: float, h: float,
                          model: BodyModel) -> tuple[Quat, Vec, float]:
        """One step on plain floats (no checks) and the work [J] of the torques over it.

        Here: Simpson's rule on the power ``ω·(M − ḣ)`` (error O(h⁵) per step), with the
        midpoint rate from cubic Hermite interpolation with the end slopes from Euler's
        equations (error O(h⁴)) and the midpoint attitude from the exponential map of the mean
        rate; three evaluations of the torques. Zero for a torque-free body.
        """
        new_q, new_omega = self._advance(q, omega, t, h, model)
        if model.torque_free:
            return new_q, new_omega, 0.0
        start = body_derivative_power(model, t, q + omega)
        end = body_derivative_power(model, t + h, new_q + new_omega)
        eighth = 0.125 * h
        mid_omega = tuple(0.5 * (a + b) + eighth * (c - d) for a, b, c, d in zip(
            omega, new_omega, start[4:7], end[4:7]))
        quarter = 0.25 * h
        mid_q = q_multiply(q, q_exp(quarter * (omega[0] + mid_omega[0]),
                                    quarter * (omega[1] + mid_omega[1]),
                                    quarter * (omega[2] + mid_omega[2])))
        mid = body_derivative_power(model, t + 0.5 * h, mid_q + mid_omega)
        return new_q, new_omega, h / 6.0 * (start[7] + 4.0 * mid[7] + end[7])

    def substeps_needed(self, h: float, speed: float) -> int:
        """Equal substeps a step of ``h`` at ``|ω| = speed`` needs to stay within
        :attr:`max_rotation_per_step` (1 when within it, up to :data:`ROTATION_LIMIT_SLACK`)."""
        rotation = abs(h) * speed
        limit = self.max_rotation_per_step
        if rotation <= limit * ROTATION_LIMIT_SLACK:
            return 1
        return math.ceil(rotation / (limit * ROTATION_LIMIT_SLACK))

    def _check_model(self, model: BodyModel) -> None:
        if not self.supports_torque and not model.torque_free:
            raise IntegratorError(f'Integrator {self.name!r} handles torque-free bodies only; '
                                  f'this model has a torque or a rotor. Use one of '
                                  f'{", ".join(torque_integrators())}')

    def _refuse_rotation(self, h: float, omega: Vec, step_index: int) -> None:
        """Raise the :class:`IntegratorError` for a step with ``h·|ω|`` above the limit."""
        stable = sorted(name for name, cls in DYNAMICS_INTEGRATORS.items()
                        if cls.max_rotation_per_step == math.inf)
        speed = math.sqrt(omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2])
        where = f' (step {step_index} of the run)' if step_index else ''
        raise IntegratorError(
            f'Integrator {self.name!r} is stable only for h·|ω| <= '
            f'{self.max_rotation_per_step} rad; got h = {h!r} s at |ω| = {speed:.6g} rad/s, '
            f'h·|ω| = {abs(h) * speed:.6g} rad{where}. Use DynamicsPropagator (it splits such '
            f'steps into substeps), a smaller step, or one of {", ".join(stable)}')

    def step(self, attitude: ArrayLike, omega_body: ArrayLike, t: float, h: float,
             model: BodyModel) -> tuple[FloatArray, FloatArray]:
        """Advance ``(attitude, omega_body)`` from ``t`` by ``h`` seconds; returns arrays.

        Raises :class:`IntegratorError` for a non-finite step or result, a step with
        ``h·|ω|`` above :attr:`max_rotation_per_step`, or a model this integrator cannot
        handle; the inputs are never modified.
        """
        self._check_model(model)
        q, omega = as_state(attitude, omega_body)
        h = check_step(h)
        limit = self.max_rotation_per_step * ROTATION_LIMIT_SLACK
        if h * h * (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]) > (
                limit * limit):
            self._refuse_rotation(h, omega, 0)
        q, omega = self._advance(q, omega, float(t), h, model)
        return output(q, omega)

    def integrate(self, attitude: ArrayLike, omega_body: ArrayLike, t_start: float, h: float,
                  steps: int, model: BodyModel) -> tuple[FloatArray, FloatArray]:
        """``steps`` equal steps of ``h`` from ``t_start`` (plain floats between steps).

        Each step's ``h·|ω|`` is checked against :attr:`max_rotation_per_step` (the rate may
        grow during the run): :class:`IntegratorError` names the first step above it.
        """
        self._check_model(model)
        q, omega = as_state(attitude, omega_body)
        h = check_step(h)
        advance = self._advance
        if self.max_rotation_per_step == math.inf:
            for k in range(int(steps)):
                q, omega = advance(q, omega, t_start + k * h, h, model)
            return output(q, omega)
        limit = self.max_rotation_per_step * ROTATION_LIMIT_SLACK / abs(h) if h else math.inf
        bound = limit * limit
        for k in range(int(steps)):
            if omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2] > bound:
                self._refuse_rotation(h, omega, k + 1)
            q, omega = advance(q, omega, t_start + k * h, h, model)
        return output(q, omega)


#: Dynamics integrators by name (values are classes): a :class:`~.registry.Registry`, the
#: mechanism the effects use too. The package's ``__init__`` registers every method; it sits
#: here, below the methods, so that a method's error message can list the others.
DYNAMICS_INTEGRATORS: Registry[type[DynamicsMethod]] = Registry('dynamics integrator',
                                                                IntegratorError)


def torque_integrators() -> tuple[str, ...]:
    """Names of the dynamics integrators that handle torques and rotors (``supports_torque``),
    sorted; the others handle torque-free bodies only."""
    return tuple(sorted(name for name, cls in DYNAMICS_INTEGRATORS.items()
                        if cls.supports_torque))
