"""Attitude integrators for a body rate known as a function of time, ``ω(t)``.

Each function advances ``q̇ = ½ q ⊗ (0, ω_body(t))`` (conventions of
:mod:`rigid_body_attitude.core.attitude.quaternion`) by one step ``h`` from time ``t``:
``step(q, omega_of_time, t, h) -> q`` with ``q`` a 4-tuple of floats and ``omega_of_time(t)``
returning a 3-sequence [rad/s]. They are the study's kinematic menu (Iserles, Munthe-Kaas, Nørsett
& Zanna, "Lie-group methods", 2000); the sampled-stream versions the propagator uses are in
:mod:`rigid_body_attitude.core.attitude.integrators.strapdown`.

``dexpinv`` below is the inverse differential of the exponential for the right-trivialised
equation ``q = q₀ ⊗ exp(θ)``: ``θ̇ = ω + ½ θ × ω + (1/|θ|²)(1 − (|θ|/2) cot(|θ|/2)) θ × (θ × ω)``
(Bortz 1971), truncated to ``ω + ½ θ × ω + (1/12) θ × (θ × ω)`` where fourth order suffices.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.attitude.float_quaternion import (
    q_multiply, q_normalize, q_rotate_step, Quat, SERIES_THRESHOLD, Vec)

__all__ = [
    'KINEMATIC_METHODS',
    'KinematicMethod',
    'bortz_step',
    'cf4_step',
    'euler_normalize_step',
    'exp_map_step',
    'exp_midpoint_step',
    'kinematic_method',
    'magnus4_step',
    'rk4_quaternion_step',
    'rkmk4_step',
]

RateFunction = Callable[[float], Sequence[float]]

_GAUSS_OFFSET = math.sqrt(3.0) / 6.0
_CF4_MAJOR = 0.25 + math.sqrt(3.0) / 6.0
_CF4_MINOR = 0.25 - math.sqrt(3.0) / 6.0


def _rate(omega_of_time: RateFunction, t: float) -> Vec:
    w = omega_of_time(t)
    return float(w[0]), float(w[1]), float(w[2])


def _cross(a: Sequence[float], b: Sequence[float]) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def exp_map_step(q: Sequence[float], omega_of_time: RateFunction, t: float, h: float) -> Quat:
    """``q ⊗ exp(h ω(t))``: rate held from the start of the step.

    Order 1; one rate evaluation, one exponential. Keeps ``|q| = 1``.
    """
    w = _rate(omega_of_time, t)
    return q_rotate_step(q, h * w[0], h * w[1], h * w[2])


def exp_midpoint_step(q: Sequence[float], omega_of_time: RateFunction, t: float,
                      h: float) -> Quat:
    """``q ⊗ exp(h ω(t + h/2))``: second-order Magnus (midpoint rule, no commutator).

    Order 2; one rate evaluation, one exponential. Keeps ``|q| = 1``. Source: Iserles,
    Munthe-Kaas, Nørsett & Zanna, Acta Numerica 9 (2000).
    """
    w = _rate(omega_of_time, t + 0.5 * h)
    return q_rotate_step(q, h * w[0], h * w[1], h * w[2])


def euler_normalize_step(q: Sequence[float], omega_of_time: RateFunction, t: float,
                         h: float) -> Quat:
    """``normalize(q + h ½ q ⊗ (0, ω(t)))``: explicit Euler and projection.

    Order 1; one product. ``|q|`` by projection only.
    """
    w = _rate(omega_of_time, t)
    d = q_multiply(q, (0.0, 0.5 * h * w[0], 0.5 * h * w[1], 0.5 * h * w[2]))
    return q_normalize((q[0] + d[0], q[1] + d[1], q[2] + d[2], q[3] + d[3]))


def rk4_quaternion_step(q: Sequence[float], omega_of_time: RateFunction, t: float,
                        h: float) -> Quat:
    """Classical RK4 on ``q̇ = ½ q ⊗ (0, ω(t))``, then normalised.

    Order 4; three rate evaluations (the midpoint once), four products. ``|q|`` drifts
    (shrinks by ``(h|ω|)⁶/9216`` per step for a constant rate) and is projected back.
    Source: Kutta (1901).
    """
    w0 = _rate(omega_of_time, t)
    wm = _rate(omega_of_time, t + 0.5 * h)
    w1 = _rate(omega_of_time, t + h)

    def rate(y: Sequence[float], w: Vec) -> Quat:
        return q_multiply(y, (0.0, 0.5 * w[0], 0.5 * w[1], 0.5 * w[2]))

    k1 = rate(q, w0)
    k2 = rate([a + 0.5 * h * b for a, b in zip(q, k1)], wm)
    k3 = rate([a + 0.5 * h * b for a, b in zip(q, k2)], wm)
    k4 = rate([a + h * b for a, b in zip(q, k3)], w1)
    s = h / 6.0
    return q_normalize(tuple(a + s * (b + 2.0 * (c + d) + e)
                             for a, b, c, d, e in zip(q, k1, k2, k3, k4)))


def magnus4_step(q: Sequence[float], omega_of_time: RateFunction, t: float, h: float) -> Quat:
    """Fourth-order Magnus with the rate at the Gauss points ``t + (½ ∓ √3/6) h``::

        φ = (h/2)(ω₁ + ω₂) + (√3/12) h² ω₁ × ω₂,   q ⊗ exp(φ).

    Order 4; two rate evaluations, one exponential. Keeps ``|q| = 1``. Coning drift
    ``+a²Ω(Ωh)⁴/1440`` (sign convention of :mod:`.strapdown`; measured by
    test/core/attitude/test_integrators_strapdown.py). Source: Iserles & Nørsett (1999); Blanes,
    Casas
    & Ros (2000).
    """
    w1 = _rate(omega_of_time, t + (0.5 - _GAUSS_OFFSET) * h)
    w2 = _rate(omega_of_time, t + (0.5 + _GAUSS_OFFSET) * h)
    c = _cross(w1, w2)
    k = math.sqrt(3.0) / 12.0 * h * h
    return q_rotate_step(q, *(0.5 * h * (a + b) + k * e for a, b, e in zip(w1, w2, c)))


def cf4_step(q: Sequence[float], omega_of_time: RateFunction, t: float, h: float) -> Quat:
    """Commutator-free fourth-order Magnus method (two exponentials, Gauss points)::

        q ⊗ exp(h(α ω₁ + β ω₂)) ⊗ exp(h(β ω₁ + α ω₂)),  α = ¼ + √3/6,  β = ¼ − √3/6.

    The earlier factor weights the earlier Gauss point (right action). Order 4; two rate
    evaluations, two exponentials, no cross product. Keeps ``|q| = 1``. Source: Blanes &
    Moan, Appl. Numer. Math. 56 (2006).
    """
    w1 = _rate(omega_of_time, t + (0.5 - _GAUSS_OFFSET) * h)
    w2 = _rate(omega_of_time, t + (0.5 + _GAUSS_OFFSET) * h)
    first = tuple(h * (_CF4_MAJOR * a + _CF4_MINOR * b) for a, b in zip(w1, w2))
    second = tuple(h * (_CF4_MINOR * a + _CF4_MAJOR * b) for a, b in zip(w1, w2))
    return q_rotate_step(q_rotate_step(q, *first), *second)


def _dexpinv_truncated(theta: Sequence[float], w: Sequence[float]) -> Vec:
    """``ω + ½ θ × ω + (1/12) θ × (θ × ω)`` (enough for order 4)."""
    c = _cross(theta, w)
    cc = _cross(theta, c)
    x, y, z = (a + 0.5 * b + e / 12.0 for a, b, e in zip(w, c, cc))
    return x, y, z


def _dexpinv_exact(theta: Sequence[float], w: Sequence[float]) -> Vec:
    """Bortz: ``ω + ½ θ × ω + (1/|θ|²)(1 − (|θ|/2) cot(|θ|/2)) θ × (θ × ω)``."""
    angle = math.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    if angle < SERIES_THRESHOLD:  # series 1/12 + |θ|²/720 guards small angles
        factor = 1.0 / 12.0 + angle * angle / 720.0
    else:
        if angle >= 2.0 * math.pi:
            raise IntegratorError(f'Expected a rotation vector shorter than 2π within a step, '
                                  f'got angle {angle!r}; reduce the step')
        factor = (1.0 - 0.5 * angle / math.tan(0.5 * angle)) / (angle * angle)
    c = _cross(theta, w)
    cc = _cross(theta, c)
    x, y, z = (a + 0.5 * b + factor * e for a, b, e in zip(w, c, cc))
    return x, y, z


def _rk4_rotation_vector(omega_of_time: RateFunction, t: float, h: float,
                         dexpinv: Callable[[Sequence[float], Sequence[float]], Vec]) -> Vec:
    w0 = _rate(omega_of_time, t)
    wm = _rate(omega_of_time, t + 0.5 * h)
    w1 = _rate(omega_of_time, t + h)
    k1 = w0
    k2 = dexpinv([0.5 * h * a for a in k1], wm)
    k3 = dexpinv([0.5 * h * a for a in k2], wm)
    k4 = dexpinv([h * a for a in k3], w1)
    x, y, z = (h / 6.0 * (a + 2.0 * (b + c) + d) for a, b, c, d in zip(k1, k2, k3, k4))
    return x, y, z


def rkmk4_step(q: Sequence[float], omega_of_time: RateFunction, t: float, h: float) -> Quat:
    """Runge–Kutta–Munthe-Kaas (RK4 in the Lie algebra), truncated ``dexpinv``.

    RK4 on ``θ̇ = dexpinv(θ, ω(t))`` from ``θ = 0``, then ``q ⊗ exp(θ)``. Order 4; three rate
    evaluations, one exponential, four cross products. Keeps ``|q| = 1``. Source:
    Munthe-Kaas, BIT 38 (1998).
    """
    return q_rotate_step(q, *_rk4_rotation_vector(omega_of_time, t, h, _dexpinv_truncated))


def bortz_step(q: Sequence[float], omega_of_time: RateFunction, t: float, h: float) -> Quat:
    """RK4 on the Bortz rotation-vector equation (exact ``dexpinv``), then ``q ⊗ exp(φ)``.

    ``φ̇ = ω + ½ φ × ω + (1/|φ|²)(1 − |φ| sin|φ| / (2(1 − cos|φ|))) φ × (φ × ω)``. Order 4;
    three rate evaluations, one exponential. Keeps ``|q| = 1``. Source: Bortz, IEEE Trans.
    AES 7(1), 1971.
    """
    return q_rotate_step(q, *_rk4_rotation_vector(omega_of_time, t, h, _dexpinv_exact))


class KinematicMethod:
    """A named ``step(q, omega_of_time, t, h) -> q`` with its nominal order and rate cost."""

    def __init__(self, name: str, step: Callable[..., Quat], order: int,
                 rate_evaluations: int):
        self.name = name
        self.step = step
        self.order = order
        self.rate_evaluations = rate_evaluations
        self.__doc__ = step.__doc__

    def integrate(self, q: Sequence[float], omega_of_time: RateFunction, t_start: float,
                  h: float, steps: int) -> Quat:
        """``steps`` steps of ``h`` from ``t_start``; returns the final attitude."""
        state = (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
        step = self.step
        for k in range(steps):
            state = step(state, omega_of_time, t_start + k * h, h)
        return state


#: Function-based kinematic methods by name.
KINEMATIC_METHODS: dict[str, KinematicMethod] = {m.name: m for m in (
    KinematicMethod('euler_normalize', euler_normalize_step, 1, 1),
    KinematicMethod('exp_map', exp_map_step, 1, 1),
    KinematicMethod('exp_midpoint', exp_midpoint_step, 2, 1),
    KinematicMethod('rk4_quaternion', rk4_quaternion_step, 4, 3),
    KinematicMethod('magnus4', magnus4_step, 4, 2),
    KinematicMethod('cf4', cf4_step, 4, 2),
    KinematicMethod('rkmk4', rkmk4_step, 4, 3),
    KinematicMethod('bortz', bortz_step, 4, 3),
)}


def kinematic_method(name: str) -> Any:
    """The function-based kinematic method ``name``; :class:`IntegratorError` if unknown."""
    if name not in KINEMATIC_METHODS:
        raise IntegratorError(f'Unknown kinematic method {name!r}; expected one of '
                              f'{", ".join(sorted(KINEMATIC_METHODS))}')
    return KINEMATIC_METHODS[name]
