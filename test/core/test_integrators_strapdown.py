"""Tests of the strapdown stream methods (integrators/strapdown.py).

Orders are measured on a generic, non-coning rate against DOP853 at rtol 2.3e−14; coning
drift on the classical coning motion of physics.md §2.3 against closed forms.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.integrators.strapdown import (
    STRAPDOWN_METHODS, strapdown_method)

DURATION = 4.0
INITIAL = tuple(quat.normalize([0.8, 0.3, -0.2, 0.4]).tolist())


def generic_rate(t):
    """A smooth rate whose direction wanders (no coning symmetry) [rad/s]."""
    return (0.7 * math.sin(1.3 * t) + 0.2, 0.5 * math.cos(2.1 * t) - 0.075 * t,
            0.4 + 0.6 * math.sin(0.7 * t + 1.0))


def generic_angle(t):
    """``∫₀ᵗ generic_rate`` (antiderivative; differences give exact delta angles)."""
    return np.array((-0.7 / 1.3 * math.cos(1.3 * t) + 0.2 * t,
                     0.5 / 2.1 * math.sin(2.1 * t) - 0.0375 * t * t,
                     0.4 * t - 0.6 / 0.7 * math.cos(0.7 * t + 1.0)))


@pytest.fixture(scope='module')
def generic_reference():
    """q(4 s) for the generic rate; DOP853 at rtol 2.3e−14 is good to ~1e−13."""
    solution = solve_ivp(
        lambda t, q: 0.5 * quat.multiply(q, np.concatenate([[0.0], generic_rate(t)])),
        (0.0, DURATION), np.array(INITIAL), method='DOP853', rtol=2.3e-14, atol=1e-16)
    return solution.y[:, -1]


def run_stream(method, steps, rate, angle):
    """Feed ``steps`` equally spaced samples to ``method``; return the final attitude."""
    h = DURATION / steps
    samples = [rate(k * h) for k in range(steps + 1)]
    q = INITIAL
    for k in range(steps):
        if method.input_kind == 'rate':
            q = method.propagate(q, samples[k], samples[k + 1], h)
        else:
            q = method.propagate(q, None, (angle((k + 1) * h) - angle(k * h)) / h, h)
    return np.array(q)


@pytest.mark.parametrize('name', sorted(STRAPDOWN_METHODS))
def test_propagate_order_on_generic_rate(name, generic_reference):
    errors = []
    for steps in (96, 192, 384):  # multiples of 2 and 3 so group methods end on a group
        method = strapdown_method(name)
        final = run_stream(method, steps, generic_rate, generic_angle)
        errors.append(quat.attitude_error(final, generic_reference))
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(2)]
    # Errors here are ≥ 1e−9, far above the reference's 1e−13, so the ratios measure the
    # method alone; ±0.3 allows the pre-asymptotic drift seen on this profile (< 0.05).
    assert all(abs(order - STRAPDOWN_METHODS[name].order) <= 0.3 for order in orders), (
        errors, orders)


def test_propagate_keeps_unit_norm_over_many_steps():
    for name in sorted(STRAPDOWN_METHODS):
        method = strapdown_method(name)
        q = INITIAL
        for k in range(2000):
            w = (3.0 + math.sin(0.01 * k), -2.0, 5.0)
            q = method.propagate(q, w, w, 0.05)
        # Every method renormalises (or uses the exact exponential): round-off only.
        assert abs(math.sqrt(sum(x * x for x in q)) - 1.0) <= 1e-14, name


# Classical coning (physics.md §2.3) with a small half-angle: the a⁴ residual
# (~7e−3 a⁴Ω(ΩT)⁴) is then far below every coefficient tested.
CONE_ANGLE = 1e-3
CONE_FREQUENCY = 2.0 * math.pi


def coning_rate(t):
    """Body rate of classical coning."""
    a, w = CONE_ANGLE, CONE_FREQUENCY
    return (-2.0 * w * math.sin(0.5 * a) ** 2, -w * math.sin(a) * math.sin(w * t),
            w * math.sin(a) * math.cos(w * t))


def coning_attitude(t):
    """Exact attitude of classical coning."""
    a, w = CONE_ANGLE, CONE_FREQUENCY
    return np.array([math.cos(0.5 * a), 0.0, math.sin(0.5 * a) * math.cos(w * t),
                     math.sin(0.5 * a) * math.sin(w * t)])


def coning_delta(t, h):
    """Exact delta angle of classical coning over ``[t, t + h]``."""
    a, w = CONE_ANGLE, CONE_FREQUENCY
    return np.array([-2.0 * w * h * math.sin(0.5 * a) ** 2,
                     -2.0 * math.sin(a) * math.sin(0.5 * w * h) * math.sin(w * (t + 0.5 * h)),
                     2.0 * math.sin(a) * math.sin(0.5 * w * h) * math.cos(w * (t + 0.5 * h))])


def measured_drift(method, samples_per_cycle, cycles=21):
    """Mean rate [rad/s] of the error rotation ``log(q_computed* ⊗ q_true)`` about the cone
    axis, from the first to the last whole cycle (the bounded, periodic part cancels)."""
    h = 1.0 / samples_per_cycle
    rates = [coning_rate(k * h) for k in range(samples_per_cycle * cycles + 1)]
    q = tuple(coning_attitude(0.0).tolist())
    along_axis = []
    for k in range(samples_per_cycle * cycles):
        if method.input_kind == 'rate':
            q = method.propagate(q, rates[k], rates[k + 1], h)
        else:
            q = method.propagate(q, None, coning_delta(k * h, h) / h, h)
        if (k + 1) % samples_per_cycle == 0:
            true = coning_attitude(round((k + 1) * h))
            along_axis.append(quat.log(quat.multiply(quat.conjugate(np.array(q)), true))[0])
    return (along_axis[-1] - along_axis[0]) / (cycles - 1)


def rate_method_drift(amplitude, coning_term, theta):
    """Leading-order (in a) drift of a rate method, in units of a²Ω, exact in θ = Ωh.

    A method whose rotation vector per step has the exact axial part ``−Ωh a²/2``, a
    transverse part of amplitude ``A·a`` rotating by θ per step and an axial coning term
    ``c·a²`` accumulates, by BCH to second order, ``−Ωh a²/2 + c a² + (A² a²/4) cot(θ/2)``
    per step (the sum of ``½ S_k × φ_k`` over the rotating partial sums ``S_k``); the truth
    returns to itself each cycle, so the drift is minus that per unit time. For exact delta
    angles (A = 2 sin(θ/2), c = 0) it gives ``a²Ω(θ − sin θ)/(2θ) ≈ a²Ω θ²/12``.
    """
    return (0.5 * theta - coning_term - 0.25 * amplitude ** 2 / math.tan(0.5 * theta)) / theta


def rate_drift_exp_map(theta):
    """exp(h ω_k): transverse amplitude θ, no coning term (→ θ²/24)."""
    return rate_method_drift(theta, 0.0, theta)


def rate_drift_exp_midpoint(theta):
    """Mean of end samples: amplitude θ cos(θ/2), no coning term (→ θ²/6)."""
    return rate_method_drift(theta * math.cos(0.5 * theta), 0.0, theta)


def rate_drift_trapezoid_coning(theta):
    """Trapezoid + (h²/12) ω_k × ω_{k+1}: coning term θ² sin θ/12 (→ θ²/12)."""
    return rate_method_drift(theta * math.cos(0.5 * theta), theta ** 2 * math.sin(theta) / 12.0,
                             theta)


def rate_drift_magnus4(theta):
    """Adams–Moulton cubic integral + coning term (→ −θ⁴/60)."""
    weights = 9.0 + 19.0 * np.exp(-1j * theta) - 5.0 * np.exp(-2j * theta) + np.exp(-3j * theta)
    return rate_method_drift(theta / 24.0 * abs(weights), theta ** 2 * math.sin(theta) / 12.0,
                             theta)


@pytest.mark.parametrize('name, samples_per_cycle, expected', [
    ('exp_map', 24, rate_drift_exp_map),
    ('euler_normalize', 24, rate_drift_exp_map),
    ('exp_midpoint', 24, rate_drift_exp_midpoint),
    ('trapezoid_coning', 24, rate_drift_trapezoid_coning),
    ('rk4_quaternion', 24, rate_drift_trapezoid_coning),
    ('magnus4', 12, rate_drift_magnus4),
])
def test_propagate_coning_drift_rate_methods(name, samples_per_cycle, expected):
    theta = CONE_FREQUENCY / samples_per_cycle
    drift = measured_drift(strapdown_method(name), samples_per_cycle)
    predicted = expected(theta) * CONE_ANGLE ** 2 * CONE_FREQUENCY
    # The prediction is exact in Ωh and leading order in a: residual O(a²) relative = 1e−6;
    # 5% also covers the bounded error left after 20 cycles. (physics.md §3 lists other
    # coefficients for rate samples, e.g. +a²Ω(Ωh)²/6 for exp_map; this model and the
    # simulation agree with each other, not with those.)
    assert drift == pytest.approx(predicted, rel=0.05)


@pytest.mark.parametrize('name, samples_per_cycle, update_samples, published', [
    ('delta_single', 60, 1, lambda x: x ** 2 / 12.0),
    ('delta_one_plus_previous', 60, 1, lambda x: x ** 4 / 60.0),
    ('delta_two_sample', 60, 2, lambda x: x ** 4 / 960.0),
    ('delta_three_sample', 24, 3, lambda x: x ** 6 / 204120.0),
])
def test_propagate_coning_drift_delta_methods(name, samples_per_cycle, update_samples,
                                              published):
    h = 1.0 / samples_per_cycle
    drift = measured_drift(strapdown_method(name), samples_per_cycle)
    expected = CONE_ANGLE ** 2 * CONE_FREQUENCY * published(CONE_FREQUENCY * update_samples * h)
    # physics.md §3 coefficients (Savage 1998, Ignagni 1996) are leading order in ΩT; at these
    # ΩT the next term is ≤ 1.5% and the a⁴ residual ≤ 0.6%, inside the 5% asked for.
    assert drift == pytest.approx(expected, rel=0.05)


def test_magnus4_restarts_after_spacing_change_and_reset():
    method = strapdown_method('magnus4')
    h = 0.01
    samples = [generic_rate(k * h) for k in range(12)]
    q = INITIAL
    for k in range(6):
        q = method.propagate(q, samples[k], samples[k + 1], h)
    # A sample spacing 10% off breaks the equal-spacing formula: the method must restart,
    # which here means a trapezoid-plus-coning step from the given attitude.
    restarted = method.propagate(q, samples[6], samples[7], 1.1 * h)
    expected = strapdown_method('trapezoid_coning').propagate(q, samples[6], samples[7],
                                                              1.1 * h)
    np.testing.assert_allclose(restarted, expected, atol=1e-16)
    method.reset()
    fresh = method.propagate(q, samples[7], samples[8], h)
    expected = strapdown_method('trapezoid_coning').propagate(q, samples[7], samples[8], h)
    np.testing.assert_allclose(fresh, expected, atol=1e-16)


def test_delta_two_sample_provisional_then_final():
    method = strapdown_method('delta_two_sample')
    first, second = np.array([0.01, -0.02, 0.03]), np.array([0.015, -0.01, 0.02])
    provisional = method.propagate(INITIAL, None, first / 0.1, 0.1)
    np.testing.assert_allclose(provisional, quat.multiply(INITIAL, quat.exp(first)),
                               atol=1e-15)
    final = method.propagate(provisional, None, second / 0.1, 0.1)
    phi = first + second + (2.0 / 3.0) * np.cross(first, second)
    np.testing.assert_allclose(final, quat.multiply(INITIAL, quat.exp(phi)), atol=1e-15)


def test_exp_map_holds_first_sample():
    # README formula: q⁺ = q ⊗ exp(h ω_k) with ω_k the sample at the START of the interval.
    q = strapdown_method('exp_map').propagate(INITIAL, (0.3, 0.0, 0.0), (9.0, 9.0, 9.0), 0.5)
    np.testing.assert_allclose(q, quat.multiply(INITIAL, quat.exp([0.15, 0.0, 0.0])),
                               atol=1e-16)


def test_registry_attributes_and_unknown_name():
    for name, cls in STRAPDOWN_METHODS.items():
        assert cls.name == name and cls.order >= 1 and cls.__doc__
        assert cls.input_kind in ('rate', 'delta_angle')
    with pytest.raises(IntegratorError, match="Unknown strapdown method 'rk5'"):
        strapdown_method('rk5')
