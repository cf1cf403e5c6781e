"""Tests of the attitude kinematics q̇ = ½ q ⊗ (0, ω_body) (kinematics.py).

References: Shuster, "A survey of attitude representations", J. Astronaut. Sci. 41(4), 1993 (fixed
body axis, any rate profile: q(t) = q₀ ⊗ exp(θ(t) e)) and
Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36 (regular precession: q(t) = exp(ω_p t ĥ) ⊗ q₀ ⊗
exp(ω_s t e_b), body rate
ω = ω_p R(q)ᵀ ĥ + ω_s e_b). Convergence orders are measured from errors at halved steps:
for an order-p method the ratio is 2ᵖ up to O(h) corrections.
"""

import math
import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.attitude.kinematics import (
    exp_map_step, quaternion_rate, rk4_quaternion_step)

AXIS = np.array([0.36, 0.48, 0.8])  # unit body axis
Q0 = quat.normalize([0.8, -0.2, 0.3, 0.4])
DURATION = 4.0
STEP_COUNTS = (40, 80, 160, 320)


def fixed_axis_angle(t):
    """θ(t) of a time-varying rate about a fixed body axis (Shuster 1993)."""
    return 0.8 * t + 0.5 * math.sin(1.3 * t)


def fixed_axis_rate(t):
    """ω(t) = θ̇(t) e [rad/s, body]."""
    return (0.8 + 0.65 * math.cos(1.3 * t)) * AXIS


def fixed_axis_attitude(t):
    return quat.multiply(Q0, quat.exp(fixed_axis_angle(t) * AXIS))


# regular precession (Landau & Lifshitz 1976, §36)
SPIN_AXIS_BODY = np.array([0.0, 0.0, 1.0])
PRECESSION_AXIS_WORLD = np.array([0.0, 0.6, 0.8])
PRECESSION_RATE, SPIN_RATE = 0.7, 2.3
PRECESSION_Q0 = quat.normalize([0.9, 0.3, -0.1, 0.2])


def precession_attitude(t):
    return quat.multiply(quat.multiply(quat.exp(PRECESSION_RATE * t * PRECESSION_AXIS_WORLD),
                                       PRECESSION_Q0), quat.exp(SPIN_RATE * t * SPIN_AXIS_BODY))


def precession_rate(t):
    """ω = ω_p R(q)ᵀ ĥ + ω_s e_b [rad/s, body]."""
    return (PRECESSION_RATE * quat.rotate_inverse(precession_attitude(t), PRECESSION_AXIS_WORLD)
            + SPIN_RATE * SPIN_AXIS_BODY)


def rk4_errors(q0, rate, exact_attitude):
    errors = []
    for count in STEP_COUNTS:
        h = DURATION / count
        q = q0
        for k in range(count):
            q = rk4_quaternion_step(q, rate, k * h, h)
        errors.append(quat.attitude_error(q, exact_attitude(DURATION)))
    return np.array(errors)


def observed_orders(errors):
    return np.log2(errors[:-1] / errors[1:])


def test_quaternion_rate_is_half_q_times_pure_omega():
    omega = np.array([0.3, -0.7, 1.1])
    expected = 0.5 * quat.multiply(Q0, np.r_[0.0, omega])
    np.testing.assert_array_equal(quaternion_rate(Q0, omega), expected)
    # batch: several attitudes and rates at once
    attitudes = np.stack([Q0, quat.identity()])
    rates = np.stack([omega, 2.0 * omega])
    batch = quaternion_rate(attitudes, rates)
    for index in range(2):
        np.testing.assert_array_equal(batch[index], quaternion_rate(attitudes[index],
                                                                    rates[index]))
    # q̇ is orthogonal to q, so |q| is a first integral of the exact flow (Shuster 1993)
    assert abs(Q0 @ quaternion_rate(Q0, omega)) <= 1e-16


def test_exp_map_step_exact_for_constant_rate():
    omega = np.array([0.4, -1.3, 2.2])
    h, steps = 0.01, 1000
    q = Q0
    for _ in range(steps):
        q = exp_map_step(q, omega, h)
    # exact per step; 1000 steps accumulate round-off of ~1e−16 each: 1000 × 2.2e−16 bound
    assert quat.attitude_error(q, quat.multiply(Q0, quat.exp(omega * h * steps))) <= 2.2e-13
    assert quat.norm_error(q) <= 4.4e-16


def test_exp_map_step_large_angle_exact():
    # one step of 3 rad: no small-angle approximation anywhere
    omega = np.array([0.0, 30.0, 0.0])
    q = exp_map_step(Q0, omega, 0.1)
    np.testing.assert_allclose(q, quat.multiply(Q0, [math.cos(1.5), 0.0, math.sin(1.5), 0.0]),
                               atol=4e-16)


def test_exp_map_step_with_varying_rate_is_first_order():
    # holding the rate over each step (documented order 1): error halves with h
    errors = []
    for count in STEP_COUNTS:
        h = DURATION / count
        q = Q0
        for k in range(count):
            q = exp_map_step(q, fixed_axis_rate(k * h), h)
        errors.append(quat.attitude_error(q, fixed_axis_attitude(DURATION)))
    orders = observed_orders(np.array(errors))
    np.testing.assert_allclose(orders, 1.0, atol=0.05)


def test_rk4_fixed_axis_time_varying_rate_order_four():
    errors = rk4_errors(Q0, fixed_axis_rate, fixed_axis_attitude)
    # measured 2.7e−7 … 6.7e−11 (ratios 15.9–16.0): order 4 within the O(h) correction
    np.testing.assert_allclose(observed_orders(errors), 4.0, atol=0.1)
    assert errors[-1] <= 1e-10


def test_rk4_regular_precession_order_four():
    # the axis of rotation moves in the body: a genuinely three-dimensional rate profile
    errors = rk4_errors(PRECESSION_Q0, precession_rate, precession_attitude)
    np.testing.assert_allclose(observed_orders(errors), 4.0, atol=0.1)
    assert errors[-1] <= 1e-8


def test_regular_precession_rate_satisfies_poisson_equation():
    # Landau & Lifshitz 1976, §36: the closed form and its body rate obey q̇ = ½ q ⊗ (0, ω)
    for t in (0.0, 0.9, 3.1):
        delta = 1e-5  # central difference: truncation δ²|q'''|/6 ≈ 2e−10, round-off 1e−11
        derivative = (precession_attitude(t + delta) - precession_attitude(t - delta)) / (
            2.0 * delta)
        np.testing.assert_allclose(derivative,
                                   quaternion_rate(precession_attitude(t), precession_rate(t)),
                                   atol=1e-9)


def test_rk4_keeps_unit_norm():
    q = Q0
    for k in range(100):
        q = rk4_quaternion_step(q, lambda t: np.array([20.0, -5.0, 3.0]), 0.05 * k, 0.05)
    assert quat.norm_error(q) <= 4.4e-16


def test_rk4_quaternion_step_batches():
    attitudes = np.stack([Q0, PRECESSION_Q0])

    def rates(t):
        return np.stack([fixed_axis_rate(t), precession_rate(t)])

    batch = rk4_quaternion_step(attitudes, rates, 0.3, 0.01)
    np.testing.assert_allclose(batch[0], rk4_quaternion_step(Q0, fixed_axis_rate, 0.3, 0.01),
                               atol=1e-16)
    np.testing.assert_allclose(batch[1], rk4_quaternion_step(PRECESSION_Q0, precession_rate,
                                                             0.3, 0.01), atol=1e-16)


@pytest.mark.parametrize('call, message', [
    (lambda: exp_map_step(Q0, [1.0, 2.0], 0.1),
     'Expected `omega_body` to have shape (..., 3), got (2,)'),
    (lambda: exp_map_step(Q0, [1.0, np.nan, 0.0], 0.1), 'Expected `omega_body` to be finite'),
    (lambda: quaternion_rate(Q0, [1.0, 2.0, 3.0, 4.0]),
     'Expected `omega_body` to have shape (..., 3), got (4,)'),
    (lambda: rk4_quaternion_step([1.0, 0.0, 0.0], fixed_axis_rate, 0.0, 0.1),
     'Expected `attitude` to have shape (..., 4), got (3,)'),
])
def test_bad_input_rejected(call, message):
    with pytest.raises(InputError, match=re.escape(message)):
        call()
