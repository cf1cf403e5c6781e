"""Strapdown (gyro-driven) attitude updates from a stream of rate or delta-angle samples.

Every method advances ``q ⊗ exp(φ)`` (conventions of
:mod:`rigid_body_attitude.core.attitude.quaternion`:
body rates, ``q̇ = ½ q ⊗ (0, ω_body)``) with a rotation vector ``φ`` built from samples, and
is a small class with

* ``name``, ``order`` (global order on a generic, non-coning rate), ``input_kind``;
* ``reset()`` — forget the sample history (after a gap, a time jump, or a new start);
* ``propagate(q, omega_previous, omega_current, dt) -> q`` on plain float tuples.

``input_kind == 'rate'``: ``omega_previous`` and ``omega_current`` are the rate samples
[rad/s] at the start and the end of the interval ``dt``. ``input_kind == 'delta_angle'``:
``omega_current`` is the mean rate over the interval, ``Δθ/dt`` (what an integrating gyro
reports), and ``omega_previous`` is not used (the method keeps its own history).

**Coning drift** (classical coning: Savage, "Strapdown inertial navigation integration algorithm
design, part 1", 1998; drift per cone period as in Ignagni 1990): under classical coning of
half-angle ``a`` at frequency ``Ω`` about the cone axis ``e``, the drift ``D`` of a method is the
long-run rate [rad/s] of the ``e`` component of the error rotation ``log(q_computed* ⊗ q_true)``
(the rotation vector that takes the computed attitude to the true one, in body axes). ``D > 0``
means the computed attitude lags the true one about the cone axis. Each method's
:attr:`coning_drift` holds the leading-order term ``D = c a²Ω θᵖ`` with
``θ = Ω × (update interval)``: ``θ = Ωh`` for updates over one sample spacing ``h``, ``ΩH``
(``H = 2h``) for ``simpson_coning`` and ``ΩT`` (``T`` = the group of 1, 2 or 3 delta angles) for
the delta-angle methods; the class docstrings quote it, and
test/core/attitude/test_integrators_strapdown.py measures every method's drift against it
(within 5 %) over whole cone periods.
Sources: Bortz (1971), Miller (JGCD 6(4), 1983), Ignagni (JGCD 13(2), 1990; 19(2), 1996),
Savage (JGCD 21(1) and 21(2), 1998).

Stateful methods that combine several sub-intervals (``simpson_coning``, ``delta_two_sample``,
``delta_three_sample``, the start-up of ``magnus4``) return provisional attitudes inside a
group and the final one at its end, computed from the attitude at the group's start (which
they remember), as flight software does with minor and major update rates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.attitude.float_quaternion import (
    q_multiply, q_normalize, q_rotate_step, Quat, Vec)

__all__ = [
    'ConingDrift',
    'DeltaOnePlusPrevious',
    'DeltaSingle',
    'DeltaThreeSample',
    'DeltaTwoSample',
    'EulerNormalize',
    'ExpMap',
    'ExpMidpoint',
    'Magnus4',
    'Rk4Quaternion',
    'STRAPDOWN_METHODS',
    'SimpsonConing',
    'TrapezoidConing',
    'strapdown_method',
]

#: Relative change of the sample spacing above which equal-spacing formulas restart.
SPACING_TOLERANCE = 1e-3


def _vec(v: Sequence[float]) -> Vec:
    return float(v[0]), float(v[1]), float(v[2])


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _trapezoid_coning(a: Vec, b: Vec, h: float) -> Vec:
    """``φ = (h/2)(a + b) + (h²/12) a × b`` for rates ``a``, ``b`` at the interval's ends."""
    c = _cross(a, b)
    k = h * h / 12.0
    return (0.5 * h * (a[0] + b[0]) + k * c[0], 0.5 * h * (a[1] + b[1]) + k * c[1],
            0.5 * h * (a[2] + b[2]) + k * c[2])


@dataclass(frozen=True)
class ConingDrift:
    """Leading-order coning drift ``D = coefficient · a²Ω · θ^power`` (module docstring).

    Attributes:
        coefficient: signed rational coefficient ``c``.
        power: power ``p`` of ``θ``.
        interval: the update interval in sample spacings (θ = Ω · interval · h).
        symbol: how the docstring writes θ (``Ωh``, ``ΩH`` or ``ΩT``).
    """

    coefficient: Fraction
    power: int
    interval: int = 1
    symbol: str = 'Ωh'

    def rate(self, cone_angle: float, frequency: float, spacing: float) -> float:
        """``D`` [rad/s] for half-angle ``a`` [rad], frequency ``Ω`` [rad/s], spacing ``h`` [s]."""
        theta = frequency * self.interval * spacing
        return float(self.coefficient) * cone_angle ** 2 * frequency * theta ** self.power

    def text(self) -> str:
        """The term as the docstrings write it, e.g. ``+a²Ω(Ωh)²/24``."""
        sign = '+' if self.coefficient > 0 else '−'
        numerator, denominator = abs(self.coefficient.numerator), self.coefficient.denominator
        power = str(self.power).translate(str.maketrans('0123456789', '⁰¹²³⁴⁵⁶⁷⁸⁹'))
        factor = '' if numerator == 1 else f'({numerator}/{denominator})'
        tail = f'/{denominator}' if numerator == 1 else ''
        return f'{sign}{factor}a²Ω({self.symbol}){power}{tail}'


class _Strapdown:
    """Shared plumbing: a method without sample history."""

    name = ''
    order = 0
    input_kind = 'rate'
    coning_drift = ConingDrift(Fraction(0), 0)

    def reset(self) -> None:
        """Forget any sample history (stateless methods have none)."""


class ExpMap(_Strapdown):
    """Rate held from the interval's first sample: ``φ = h ω_k`` (zero-order hold).

    Order 1; cost one exponential and one product. Keeps ``|q| = 1``. Coning drift
    ``+a²Ω(Ωh)²/24`` (the next term ``+a²Ω(Ωh)⁴/1440``; Ignagni 1990). The first-order gyro
    step of imu_filter_madgwick-style filters, done exactly on the sphere (Savage 1998).
    """

    name = 'exp_map'
    order = 1
    coning_drift = ConingDrift(Fraction(1, 24), 2)

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """``q ⊗ exp(dt ω_previous)``, renormalised."""
        return q_rotate_step(q, omega_previous[0] * dt, omega_previous[1] * dt,
                             omega_previous[2] * dt)


class ExpMidpoint(_Strapdown):
    """Mean of the end samples: ``φ = (h/2)(ω_k + ω_{k+1})`` (second-order Magnus, no commutator).

    Order 2; cost one exponential. Keeps ``|q| = 1``. Coning drift ``+a²Ω(Ωh)²/6`` (four
    times ``exp_map``'s: the mean of two point samples underestimates the transverse rotation
    by ``cos(θ/2)``). Source: Savage (1998).
    """

    name = 'exp_midpoint'
    order = 2
    coning_drift = ConingDrift(Fraction(1, 6), 2)

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """``q ⊗ exp(dt (ω_previous + ω_current)/2)``."""
        k = 0.5 * dt
        return q_rotate_step(q, k * (omega_previous[0] + omega_current[0]),
                             k * (omega_previous[1] + omega_current[1]),
                             k * (omega_previous[2] + omega_current[2]))


class TrapezoidConing(_Strapdown):
    """Trapezoid plus the coning term: ``φ = (h/2)(ω_k + ω_{k+1}) + (h²/12) ω_k × ω_{k+1}``.

    Order 2 (the trapezoid integral limits it; the coning term is exact to O(h⁵) for any
    smooth rate); cost one exponential and a cross product. Coning drift ``+a²Ω(Ωh)²/12``:
    half ``exp_midpoint``'s, not O(θ⁴) — point rate samples cannot cancel the θ² term, only
    delta angles can (``delta_two_sample``). Source: Savage (1998), Bortz (1971) second-order
    expansion.
    """

    name = 'trapezoid_coning'
    order = 2
    coning_drift = ConingDrift(Fraction(1, 12), 2)

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """One step with the trapezoid-plus-coning rotation vector."""
        return q_rotate_step(q, *_trapezoid_coning(_vec(omega_previous), _vec(omega_current), dt))


class Magnus4(_Strapdown):
    """Fourth-order Magnus increment from a stream of equally spaced rate samples.

    For the interval ``[t_{k−1}, t_k]``::

        φ = (h/24)(ω_{k−3} − 5ω_{k−2} + 19ω_{k−1} + 9ω_k) + (h²/12) ω_{k−1} × ω_k.

    The first term integrates the cubic through the last four samples (Adams–Moulton, local
    error O(h⁵)); the commutator term equals ``(h³/12) ω(t_½) × ω̇(t_½)`` to O(h⁵), which is
    the second Magnus term to that order (the third is O(h⁵)). Start-up: the first two
    intervals return trapezoid-plus-coning attitudes; at the fourth sample the three first
    intervals are recomputed from the stored initial attitude with the cubic through
    ``ω₀…ω₃`` (weights (9, 19, −5, 1), (−1, 13, 13, −1), (1, −5, 19, 9)/24), so the whole run
    is fourth order. A spacing change of more than :data:`SPACING_TOLERANCE` (relative) or a
    ``omega_previous`` that is not the last sample restarts this sequence.

    Order 4; cost one exponential, one cross product. Keeps ``|q| = 1``. Coning drift
    ``−a²Ω(Ωh)⁴/60`` (negative: it leads the truth; the Magnus-4 step with the rate at the
    Gauss points, :func:`~rigid_body_attitude.core.attitude.integrators.kinematic.magnus4_step`,
    drifts
    ``+θ⁴/1440`` instead). Source: Iserles & Nørsett (1999) Magnus expansion;
    Savage (1998).
    """

    name = 'magnus4'
    order = 4
    coning_drift = ConingDrift(Fraction(-1, 60), 4)

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the samples; the next calls run the start-up sequence."""
        self._rates: list[Vec] = []
        self._anchor: Quat | None = None
        self._spacing = 0.0

    def _continues(self, omega_previous: Vec, dt: float) -> bool:
        return (bool(self._rates) and self._rates[-1] == omega_previous
                and abs(dt - self._spacing) <= SPACING_TOLERANCE * abs(self._spacing))

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """One interval; see the class docstring for the start-up sequence."""
        previous, current = _vec(omega_previous), _vec(omega_current)
        if not self._continues(previous, dt):
            self._rates = [previous]
            self._anchor = (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
            self._spacing = dt
        self._rates.append(current)
        rates = self._rates
        if len(rates) < 4:
            return q_rotate_step(q, *_trapezoid_coning(previous, current, dt))
        if len(rates) == 4:
            return self._start_up(dt)
        del rates[0]
        w0, w1, w2, w3 = rates
        k = dt / 24.0
        c = _cross(w2, w3)
        k2 = dt * dt / 12.0
        return q_rotate_step(q, *(k * (a - 5.0 * b + 19.0 * e + 9.0 * f) + k2 * g
                                  for a, b, e, f, g in zip(w0, w1, w2, w3, c)))

    def _start_up(self, dt: float) -> Quat:
        """Recompute the first three intervals with the cubic through ``ω₀…ω₃``."""
        w0, w1, w2, w3 = self._rates
        k, k2 = dt / 24.0, dt * dt / 12.0
        q = self._anchor
        if q is None:  # set with the first sample of the sequence
            raise IntegratorError('magnus4 start-up without a stored initial attitude')
        weights = ((9.0, 19.0, -5.0, 1.0), (-1.0, 13.0, 13.0, -1.0), (1.0, -5.0, 19.0, 9.0))
        ends = ((w0, w1), (w1, w2), (w2, w3))
        for (a0, a1, a2, a3), (start, end) in zip(weights, ends):
            c = _cross(start, end)
            q = q_rotate_step(q, *(k * (a0 * p + a1 * r + a2 * s + a3 * u) + k2 * g
                                   for p, r, s, u, g in zip(w0, w1, w2, w3, c)))
        return q


class SimpsonConing(_Strapdown):
    """Three samples over ``H = 2h``: ``φ = (H/6)(ω₀ + 4ω₁ + ω₂) + (H²/12) ω₀ × ω₂``.

    Order 4 at the end of each pair of intervals (Simpson's rule, and the coning term exact
    to O(H⁵)); the attitude after the first interval of a pair is provisional
    (trapezoid + coning). Cost one exponential per pair plus one provisional. Keeps
    ``|q| = 1``. Coning drift ``+(3/320)a²Ω(ΩH)⁴``. Source: Savage (1998); Ignagni (1990).
    """

    name = 'simpson_coning'
    order = 4
    coning_drift = ConingDrift(Fraction(3, 320), 4, 2, 'ΩH')

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Start a new pair with the next sample."""
        self._first: tuple[Quat, Vec, Vec, float] | None = None

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """Provisional step on the first interval of a pair, Simpson step on the second."""
        previous, current = _vec(omega_previous), _vec(omega_current)
        first = self._first
        if (first is None or first[2] != previous
                or abs(dt - first[3]) > SPACING_TOLERANCE * abs(first[3])):
            anchor = (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
            self._first = (anchor, previous, current, dt)
            return q_rotate_step(q, *_trapezoid_coning(previous, current, dt))
        anchor, w0, w1, _ = first
        self._first = None
        span = 2.0 * dt
        c = _cross(w0, current)
        k, k2 = span / 6.0, span * span / 12.0
        return q_rotate_step(anchor, *(k * (a + 4.0 * b + e) + k2 * g
                                       for a, b, e, g in zip(w0, w1, current, c)))


class EulerNormalize(_Strapdown):
    """Explicit Euler on ``q̇ = ½ q ⊗ (0, ω_k)`` followed by normalisation.

    Order 1; cost one product. ``|q|`` only by projection: without it the norm grows by
    ``(h|ω|)²/8`` per step, with it the attitude lags ``(h|ω|)³/12`` rad per step
    (series of the projected step). Coning drift ``+a²Ω(Ωh)²/24``, as ``exp_map`` (the norm
    projection's lag is O(a³)). The baseline of first-order filters (e.g. imu_filter_madgwick).
    """

    name = 'euler_normalize'
    order = 1
    coning_drift = ConingDrift(Fraction(1, 24), 2)

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """``normalize(q + dt ½ q ⊗ (0, ω_previous))``."""
        k = 0.5 * dt
        d = q_multiply(q, (0.0, k * omega_previous[0], k * omega_previous[1],
                           k * omega_previous[2]))
        return q_normalize((q[0] + d[0], q[1] + d[1], q[2] + d[2], q[3] + d[3]))


class Rk4Quaternion(_Strapdown):
    """Classical RK4 on ``q`` with the rate interpolated linearly between the two samples.

    The midpoint stages use ``(ω_k + ω_{k+1})/2``, whose O(h²) interpolation error limits the
    method to order 2 on sampled rates (order 4 when the rate is known as a function of time,
    see :func:`rigid_body_attitude.core.attitude.integrators.kinematic.rk4_quaternion_step`). Cost
    four
    products; ``|q|`` kept by projection (RK4 alone shrinks it by ``(h|ω|)⁶/9216`` per step).
    Coning drift ``+a²Ω(Ωh)²/12``, as ``trapezoid_coning`` (to which it is equivalent to
    O(h⁴) per step). Source: Kutta (1901); Iserles, Munthe-Kaas, Nørsett & Zanna, "Lie-group
    methods", 2000.
    """

    name = 'rk4_quaternion'
    order = 2
    coning_drift = ConingDrift(Fraction(1, 12), 2)

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """One RK4 step with rates ``ω_k``, ``(ω_k + ω_{k+1})/2``, ``(ω_k + ω_{k+1})/2``,
        ``ω_{k+1}``."""
        a, b = _vec(omega_previous), _vec(omega_current)
        mid = (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]))

        def rate(y: Sequence[float], w: Vec) -> Quat:
            return q_multiply(y, (0.0, 0.5 * w[0], 0.5 * w[1], 0.5 * w[2]))

        y0 = (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
        k1 = rate(y0, a)
        k2 = rate(tuple(y + 0.5 * dt * k for y, k in zip(y0, k1)), mid)
        k3 = rate(tuple(y + 0.5 * dt * k for y, k in zip(y0, k2)), mid)
        k4 = rate(tuple(y + dt * k for y, k in zip(y0, k3)), b)
        s = dt / 6.0
        return q_normalize(tuple(y + s * (p + 2.0 * (r + u) + v)
                                 for y, p, r, u, v in zip(y0, k1, k2, k3, k4)))


class DeltaSingle(_Strapdown):
    """Delta-angle single-sample update: ``φ = Δθ_k`` (no coning correction).

    Order 2 on a generic rate (the integral is exact, the missing commutator is O(h³) per
    step); cost one exponential. Coning drift ``+a²Ω(ΩT)²/12``, ``T = h``. Source: Savage
    (1998), Miller (1983).
    """

    name = 'delta_single'
    order = 2
    input_kind = 'delta_angle'
    coning_drift = ConingDrift(Fraction(1, 12), 2, 1, 'ΩT')

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """``q ⊗ exp(dt ω̄)`` with ``ω̄ = Δθ/dt`` the interval's mean rate."""
        return q_rotate_step(q, omega_current[0] * dt, omega_current[1] * dt,
                             omega_current[2] * dt)


class DeltaOnePlusPrevious(_Strapdown):
    """One sample plus the previous one: ``φ = Δθ_k + (1/12) Δθ_{k−1} × Δθ_k``.

    Order 3 on a generic rate (the coning term is centred half a sample early); cost one
    exponential and a cross product; the first interval after ``reset`` has no previous
    sample and uses ``Δθ_k``. Coning drift ``+a²Ω(ΩT)⁴/60``, ``T = h``. Source: Ignagni
    (1990), Savage (1998).
    """

    name = 'delta_one_plus_previous'
    order = 3
    input_kind = 'delta_angle'
    coning_drift = ConingDrift(Fraction(1, 60), 4, 1, 'ΩT')

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the previous delta angle."""
        self._previous: Vec | None = None

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """One interval with the coning term from the stored previous delta angle."""
        delta = (omega_current[0] * dt, omega_current[1] * dt, omega_current[2] * dt)
        previous, self._previous = self._previous, delta
        if previous is None:
            return q_rotate_step(q, *delta)
        c = _cross(previous, delta)
        return q_rotate_step(q, *(d + g / 12.0 for d, g in zip(delta, c)))


class _DeltaGroup(_Strapdown):
    """Delta-angle methods that update once per group of ``size`` samples."""

    input_kind = 'delta_angle'
    size = 1

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Start a new group with the next sample."""
        self._anchor: Quat | None = None
        self._deltas: list[Vec] = []

    def propagate(self, q: Sequence[float], omega_previous: Sequence[float],
                  omega_current: Sequence[float], dt: float) -> Quat:
        """Provisional ``q ⊗ exp(Δθ)`` inside a group, the full update at its end."""
        if not self._deltas:
            self._anchor = (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
        delta = (omega_current[0] * dt, omega_current[1] * dt, omega_current[2] * dt)
        self._deltas.append(delta)
        if len(self._deltas) < self.size:
            return q_rotate_step(q, *delta)
        phi = self._rotation_vector(self._deltas)
        self._deltas = []
        anchor = self._anchor if self._anchor is not None else q  # set at the group's start
        return q_rotate_step(anchor, *phi)

    def _rotation_vector(self, deltas: list[Vec]) -> Vec:
        raise IntegratorError(f'{type(self).__name__} defines no rotation vector')


class DeltaTwoSample(_DeltaGroup):
    """Two-sample coning algorithm: ``φ = Δθ₁ + Δθ₂ + (2/3) Δθ₁ × Δθ₂`` over ``T = 2h``.

    Order 4 at the group ends (exact for a rate linear in time); cost one exponential per
    two samples plus one provisional. Coning drift ``+a²Ω(ΩT)⁴/960``. Source: Miller (1983),
    Savage (1998).
    """

    name = 'delta_two_sample'
    order = 4
    size = 2
    coning_drift = ConingDrift(Fraction(1, 960), 4, 2, 'ΩT')

    def _rotation_vector(self, deltas: list[Vec]) -> Vec:
        d1, d2 = deltas
        c = _cross(d1, d2)
        k = 2.0 / 3.0
        return (d1[0] + d2[0] + k * c[0], d1[1] + d2[1] + k * c[1], d1[2] + d2[2] + k * c[2])


class DeltaThreeSample(_DeltaGroup):
    """Three-sample coning algorithm over ``T = 3h``::

        φ = Δθ₁ + Δθ₂ + Δθ₃ + (9/20) Δθ₁ × Δθ₃ + (27/40) Δθ₂ × (Δθ₃ − Δθ₁).

    Order 4 at the group ends on a generic rate (the third Magnus term is not modelled);
    cost one exponential per three samples plus two provisional. Coning drift
    ``+a²Ω(ΩT)⁶/204120`` (leading order in ``a``; a residual of about ``7e−3 a⁴Ω(ΩT)⁴``
    dominates it unless ``a ≲ 1e−3`` rad). Source: Miller (1983), Ignagni (1996).
    """

    name = 'delta_three_sample'
    order = 4
    size = 3
    coning_drift = ConingDrift(Fraction(1, 204120), 6, 3, 'ΩT')

    def _rotation_vector(self, deltas: list[Vec]) -> Vec:
        d1, d2, d3 = deltas
        c13 = _cross(d1, d3)
        c2 = _cross(d2, (d3[0] - d1[0], d3[1] - d1[1], d3[2] - d1[2]))
        x, y, z = (a + b + e + 0.45 * g + 0.675 * f
                   for a, b, e, g, f in zip(d1, d2, d3, c13, c2))
        return x, y, z


#: Strapdown methods by name (each value is a class; call it for a fresh instance).
STRAPDOWN_METHODS: dict[str, Any] = {cls.name: cls for cls in (
    ExpMap, ExpMidpoint, TrapezoidConing, Magnus4, SimpsonConing, EulerNormalize,
    Rk4Quaternion, DeltaSingle, DeltaOnePlusPrevious, DeltaTwoSample, DeltaThreeSample)}


def strapdown_method(name: str) -> Any:
    """A fresh strapdown method by name; :class:`IntegratorError` lists the valid names."""
    if name not in STRAPDOWN_METHODS:
        raise IntegratorError(f'Unknown strapdown method {name!r}; expected one of '
                              f'{", ".join(sorted(STRAPDOWN_METHODS))}')
    return STRAPDOWN_METHODS[name]()
