"""Tests of the strapdown stream methods (integrators/strapdown.py).

Orders are measured on a generic, non-coning rate against DOP853 at rtol 2.3e−14; coning
drift on the classical coning motion (Savage, "Strapdown inertial navigation integration algorithm
design, part 1: attitude algorithms", JGCD 21(1), 1998) against closed forms.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion
from rigid_body_attitude.core.attitude.integrators.kinematic import magnus4_step
from rigid_body_attitude.core.attitude.integrators.strapdown import (
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


# The torque-free triaxial body (Hairer & Vilmart, "Preprocessed discrete Moser–Veselov algorithm
# for the full dynamics of a rigid body", J. Phys. A 39, 2006) in its exact motion: the
# body rate a gyro on it would read, and the exact attitude to compare with.
TORQUE_FREE_MOMENTS = (0.6, 0.8, 1.0)
TORQUE_FREE_OMEGA = (1.8 / 0.6, 0.4 / 0.8, -0.9 / 1.0)


@pytest.fixture(scope='module')
def torque_free_streams():
    """Per step count: rate samples, exact delta angles (8-point Gauss–Legendre of the exact
    rate per interval, error ≪ 1e−15 rad) and the exact final attitude."""
    motion = TorqueFreeMotion(TORQUE_FREE_MOMENTS, INITIAL, omega_body=TORQUE_FREE_OMEGA)
    nodes, weights = np.polynomial.legendre.leggauss(8)
    streams = {}
    for steps in (96, 192, 384):
        h = DURATION / steps
        rates = [tuple(w) for w in motion.omega_body(h * np.arange(steps + 1)).tolist()]
        times = h * (np.arange(steps)[:, None] + 0.5 * (1.0 + nodes))
        deltas = 0.5 * h * np.einsum('j,kjc->kc', weights, motion.omega_body(times))
        streams[steps] = (rates, [tuple(d) for d in (deltas / h).tolist()], h)
    return streams, motion.attitude(DURATION)


@pytest.mark.parametrize('name', sorted(STRAPDOWN_METHODS))
def test_propagate_order_on_torque_free_body(name, torque_free_streams):
    streams, truth = torque_free_streams
    errors = []
    for steps, (rates, mean_rates, h) in sorted(streams.items()):
        method = strapdown_method(name)
        q = INITIAL
        for k in range(steps):
            if method.input_kind == 'rate':
                q = method.propagate(q, rates[k], rates[k + 1], h)
            else:
                q = method.propagate(q, None, mean_rates[k], h)
        errors.append(quat.attitude_error(np.array(q), truth))
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(2)]
    # Errors ≥ 1e−10 here, against an exact solution good to ~1e−15: the ratios measure the
    # method alone; ±0.3 as on the generic rate.
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


# Classical coning (Savage 1998) with a small half-angle: the a⁴ residual
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


def measured_drift(step, samples_per_cycle, cycles=21):
    """Mean rate [rad/s] of the error rotation ``log(q_computed* ⊗ q_true)`` about the cone
    axis (the sign convention of strapdown.py), from the first to the last whole cycle (the
    bounded, periodic part cancels). ``step(q, k, h)`` advances over ``[kh, (k + 1)h]``."""
    h = 1.0 / samples_per_cycle
    q = tuple(coning_attitude(0.0).tolist())
    along_axis = []
    for k in range(samples_per_cycle * cycles):
        q = step(q, k, h)
        if (k + 1) % samples_per_cycle == 0:
            true = coning_attitude(round((k + 1) * h))
            along_axis.append(quat.log(quat.multiply(quat.conjugate(np.array(q)), true))[0])
    return (along_axis[-1] - along_axis[0]) / (cycles - 1)


def stream_step(method):
    """Feed ``method`` rate samples (or exact delta angles) of classical coning."""
    def step(q, k, h):
        if method.input_kind == 'rate':
            return method.propagate(q, coning_rate(k * h), coning_rate((k + 1) * h), h)
        return method.propagate(q, None, coning_delta(k * h, h) / h, h)
    return step


# 48 samples per cycle (θ = Ωh = 0.13): the terms after the leading one are ≤ 1.4 % of it
# (measured 0.986–1.0003 of it); the three-sample drift is (ΩT)⁶-small, so 24 samples per
# cycle keep it (7e−12 rad/s) far above round-off, its next term then 1.3 %.
@pytest.mark.parametrize('name', sorted(STRAPDOWN_METHODS))
def test_propagate_coning_drift_matches_documented_coefficient(name):
    cls = STRAPDOWN_METHODS[name]
    samples_per_cycle = 24 if name == 'delta_three_sample' else 48
    drift = measured_drift(stream_step(strapdown_method(name)), samples_per_cycle)
    documented = cls.coning_drift.rate(CONE_ANGLE, CONE_FREQUENCY, 1.0 / samples_per_cycle)
    # The coefficient is leading order in θ and in a; with a = 1e−3 the a⁴ residual is
    # ≤ 1e−5 relative, so 5 % bounds the remaining θ terms and the bounded error left after
    # 20 cycles. The docstring quotes the same term.
    assert drift == pytest.approx(documented, rel=0.05)
    assert cls.coning_drift.text() in ' '.join(cls.__doc__.split())


def test_magnus4_gauss_points_coning_drift():
    # kinematic.magnus4_step (ω(t) at the Gauss points): +a²Ω(Ωh)⁴/1440 (Ignagni, JGCD 13(2),
    # 1990),
    # the figure strapdown.Magnus4's docstring quotes for comparison.
    samples_per_cycle = 24
    drift = measured_drift(lambda q, k, h: magnus4_step(q, coning_rate, k * h, h),
                           samples_per_cycle)
    theta = CONE_FREQUENCY / samples_per_cycle
    assert drift == pytest.approx(CONE_ANGLE ** 2 * CONE_FREQUENCY * theta ** 4 / 1440.0,
                                  rel=0.05)


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
