"""Splitting methods for the rigid body: exact rotations, torque kicks, symmetric compositions.

Free part, principal axes, ``T = Σ m_i²/(2J_i)``. Two second-order symmetric approximations
of its flow are built from exactly integrable pieces:

* **axis sweep** ``T₁(h/2) T₂(h/2) T₃(h) T₂(h/2) T₁(h/2)``, with ``T_i(τ)``: ``θ = τ m_i/J_i``,
  ``m ←`` rotation of ``m`` about ``e_i`` by ``−θ``, ``q ← q ⊗ exp(θ e_i)`` (McLachlan 1993;
  Touma & Wisdom 1994; Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., 2006,
  §VII.5);
* **Casimir split** ``T = G²/(2J₂) + Σ_{i=1,3} ½ (1/J_i − 1/J₂) m_i²``: the ``G²`` flow
  ``q ← q ⊗ exp(τ m/J₂)`` (``m`` constant) commutes with everything, the other two terms are
  axis rotations with ``θ = τ (1/J_i − 1/J₂) m_i``, swept ``R₁(h/2) R₃(h) R₁(h/2)``. For an
  axisymmetric body one term vanishes and the free flow is *exact*, including any fast spin
  about the symmetry axis (Dullweber, Leimkuhler & McLachlan, J. Chem. Phys. 107, 1997).

With a torque ``M(t, q, ω)`` or a rotor ``h(t)`` the rest of the field,
``ṁ = M(t, q, ω) − ḣ(t) − ω × h(t)`` with ``q`` and ``t`` frozen, is a *kick*. A kick is
exact in one evaluation when no rotor momentum is present and the model declares
``torque_depends_on_rate = False`` (gravity, commanded torques); otherwise it is integrated by
RK4 (error O(τ⁵): the compositions then stay fourth order at most).

A composition with weights ``w₁…w_s`` (symmetric, ``Σ w = 1``) is
``kick(w₁h/2) free(w₁h) kick((w₁+w₂)h/2) free(w₂h) … free(w_s h) kick(w_s h/2)``, with each
kick at the time reached so far; adjacent half-kicks at the same (t, q) are merged. World
angular momentum, ``|q|`` and ``|m|`` are kept exactly by every free piece; in floating point
the rounding is kept unbiased (``cos θ = 1 − 2 sin²(θ/2)``; torque-free axis sweeps rotate the
principal rate directly, with no ``m ↔ ω`` conversion per step; body ↔ principal through
``V⁻¹`` and ``V``), so over 10⁶ steps of the torque-free box world H stays within 2.5e−13. For an
axisymmetric body with exact kicks the Casimir and RKN methods run the same maps in the fused
plain-float loop of :mod:`rigid_body_attitude.core.dynamics.integrators.axisymmetric`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.integrators.axisymmetric import (
    compose, spin_frame, SpinFrame)
from rigid_body_attitude.core.dynamics.integrators.base import (
    as_state, BodyModel, check_step, FloatArray, output, q_exp, q_multiply, q_normalize, Quat,
    SERIES_THRESHOLD, Vec)
from rigid_body_attitude.core.dynamics.integrators.dynamics_base import DynamicsMethod
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion

__all__ = [
    'BlanesMoan4Splitting',
    'BlanesMoan6Splitting',
    'Casimir6Splitting',
    'Casimir8Splitting',
    'PrincipalFrame',
    'StrangSplitting',
    'Yoshida4Splitting',
    'axis_sweep',
    'casimir_free_flow',
    'exact_free_flow',
    'rate_axis_sweep',
]

#: Yoshida (1990) fourth-order triple jump.
_Y4 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
YOSHIDA4_WEIGHTS = (_Y4, 1.0 - 2.0 * _Y4, _Y4)
#: Yoshida (1990) sixth-order composition, solution A (seven stages).
_Y6 = (0.784513610477560, 0.235573213359357, -1.17767998417887)
YOSHIDA6_WEIGHTS = _Y6 + (1.0 - 2.0 * sum(_Y6),) + _Y6[::-1]
#: Kahan & Li (Math. Comp. 66, 1997) eighth-order composition s17odr8 (seventeen stages).
_KL8 = (0.13020248308889008087881763, 0.56116298177510838456196441,
        -0.38947496264484728640807860, 0.15884190655515560089621075,
        -0.39590389413323757733623154, 0.18453964097831570709183254,
        0.25837438768632204729397911, 0.29501172360931029887096624)
KAHAN_LI8_WEIGHTS = _KL8 + (-0.60550853383003451169892108,) + _KL8[::-1]
#: Blanes & Moan (J. Comput. Appl. Math. 142, 2002), Table 3, SRKN₆ᵇ (order 4) and SRKN₁₁ᵇ
#: (order 6): kick weights b and free-flow weights a of B(b₁)A(a₁)…A(a₁)B(b₁).
_BM4_B = (0.0829844064174052, 0.396309801498368, -0.0390563049223486)
_BM4_A = (0.245298957184271, 0.604872665711080)
BLANES_MOAN4_KICKS = _BM4_B + (1.0 - 2.0 * sum(_BM4_B),) + _BM4_B[::-1]
BLANES_MOAN4_FREE = _BM4_A + (0.5 - sum(_BM4_A),) * 2 + _BM4_A[::-1]
_BM6_B = (0.0414649985182624, 0.198128671918067, -0.0400061921041533, 0.0752539843015807,
          -0.0115113874206879)
_BM6_A = (0.123229775946271, 0.290553797799558, -0.127049212625417, -0.246331761062075,
          0.357208872795928)
BLANES_MOAN6_KICKS = _BM6_B + (0.5 - sum(_BM6_B),) * 2 + _BM6_B[::-1]
BLANES_MOAN6_FREE = _BM6_A + (1.0 - 2.0 * sum(_BM6_A),) + _BM6_A[::-1]


class PrincipalFrame:
    """Plain-float data of a model's principal frame (cached per model by the methods).

    A diagonal inertia keeps the body axes (``V = I``, no conversions) with the moments in
    body order; ``order`` lists the axes by increasing moment, so sweeps and the Casimir
    reference (the middle moment) do not depend on how the body axes are labelled. Otherwise
    the model's principal axes are used, already sorted.
    """

    def __init__(self, model: BodyModel):
        tensor = np.array(model.tensor_entries, dtype=np.float64).reshape(3, 3)
        if np.count_nonzero(tensor - np.diag(np.diag(tensor))) == 0:
            axes = np.eye(3)
            moments = np.diag(tensor)
            self.order = tuple(int(i) for i in np.argsort(moments, kind='stable'))
        else:
            axes = np.asarray(model.principal_axes, dtype=np.float64)
            moments = np.asarray(model.principal_moments, dtype=np.float64)
            self.order = (0, 1, 2)
        self.moments = tuple(float(x) for x in moments)
        self.axes = tuple(axes.ravel().tolist())  # row-major V: body = V · principal
        # V⁻¹ (not Vᵀ) for body → principal: V Vᵀ differs from I by a fixed ~ε matrix, which
        # every step's round trip applied again (a linear drift, 8e−16 per step in |m|).
        self.inverse_axes = tuple(np.linalg.inv(axes).ravel().tolist())
        self.identity = bool(np.array_equal(axes, np.eye(3)))
        self.rotation = ((1.0, 0.0, 0.0, 0.0) if self.identity  # q_body ⊗ rotation = q_p
                         else tuple(quat.from_matrix(axes).tolist()))
        reference = self.moments[self.order[1]]
        self.reference = reference
        self.casimir = tuple(1.0 / j - 1.0 / reference for j in self.moments)

    def body_vector(self, v: Vec) -> Vec:
        """Principal components to body components, ``V v``."""
        if self.identity:
            return v
        a = self.axes
        return (a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
                a[6] * v[0] + a[7] * v[1] + a[8] * v[2])

    def principal_vector(self, v: Vec) -> Vec:
        """Body components to principal components, ``V⁻¹ v`` (= ``Vᵀ v`` to round-off)."""
        if self.identity:
            return v
        a = self.inverse_axes
        return (a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
                a[6] * v[0] + a[7] * v[1] + a[8] * v[2])

    def body_attitude(self, q: Quat) -> Quat:
        """Principal-frame attitude to body attitude, ``q ⊗ r*``."""
        if self.identity:
            return q
        r = self.rotation
        return q_multiply(q, (r[0], -r[1], -r[2], -r[3]))

    def to_principal(self, q: Quat, omega: Vec) -> tuple[Quat, Vec]:
        """Body-frame ``(q, ω)`` to the principal-frame attitude and momentum
        ``(q ⊗ r, J_p ⊙ (Vᵀ ω))``.

        The rate is rotated, then scaled by the principal moments: no product with the full
        tensor (whose rounding, amplified by ``J⁻¹`` on the way back, cost ~κ(J)ε per step).
        """
        j = self.moments
        if self.identity:
            return q, (j[0] * omega[0], j[1] * omega[1], j[2] * omega[2])
        p = self.principal_vector(omega)
        return q_multiply(q, self.rotation), (j[0] * p[0], j[1] * p[1], j[2] * p[2])

    def to_principal_rate(self, q: Quat, omega: Vec) -> tuple[Quat, Vec]:
        """Body-frame ``(q, ω)`` to the principal-frame ``(q ⊗ r, Vᵀ ω)`` (a rotation only)."""
        if self.identity:
            return q, omega
        return q_multiply(q, self.rotation), self.principal_vector(omega)

    def to_body_rate(self, q: Quat, omega: Vec) -> tuple[Quat, Vec]:
        """Principal-frame ``(q, ω)`` back to the body frame, ``(q ⊗ r*, V ω)``."""
        if self.identity:
            return q, omega
        return self.body_attitude(q), self.body_vector(omega)

    def to_body(self, q: Quat, m: Vec) -> tuple[Quat, Vec]:
        """Principal-frame ``(q, m)`` back to body-frame ``(q ⊗ r*, V (m ⊘ J_p))``."""
        j = self.moments
        rate = (m[0] / j[0], m[1] / j[1], m[2] / j[2])
        if self.identity:
            return q, rate
        return self.body_attitude(q), self.body_vector(rate)


def _rotation(q: Quat, m: Vec, axis: int, theta: float) -> tuple[Quat, Vec]:
    """``q ⊗ exp(θ e_axis)`` and ``m`` rotated about ``e_axis`` by ``−θ`` (principal frame).

    ``cos θ = 1 − 2 sin²(θ/2)``: the form ``cos²(θ/2) − sin²(θ/2)`` rounds ``cos²(θ/2)`` down by
    ``(θ²/8)²`` whenever that is below a quarter ulp (θ ≲ 2e−4), a bias that shrank ``|m|``.
    """
    half = 0.5 * theta
    c2, s2 = math.cos(half), math.sin(half)
    c, s = 1.0 - 2.0 * s2 * s2, 2.0 * s2 * c2
    w, x, y, z = q
    m1, m2, m3 = m
    if axis == 0:
        return ((w * c2 - x * s2, w * s2 + x * c2, y * c2 + z * s2, z * c2 - y * s2),
                (m1, m2 * c + m3 * s, m3 * c - m2 * s))
    if axis == 1:
        return ((w * c2 - y * s2, x * c2 - z * s2, w * s2 + y * c2, z * c2 + x * s2),
                (m1 * c - m3 * s, m2, m1 * s + m3 * c))
    return ((w * c2 - z * s2, x * c2 + y * s2, y * c2 - x * s2, w * s2 + z * c2),
            (m1 * c + m2 * s, m2 * c - m1 * s, m3))


def _rate_rotation(q: Quat, omega: Vec, axis: int, theta: float,
                   frame: PrincipalFrame) -> tuple[Quat, Vec]:
    """:func:`_rotation` carried out on the principal rate ``ω = m ⊘ J``: with ``(j, k)`` the
    other two axes in cyclic order, ``ω_j ← ω_j c + J_k ω_k s/J_j``,
    ``ω_k ← ω_k c − J_j ω_j s/J_k``. No ``m ↔ ω`` conversion per step, whose rounding is
    biased for some moments (the box: +6e−18 in ``|m|`` per step); no precomputed ratios
    ``J_k/J_j``, whose product with ``J_j/J_k`` is a fixed 1 ± ε (a bias of ε sin²θ per
    rotation, 1e−11 in H after 10⁵ Yoshida-4 steps at h|ω| = 2)."""
    half = 0.5 * theta
    c2, s2 = math.cos(half), math.sin(half)
    c, s = 1.0 - 2.0 * s2 * s2, 2.0 * s2 * c2
    j1, j2, j3 = frame.moments
    w, x, y, z = q
    w1, w2, w3 = omega
    if axis == 0:
        return ((w * c2 - x * s2, w * s2 + x * c2, y * c2 + z * s2, z * c2 - y * s2),
                (w1, w2 * c + j3 * w3 * s / j2, w3 * c - j2 * w2 * s / j3))
    if axis == 1:
        return ((w * c2 - y * s2, x * c2 - z * s2, w * s2 + y * c2, z * c2 + x * s2),
                (w1 * c - j3 * w3 * s / j1, w2, w3 * c + j1 * w1 * s / j3))
    return ((w * c2 - z * s2, x * c2 + y * s2, y * c2 - x * s2, w * s2 + z * c2),
            (w1 * c + j2 * w2 * s / j1, w2 * c - j1 * w1 * s / j2, w3))


def rate_axis_sweep(q: Quat, omega: Vec, h: float,
                    frame: PrincipalFrame) -> tuple[Quat, Vec]:
    """:func:`axis_sweep` on the principal rate (``θ = τ ω_i``), for torque-free steps."""
    a, b, c = frame.order
    half = 0.5 * h
    q, omega = _rate_rotation(q, omega, a, half * omega[a], frame)
    q, omega = _rate_rotation(q, omega, b, half * omega[b], frame)
    q, omega = _rate_rotation(q, omega, c, h * omega[c], frame)
    q, omega = _rate_rotation(q, omega, b, half * omega[b], frame)
    return _rate_rotation(q, omega, a, half * omega[a], frame)


def axis_sweep(q: Quat, m: Vec, h: float, frame: PrincipalFrame) -> tuple[Quat, Vec]:
    """``T₁(h/2) T₂(h/2) T₃(h) T₂(h/2) T₁(h/2)`` in the principal frame (order 2; axes by
    increasing moment)."""
    j = frame.moments
    a, b, c = frame.order
    half = 0.5 * h
    q, m = _rotation(q, m, a, half * m[a] / j[a])
    q, m = _rotation(q, m, b, half * m[b] / j[b])
    q, m = _rotation(q, m, c, h * m[c] / j[c])
    q, m = _rotation(q, m, b, half * m[b] / j[b])
    return _rotation(q, m, a, half * m[a] / j[a])


def casimir_free_flow(q: Quat, m: Vec, h: float, frame: PrincipalFrame) -> tuple[Quat, Vec]:
    """``G²/(2J₂)`` flow, then ``R₁(h/2) R₃(h) R₁(h/2)`` (exact when two moments are equal)."""
    a, _, c = frame.order
    ca, cc = frame.casimir[a], frame.casimir[c]
    if ca == 0.0 or cc == 0.0:
        return _casimir_one_axis(q, m, h, frame.reference, c if ca == 0.0 else a,
                                 cc if ca == 0.0 else ca)
    k = h / frame.reference
    q = q_multiply(q, q_exp(k * m[0], k * m[1], k * m[2]))
    half = 0.5 * h
    q, m = _rotation(q, m, a, half * ca * m[a])
    q, m = _rotation(q, m, c, h * cc * m[c])
    return _rotation(q, m, a, half * ca * m[a])


def _casimir_one_axis(q: Quat, m: Vec, h: float, reference: float, axis: int,
                      coefficient: float) -> tuple[Quat, Vec]:
    """Exact axisymmetric free flow ``q ⊗ exp(h m/J_t) ⊗ exp(h c m_s e_s)`` (hot path,
    inlined: the two flows commute, so their order does not matter)."""
    k = h / reference
    vx, vy, vz = k * m[0], k * m[1], k * m[2]
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    if angle < SERIES_THRESHOLD:  # guard zero and subnormal angles
        scale = 0.5 - angle * angle / 48.0
    else:
        scale = math.sin(0.5 * angle) / angle
    ew, ex, ey, ez = math.cos(0.5 * angle), vx * scale, vy * scale, vz * scale
    w, x, y, z = q
    w, x, y, z = (w * ew - x * ex - y * ey - z * ez, w * ex + x * ew + y * ez - z * ey,
                  w * ey - x * ez + y * ew + z * ex, w * ez + x * ey - y * ex + z * ew)
    if coefficient == 0.0:
        return (w, x, y, z), m
    return _rotation((w, x, y, z), m, axis, h * coefficient * m[axis])


def exact_free_flow(q: Quat, m: Vec, h: float, frame: PrincipalFrame) -> tuple[Quat, Vec]:
    """The exact free flow: the Casimir split when two moments are equal (cheap), otherwise
    :class:`TorqueFreeMotion` (Jacobi elliptic functions, ≈0.5 ms)."""
    a, _, c = frame.order
    if frame.casimir[a] == 0.0 or frame.casimir[c] == 0.0:
        return casimir_free_flow(q, m, h, frame)
    motion = TorqueFreeMotion(frame.moments, q, momentum_body=m)
    q_new, omega = motion.state(h)
    j = frame.moments
    return (tuple(q_new.tolist()),
            (float(omega[0]) * j[0], float(omega[1]) * j[1], float(omega[2]) * j[2]))


def _torque(model: BodyModel, t: float, q: Quat, omega: Vec) -> Vec:
    """The model's torque [N m, body] as plain floats (arrays only for a model that needs
    them, ``torque_takes_floats`` False)."""
    if model.torque_takes_floats:
        x, y, z = model.torque_body(t, q, omega)
        return x, y, z
    torque = model.torque_body(t, np.array(q), np.array(omega))
    return float(torque[0]), float(torque[1]), float(torque[2])


def _kick(q: Quat, m: Vec, t: float, tau: float, model: BodyModel,
          frame: PrincipalFrame) -> Vec:
    """Advance ``ṁ = M(t, q, ω) − ḣ(t) − ω × h(t)`` over ``τ`` with q and t frozen.

    ``q`` and ``m`` are principal-frame; the torque and rotor callables see the body frame.
    """
    attitude = frame.body_attitude(q)
    j = frame.moments
    if model.has_rotor:
        rotor, rotor_rate = model.rotor_momentum(t)
        hx, hy, hz = frame.principal_vector((float(rotor[0]), float(rotor[1]), float(rotor[2])))
        rx, ry, rz = frame.principal_vector(
            (float(rotor_rate[0]), float(rotor_rate[1]), float(rotor_rate[2])))
    else:
        hx = hy = hz = rx = ry = rz = 0.0
    if hx == hy == hz == 0.0 and not model.torque_depends_on_rate:
        omega = frame.body_vector((m[0] / j[0], m[1] / j[1], m[2] / j[2]))
        mx, my, mz = frame.principal_vector(_torque(model, t, attitude, omega))
        return m[0] + tau * (mx - rx), m[1] + tau * (my - ry), m[2] + tau * (mz - rz)

    def field(momentum: Vec) -> Vec:
        p, r, s = momentum[0] / j[0], momentum[1] / j[1], momentum[2] / j[2]
        mx, my, mz = frame.principal_vector(
            _torque(model, t, attitude, frame.body_vector((p, r, s))))
        return (mx - rx - (r * hz - s * hy), my - ry - (s * hx - p * hz),
                mz - rz - (p * hy - r * hx))

    half = 0.5 * tau
    k1 = field(m)
    k2 = field((m[0] + half * k1[0], m[1] + half * k1[1], m[2] + half * k1[2]))
    k3 = field((m[0] + half * k2[0], m[1] + half * k2[1], m[2] + half * k2[2]))
    k4 = field((m[0] + tau * k3[0], m[1] + tau * k3[1], m[2] + tau * k3[2]))
    sixth = tau / 6.0
    return (m[0] + sixth * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]),
            m[1] + sixth * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]),
            m[2] + sixth * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]))


def _exact_kick(q: Quat, m: Vec, t: float, tau: float, model: BodyModel,
                frame: PrincipalFrame) -> Vec:
    """``m += τ M(t, q)`` (principal frame): exact for a rate-independent torque, no rotor."""
    j = frame.moments
    if frame.identity:
        mx, my, mz = _torque(model, t, q, (m[0] / j[0], m[1] / j[1], m[2] / j[2]))
        return m[0] + tau * mx, m[1] + tau * my, m[2] + tau * mz
    omega = frame.body_vector((m[0] / j[0], m[1] / j[1], m[2] / j[2]))
    mx, my, mz = frame.principal_vector(_torque(model, t, frame.body_attitude(q), omega))
    return m[0] + tau * mx, m[1] + tau * my, m[2] + tau * mz


def strang_kick_weights(weights: tuple[float, ...]) -> tuple[float, ...]:
    """Kick weights of a composition of Strang steps: ``w₁/2, (w₁+w₂)/2, …, w_s/2``."""
    padded = (0.0,) + tuple(weights) + (0.0,)
    return tuple(0.5 * (a + b) for a, b in zip(padded, padded[1:]))


class _Composition(DynamicsMethod):
    """``B(b₀) A(a₁) B(b₁) … A(a_s) B(b_s)``: kicks B and free flows A (module docstring)."""

    supports_torque = True
    free_weights: tuple[float, ...] = (1.0,)
    kick_weights: tuple[float, ...] = (0.5, 0.5)
    free_flow = staticmethod(axis_sweep)

    def __init__(self) -> None:
        self._model: BodyModel | None = None
        self._frame: PrincipalFrame | None = None
        self._spin: SpinFrame | None = None

    def _frame_of(self, model: BodyModel) -> PrincipalFrame:
        if model is not self._model or self._frame is None:
            self._frame = PrincipalFrame(model)
            exact_flow = type(self).free_flow in (casimir_free_flow, exact_free_flow)
            self._spin = (spin_frame(model, self._frame.axes, self._frame.moments)
                          if exact_flow else None)
            self._model = model
        return self._frame

    def _kick_function(self, model: BodyModel) -> Any:
        """The exact one-evaluation kick when allowed, else the general (RK4) one."""
        if not model.torque_depends_on_rate and not model.has_rotor:
            return _exact_kick
        return _kick

    def _free_only(self, q: Quat, m: Vec, h: float, frame: PrincipalFrame) -> tuple[Quat, Vec]:
        for weight in self.free_weights:
            q, m = self.free_flow(q, m, weight * h, frame)
        return q, m

    def _stages(self, q: Quat, m: Vec, t: float, h: float, model: BodyModel,
                frame: PrincipalFrame, kick: Any, first: float) -> tuple[Quat, Vec]:
        """Every stage of one step but the final kick; the first kick has weight ``first``."""
        free_flow = self.free_flow
        kicks = self.kick_weights
        elapsed = 0.0
        weight = first
        for index, free in enumerate(self.free_weights):
            if weight != 0.0:
                m = kick(q, m, t + elapsed, weight * h, model, frame)
            q, m = free_flow(q, m, free * h, frame)
            elapsed += free * h
            weight = kicks[index + 1]
        return q, m

    def _advance(self, q: Quat, omega: Vec, t: float, h: float,
                 model: BodyModel) -> tuple[Quat, Vec]:
        frame = self._frame_of(model)
        if self._spin is not None:  # axisymmetric, exact kicks: the fused loop
            q, m = self._spin.to_spin(q, omega)
            q, m = compose(q, m, t, h, 1, self.free_weights, self.kick_weights, self._spin)
            q, omega = self._spin.to_body(q, m)
            return q_normalize(q), omega
        if model.torque_free and self.free_flow is axis_sweep:  # on the rate: no J round trip
            q, omega = frame.to_principal_rate(q, omega)
            for weight in self.free_weights:
                q, omega = rate_axis_sweep(q, omega, weight * h, frame)
            q, omega = frame.to_body_rate(q, omega)
            return q_normalize(q), omega
        q, m = frame.to_principal(q, omega)
        if model.torque_free:
            q, m = self._free_only(q, m, h, frame)
        else:
            kick = self._kick_function(model)
            q, m = self._stages(q, m, t, h, model, frame, kick, self.kick_weights[0])
            m = kick(q, m, t + h, self.kick_weights[-1] * h, model, frame)
        q, omega = frame.to_body(q, m)
        return q_normalize(q), omega

    def integrate(self, attitude: ArrayLike, omega_body: ArrayLike, t_start: float, h: float,
                  steps: int, model: BodyModel) -> tuple[FloatArray, FloatArray]:
        """``steps`` equal steps; with exact kicks the last kick of a step and the first of
        the next (same time and attitude) are merged into one torque evaluation, and an
        axisymmetric body runs the fused loop :func:`.axisymmetric.compose`."""
        self._check_model(model)
        frame = self._frame_of(model)
        if self._spin is not None:
            q, omega = as_state(attitude, omega_body)
            q, m = self._spin.to_spin(q, omega)
            q, m = compose(q, m, float(t_start), check_step(h), int(steps), self.free_weights,
                           self.kick_weights, self._spin)
            return output(*self._spin.to_body(q, m))
        if model.torque_free and self.free_flow is axis_sweep:
            # principal frame once per call: no per-step V round trip (its fixed ~ε error)
            q, omega = frame.to_principal_rate(*as_state(attitude, omega_body))
            h = check_step(h)
            for _ in range(int(steps)):
                for weight in self.free_weights:
                    q, omega = rate_axis_sweep(q, omega, weight * h, frame)
                q = q_normalize(q)
            return output(*frame.to_body_rate(q, omega))
        if model.torque_free or self._kick_function(model) is not _exact_kick:
            return super().integrate(attitude, omega_body, t_start, h, steps, model)
        q, omega = as_state(attitude, omega_body)
        h = check_step(h)
        q, m = frame.to_principal(q, omega)
        kicks = self.kick_weights
        merged = kicks[-1] + kicks[0]
        for k in range(int(steps)):
            q, m = self._stages(q, m, t_start + k * h, h, model, frame, _exact_kick,
                                kicks[0] if k == 0 else merged)
            q = q_normalize(q)
        if steps > 0:
            m = _exact_kick(q, m, t_start + steps * h, kicks[-1] * h, model, frame)
        return output(*frame.to_body(q, m))


class StrangSplitting(_Composition):
    """Strang splitting: ``kick(h/2) ∘ T₁(h/2)T₂(h/2)T₃(h)T₂(h/2)T₁(h/2) ∘ kick(h/2)``.

    Order 2; cost five exact axis rotations (five sin/cos pairs) per step, plus two kicks
    (one torque evaluation each when exact, four with RK4) when a torque or rotor acts.
    Invariants (torque-free): ``|q|``, ``|m|`` and the world angular momentum exactly (each
    sub-flow is a rotation that keeps ``q ⊗ m ⊗ q*``), energy bounded without drift
    (symplectic; Hairer–Vilmart body T = 1000, h = 0.05: 4.4e−4). Source: McLachlan (1993);
    Touma & Wisdom (1994); Dullweber, Leimkuhler & McLachlan, J. Chem. Phys. 107 (1997).
    """

    name = 'strang'
    order = 2


class Yoshida4Splitting(_Composition):
    """Yoshida's fourth-order triple jump of Strang steps: ``S(w₁h) S(w₀h) S(w₁h)``.

    ``w₁ = 1/(2 − 2^{1/3})``, ``w₀ = 1 − 2w₁`` (a negative inner step). Order 4; cost fifteen
    axis rotations and four (merged) kicks per step. Invariants as :class:`StrangSplitting`.
    Source: Yoshida, Phys. Lett. A 150 (1990).
    """

    name = 'yoshida4'
    order = 4
    free_weights = YOSHIDA4_WEIGHTS
    kick_weights = strang_kick_weights(YOSHIDA4_WEIGHTS)


class Casimir6Splitting(_Composition):
    """Yoshida's sixth-order seven-stage composition of the Casimir-split Strang step.

    Free flow ``G²/(2J₂)`` flow plus ``R₁(h/2)R₃(h)R₁(h/2)``, exact for an axisymmetric body,
    so a fast spin about the symmetry axis costs nothing and (for a symmetric top with its
    centre of mass on the axis, whose gravity commutes with the spin) does not limit the step.
    Order 6 when kicks are exact (no rotor, ``torque_depends_on_rate`` False), otherwise 4
    (RK4 kicks). Cost seven free flows (one exponential and up to three rotations each) and
    eight kicks per step. Invariants as :class:`StrangSplitting`. Source: Yoshida, Phys.
    Lett. A 150 (1990); Dullweber, Leimkuhler & McLachlan (1997).
    """

    name = 'casimir6'
    order = 6
    free_weights = YOSHIDA6_WEIGHTS
    kick_weights = strang_kick_weights(YOSHIDA6_WEIGHTS)
    free_flow = staticmethod(casimir_free_flow)


class Casimir8Splitting(_Composition):
    """Kahan & Li's eighth-order seventeen-stage composition of the Casimir-split Strang step.

    As :class:`Casimir6Splitting` with the s17odr8 weights. Order 8 when kicks are exact,
    otherwise 4. Cost seventeen free flows and eighteen kicks per step: expensive per step,
    but on the symmetric heavy top (fast spin exact) it reaches 1.0e−9 rad at T = 10 s with 130
    steps, 3.8 ms in the fused loop of :mod:`.axisymmetric` (≈1.7 µs per stage with the
    plain-float gravity torque); scipy's DOP853 needs 21 ms per simulated second on the same
    model, 54× more (accuracy study, docs/accuracy/, ``heavy_top``). Invariants as
    :class:`StrangSplitting`. Source: Kahan & Li, Math. Comp. 66 (1997); Hairer, Lubich &
    Wanner, *Geometric Numerical Integration*, §V.3.
    """

    name = 'casimir8'
    order = 8
    free_weights = KAHAN_LI8_WEIGHTS
    kick_weights = strang_kick_weights(KAHAN_LI8_WEIGHTS)
    free_flow = staticmethod(casimir_free_flow)


class _BlanesMoan(_Composition):
    """RKN splitting methods: the free flow must be exact (:func:`exact_free_flow`)."""

    free_flow = staticmethod(exact_free_flow)

    def _free_only(self, q: Quat, m: Vec, h: float, frame: PrincipalFrame) -> tuple[Quat, Vec]:
        return exact_free_flow(q, m, h, frame)  # torque-free: one exact flow over h


class BlanesMoan4Splitting(_BlanesMoan):
    """Blanes–Moan SRKN₆ᵇ: six exact free flows between seven kicks, order 4.

    Runge–Kutta–Nyström splitting: the order conditions assume ``[B,[B,[B,A]]] = 0``, which
    holds when the kick ``ṁ = M(t, q)`` does not depend on ω (its iterated brackets with the
    free flow lose one power of ``m`` each). Order 4 then; with a rate-dependent torque or a
    rotor (RK4 kicks) the RKN conditions fail, yet the order stays 4 (measured 4.00–4.01 with
    viscous damping and with a rotor, test/core/dynamics/test_integrators_rkn_orders.py). The free
    flow is exact:
    the Casimir split for an axisymmetric body, the elliptic solution otherwise (≈0.5 ms per
    flow). Cost six free flows and six torque evaluations per step (kicks merged across
    steps). Invariants as :class:`StrangSplitting`. Source: Blanes & Moan, J. Comput. Appl.
    Math. 142 (2002), Table 3.
    """

    name = 'rkn4'
    order = 4
    free_weights = BLANES_MOAN4_FREE
    kick_weights = BLANES_MOAN4_KICKS


class BlanesMoan6Splitting(_BlanesMoan):
    """Blanes–Moan SRKN₁₁ᵇ: eleven exact free flows between twelve kicks, order 6.

    Order 6 for a rate-independent torque and no rotor; 4 otherwise (the RKN conditions of
    :class:`BlanesMoan4Splitting` fail; measured 4.00–4.01 with viscous damping and with a
    rotor, test/core/dynamics/test_integrators_rkn_orders.py); exact free flow. Cost eleven free
    flows and eleven torque evaluations per step. On the symmetric heavy top (fast spin
    exact) it reaches 1e−9 rad at T = 10 s with ~240 steps. Invariants as
    :class:`StrangSplitting`. Source: Blanes & Moan,
    J. Comput. Appl. Math. 142 (2002), Table 3.
    """

    name = 'rkn6'
    order = 6
    free_weights = BLANES_MOAN6_FREE
    kick_weights = BLANES_MOAN6_KICKS
