"""Adaptive embedded Dormand–Prince 5(4) on the coupled attitude/Euler equations.

``y = (q, ω)`` as in :mod:`rigid_body_attitude.core.dynamics.integrators.rigid_body_rk4`; each call
of
``step`` advances exactly ``h`` seconds with as many internal steps as the error control asks
for, and remembers the last internal step size for the next call.
"""

from __future__ import annotations

import math

from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.dynamics.integrators.base import (
    body_derivative, BodyModel, q_normalize, Quat, Vec)
from rigid_body_attitude.core.dynamics.integrators.dynamics_base import DynamicsMethod

__all__ = ['DormandPrince45']

_C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0)
_A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
    (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84),
)
#: Fifth-order solution minus the embedded fourth-order one (error estimate weights).
_E = (71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40)

#: Internal steps allowed per call before the integrator gives up.
MAX_INTERNAL_STEPS = 100000


class DormandPrince45(DynamicsMethod):
    """Dormand–Prince 5(4) with embedded error control (FSAL, seven stages).

    Error per internal step, RMS over the seven components of
    ``err_i/(atol + rtol·max(|y_i|, |y_i⁺|))`` ≤ 1; step factor ``0.9·err^(−1/5)`` clipped to
    [0.2, 5]. ``q`` is renormalised after each accepted step. Order 5 (local
    extrapolation); cost six new evaluations of Euler's equations per accepted step.
    Invariants: none beyond ``|q|`` by projection; the tolerance bounds the drift.
    Counters ``steps_taken``, ``steps_rejected`` and ``evaluations`` accumulate across calls
    (:meth:`reset_counters`). Source: Dormand & Prince, J. Comput. Appl. Math. 6 (1980);
    Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4–5.
    """

    name = 'dopri45'
    order = 5
    supports_torque = True

    def __init__(self, rtol: float = 1e-9, atol: float = 1e-12):
        if not (rtol > 0.0 and atol > 0.0 and math.isfinite(rtol) and math.isfinite(atol)):
            raise IntegratorError(f'Expected positive finite tolerances, got rtol={rtol!r}, '
                                  f'atol={atol!r}')
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.internal_step: float | None = None
        self.reset_counters()

    def reset_counters(self) -> None:
        """Zero ``steps_taken``, ``steps_rejected`` and ``evaluations``."""
        self.steps_taken = 0
        self.steps_rejected = 0
        self.evaluations = 0

    def _initial_step(self, y: tuple[float, ...], f: tuple[float, ...], span: float) -> float:
        scale = [self.atol + self.rtol * abs(a) for a in y]
        d0 = math.sqrt(sum((a / s) ** 2 for a, s in zip(y, scale)) / 7.0)
        d1 = math.sqrt(sum((b / s) ** 2 for b, s in zip(f, scale)) / 7.0)
        guess = 0.01 * d0 / d1 if d0 > 1e-5 and d1 > 1e-5 else 1e-6
        return min(abs(span), guess)

    def _advance(self, q: Quat, omega: Vec, t: float, h: float,
                 model: BodyModel) -> tuple[Quat, Vec]:
        y = q + omega
        end = t + h
        direction = 1.0 if h >= 0.0 else -1.0
        k1 = body_derivative(model, t, y)
        self.evaluations += 1
        step = self.internal_step if self.internal_step else self._initial_step(y, k1, h)
        step = direction * abs(step)
        for _ in range(MAX_INTERNAL_STEPS):
            if direction * (end - t) <= 1e-15 * max(1.0, abs(end)):
                return (y[0], y[1], y[2], y[3]), (y[4], y[5], y[6])
            last = direction * (t + step - end) >= 0.0
            if last:
                step = end - t
            stages = [k1]
            for i in range(1, 7):
                row = _A[i]
                point = tuple(yj + step * sum(a * k[j] for a, k in zip(row, stages))
                              for j, yj in enumerate(y))
                stages.append(body_derivative(model, t + _C[i] * step, point))
            self.evaluations += 6
            new = point  # stage 7 is evaluated at the fifth-order solution (FSAL)
            error = 0.0
            for j in range(7):
                estimate = step * sum(e * k[j] for e, k in zip(_E, stages))
                scale = self.atol + self.rtol * max(abs(y[j]), abs(new[j]))
                error += (estimate / scale) ** 2
            error = math.sqrt(error / 7.0)
            if not math.isfinite(error):
                raise IntegratorError(f'dopri45 error estimate is not finite at t={t!r} '
                                      f'with internal step {step!r}')
            factor = min(5.0, max(0.2, 0.9 * error ** -0.2)) if error > 0.0 else 5.0
            if error <= 1.0:
                t = end if last else t + step
                qn = q_normalize(new[:4])
                y = qn + (new[4], new[5], new[6])
                k1 = stages[6] if qn == new[:4] else body_derivative(model, t, y)
                self.steps_taken += 1
                if not last:
                    self.internal_step = abs(step * factor)
                step = direction * abs(step * factor)
            else:
                self.steps_rejected += 1
                step = step * max(0.2, factor)
        raise IntegratorError(f'dopri45 needed more than {MAX_INTERNAL_STEPS} internal steps '
                              f'for one step of {h!r} s (rtol={self.rtol}, atol={self.atol})')
