"""Classical RK4 on the coupled attitude/Euler equations, with renormalisation.

``y = (q, ω)``, ``ẏ = (½ q ⊗ (0, ω), J⁻¹(M − ḣ − ω × (Jω + h)))`` (Landau & Lifshitz, *Mechanics*,
3rd ed., 1976, §36); after the step ``q`` is projected back to unit norm. The work of the torques,
``W = ∫ ω·(M − ħ) dt``, is integrated alongside as an eighth component (the same RK4 weights on the
stage powers): the energy balance costs no extra torque evaluation.
"""

from __future__ import annotations

from rigid_body_attitude.core.dynamics.integrators.base import BodyModel, q_normalize, Quat, Vec
from rigid_body_attitude.core.dynamics.integrators.dynamics_base import DynamicsMethod
from rigid_body_attitude.core.dynamics.integrators.rk4_kernel import Rk4Kernel, rk4_kernel

__all__ = ['RigidBodyRk4']


class RigidBodyRk4(DynamicsMethod):
    """Classical RK4 on ``(q, ω)`` jointly, then ``q`` renormalised.

    Order 4; cost four evaluations of Euler's equations (and of the torque) per step, plain
    float math, every stage written out (``bench/effect_costs.py`` prices it). Invariants:
    ``|q| = 1`` by projection only (RK4 alone shrinks ``|q|`` by ``(h|ω|)⁶/9216`` per step);
    energy, ``|m|`` and world momentum drift at O(h⁴) per unit time (Hairer–Vilmart body,
    T = 1000, h = 0.05: energy −6e−7, test/hard/test_hard_long_runs.py). Steps with h·|ω| > 2 rad
    are refused (:class:`IntegratorError`; RK4 diverges above 2√2, silently until it overflows).
    Source: Kutta (1901); Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1.
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
