"""Classical RK4 on the coupled attitude/Euler equations, with renormalisation.

``y = (q, ω)``, ``ẏ = (½ q ⊗ (0, ω), J⁻¹(M − ḣ − ω × (Jω + h)))`` (physics.md §1); after the
step ``q`` is projected back to unit norm. The work of the torques, ``W = ∫ ω·(M − ħ) dt``, is
integrated alongside as an eighth component (the same RK4 weights on the stage powers): the
energy balance costs no extra torque evaluation.
"""

from __future__ import annotations

from rigid_body_attitude.core.dynamics.integrators.base import (
    body_derivative_power, BodyModel, q_normalize, Quat, Vec)
from rigid_body_attitude.core.dynamics.integrators.dynamics_base import DynamicsMethod
from rigid_body_attitude.core.dynamics.integrators.rk4_kernel import Rk4Kernel, rk4_kernel

__all__ = ['RigidBodyRk4', 'rk4_state_step', 'rk4_work_step']


def rk4_work_step(model: BodyModel, t: float, state: tuple[float, ...],
                  h: float) -> tuple[tuple[float, ...], float]:
    """One classical RK4 step of ``h`` from ``t`` on the 7-float state ``(q, ω)``, without
    renormalisation, and the work [J] of the torques over the step (RK4 quadrature of the
    stage powers). Plain floats, every stage written out (no per-stage tuple building)."""
    y0, y1, y2, y3, y4, y5, y6 = state
    half = 0.5 * h
    a0, a1, a2, a3, a4, a5, a6, a7 = body_derivative_power(model, t, state)
    b0, b1, b2, b3, b4, b5, b6, b7 = body_derivative_power(model, t + half, (
        y0 + half * a0, y1 + half * a1, y2 + half * a2, y3 + half * a3, y4 + half * a4,
        y5 + half * a5, y6 + half * a6))
    c0, c1, c2, c3, c4, c5, c6, c7 = body_derivative_power(model, t + half, (
        y0 + half * b0, y1 + half * b1, y2 + half * b2, y3 + half * b3, y4 + half * b4,
        y5 + half * b5, y6 + half * b6))
    d0, d1, d2, d3, d4, d5, d6, d7 = body_derivative_power(model, t + h, (
        y0 + h * c0, y1 + h * c1, y2 + h * c2, y3 + h * c3, y4 + h * c4, y5 + h * c5,
        y6 + h * c6))
    s = h / 6.0
    return ((y0 + s * (a0 + 2.0 * (b0 + c0) + d0), y1 + s * (a1 + 2.0 * (b1 + c1) + d1),
             y2 + s * (a2 + 2.0 * (b2 + c2) + d2), y3 + s * (a3 + 2.0 * (b3 + c3) + d3),
             y4 + s * (a4 + 2.0 * (b4 + c4) + d4), y5 + s * (a5 + 2.0 * (b5 + c5) + d5),
             y6 + s * (a6 + 2.0 * (b6 + c6) + d6)),
            s * (a7 + 2.0 * (b7 + c7) + d7))


def rk4_state_step(model: BodyModel, t: float, state: tuple[float, ...],
                   h: float) -> tuple[float, ...]:
    """:func:`rk4_work_step` without the work."""
    return rk4_work_step(model, t, state, h)[0]


class RigidBodyRk4(DynamicsMethod):
    """Classical RK4 on ``(q, ω)`` jointly, then ``q`` renormalised.

    Order 4; cost four evaluations of Euler's equations (and of the torque) per step, plain
    float math, every stage written out (``bench/effect_costs.py`` prices it). Invariants:
    ``|q| = 1`` by projection only (RK4 alone shrinks ``|q|`` by ``(h|ω|)⁶/9216`` per step);
    energy, ``|m|`` and world momentum drift at O(h⁴) per unit time (Hairer–Vilmart body,
    T = 1000, h = 0.05: energy −6e−7, physics.md §6). Steps with h·|ω| > 2 rad are refused
    (:class:`IntegratorError`; RK4 diverges above 2√2, silently until it overflows). Source:
    Kutta (1901); Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1.
    """

    name = 'rk4'
    order = 4
    supports_torque = True
    #: Stable for h·|ω| < 2√2 (RK4 on the imaginary axis; for a torque-free body every
    #: eigenvalue of the linearised equations has |λ| ≤ |ω|: the attitude |ω|/2, the body
    #: precession of m at most |ω| because J₁ + J₂ ≥ J₃); at h|ω| = 3 it diverges within ten
    #: steps. Steps above 2 rad are refused (:class:`.dynamics_base.DynamicsMethod`).
    max_rotation_per_step = 2.0

    def __init__(self) -> None:
        self._model: BodyModel | None = None
        self._kernel: Rk4Kernel | None = None

    def _kernel_of(self, model: BodyModel) -> Rk4Kernel:
        """The step written out for ``model`` (:mod:`.rk4_kernel`), built once per model."""
        if model is not self._model or self._kernel is None:
            self._kernel = rk4_kernel(model)
            self._model = model
        return self._kernel

    def _advance(self, q: Quat, omega: Vec, t: float, h: float,
                 model: BodyModel) -> tuple[Quat, Vec]:
        y1 = self._kernel_of(model)(t, q + omega, h)[0]
        return q_normalize(y1[:4]), (y1[4], y1[5], y1[6])

    def advance_with_work(self, q: Quat, omega: Vec, t: float, h: float,
                          model: BodyModel) -> tuple[Quat, Vec, float]:
        """One step on plain floats and the work of the torques (stage quadrature)."""
        y1, work = self._kernel_of(model)(t, q + omega, h)
        return q_normalize(y1[:4]), (y1[4], y1[5], y1[6]), work
