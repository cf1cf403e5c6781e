"""Tests of the ω(t)-driven kinematic methods (integrators/kinematic.py) and of the angle and
direction-cosine forms (integrators/angles.py)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.attitude.integrators import angles
from rigid_body_attitude.core.attitude.integrators.kinematic import (
    KINEMATIC_METHODS, kinematic_method)

DURATION = 4.0
INITIAL = tuple(quat.normalize([0.8, 0.3, -0.2, 0.4]).tolist())


def generic_rate(t):
    """A smooth rate whose direction wanders (no coning symmetry) [rad/s]."""
    return (0.7 * math.sin(1.3 * t) + 0.2, 0.5 * math.cos(2.1 * t) - 0.075 * t,
            0.4 + 0.6 * math.sin(0.7 * t + 1.0))


@pytest.fixture(scope='module')
def reference():
    """q(4 s) by DOP853 at rtol 2.3e−14 (good to ~1e−13)."""
    solution = solve_ivp(
        lambda t, q: 0.5 * quat.multiply(q, np.concatenate([[0.0], generic_rate(t)])),
        (0.0, DURATION), np.array(INITIAL), method='DOP853', rtol=2.3e-14, atol=1e-16)
    return solution.y[:, -1]


def measured_orders(errors):
    """log2 of successive error ratios for step counts doubling."""
    return [math.log2(errors[i] / errors[i + 1]) for i in range(len(errors) - 1)]


@pytest.mark.parametrize('name', sorted(KINEMATIC_METHODS))
def test_integrate_order_on_generic_rate(name, reference):
    method = kinematic_method(name)
    errors = [quat.attitude_error(np.array(method.integrate(INITIAL, generic_rate, 0.0,
                                                            DURATION / n, n)), reference)
              for n in (96, 192, 384)]
    # Smallest error ~4e−11 ≫ reference error 1e−13: the ratios measure the method.
    assert all(abs(order - method.order) <= 0.3 for order in measured_orders(errors)), errors


def test_integrate_exponential_methods_keep_norm_at_large_steps():
    for name in ('exp_map', 'exp_midpoint', 'magnus4', 'cf4', 'rkmk4', 'bortz'):
        q = kinematic_method(name).integrate(INITIAL, lambda t: (40.0, -25.0, 10.0), 0.0,
                                             0.05, 400)
        assert abs(math.sqrt(sum(x * x for x in q)) - 1.0) <= 1e-14, name


def test_integrate_constant_rate_is_exact_for_exponential_methods():
    # A constant rate has exact solution q0 ⊗ exp(t ω): the Magnus family reproduces it up to
    # round-off (~1e−13 after 100 steps), whatever the step.
    omega = (0.4, -1.1, 2.0)
    expected = quat.multiply(INITIAL, quat.exp(10.0 * np.array(omega)))
    for name in ('exp_map', 'exp_midpoint', 'magnus4', 'cf4', 'rkmk4', 'bortz'):
        q = kinematic_method(name).integrate(INITIAL, lambda t: omega, 0.0, 0.1, 100)
        assert quat.attitude_error(np.array(q), expected) <= 1e-12, name


def test_magnus4_coning_drift_gauss_points():
    # Coning (Savage, "Strapdown inertial navigation integration algorithm design, part 1: attitude
    # algorithms", JGCD 21(1), 1998), a = 1e−3, Ωh = 2π/12. Leading order in a, exact in θ = Ωh:
    # drift = a²Ω (θ/2 − c − (A²/4) cot(θ/2))/θ with A = θ cos(θ/(2√3)), c = (√3/12) θ²
    # sin(θ/√3) (see test_integrators_strapdown.rate_method_drift) → +a²Ω θ⁴/1440.
    a, frequency, per_cycle = 1e-3, 2.0 * math.pi, 12
    h, theta = 1.0 / per_cycle, 2.0 * math.pi / per_cycle

    def rate(t):
        return (-2 * frequency * math.sin(a / 2) ** 2, -frequency * math.sin(a) *
                math.sin(frequency * t), frequency * math.sin(a) * math.cos(frequency * t))

    def truth(t):
        return np.array([math.cos(a / 2), 0.0, math.sin(a / 2) * math.cos(frequency * t),
                         math.sin(a / 2) * math.sin(frequency * t)])

    method = kinematic_method('magnus4')
    q = tuple(truth(0.0).tolist())
    along_axis = []
    for cycle in range(21):
        q = method.integrate(q, rate, float(cycle), h, per_cycle)
        along_axis.append(quat.log(quat.multiply(quat.conjugate(np.array(q)),
                                                 truth(cycle + 1.0)))[0])
    drift = (along_axis[-1] - along_axis[0]) / 20.0
    amplitude = theta * math.cos(theta / (2.0 * math.sqrt(3.0)))
    coning = math.sqrt(3.0) / 12.0 * theta ** 2 * math.sin(theta / math.sqrt(3.0))
    predicted = a * a * frequency * (0.5 * theta - coning
                                     - 0.25 * amplitude ** 2 / math.tan(0.5 * theta)) / theta
    assert drift == pytest.approx(predicted, rel=0.05)
    assert predicted == pytest.approx(a * a * frequency * theta ** 4 / 1440.0, rel=0.05)


def test_kinematic_method_unknown_name():
    with pytest.raises(IntegratorError, match="Unknown kinematic method 'magnus6'"):
        kinematic_method('magnus6')


def integrate_angles(step, to_quaternion, from_quaternion, steps):
    """Integrate an angle form over the generic rate and return the final quaternion."""
    state = tuple(from_quaternion(np.array(INITIAL)).tolist())
    h = DURATION / steps
    for k in range(steps):
        state = step(state, generic_rate, k * h, h)
    return to_quaternion(np.array(state))


@pytest.mark.parametrize('step, to_quaternion, from_quaternion', [
    (angles.euler_zxz_rk4_step, quat.from_euler_zxz, quat.as_euler_zxz),
    (angles.bryant_xyz_rk4_step, quat.from_bryant_xyz, quat.as_bryant_xyz),
])
def test_angle_forms_fourth_order_away_from_singularity(step, to_quaternion, from_quaternion,
                                                        reference):
    errors = [quat.attitude_error(integrate_angles(step, to_quaternion, from_quaternion, n),
                                  reference) for n in (192, 384, 768)]
    # Same reference as above; also checks the Euler and Bryant angle rates (Wittenburg 2008, §2.2)
    # against our conventions (a
    # sign slip there would leave an O(1) error, not order 4).
    assert all(abs(order - 4.0) <= 0.3 for order in measured_orders(errors)), errors


def test_angle_rates_refuse_singularity():
    with pytest.raises(IntegratorError, match='sin θ = 0'):
        angles.euler_zxz_rk4_step((0.3, 1e-12, 0.2), generic_rate, 0.0, 0.01)
    with pytest.raises(IntegratorError, match='cos α₂ = 0'):
        angles.bryant_xyz_rk4_step((0.3, 0.5 * math.pi, 0.2), generic_rate, 0.0, 0.01)


def test_angle_rates_euler_match_quaternion_rate():
    # ω from the angle rates must reproduce q̇ = ½ q ⊗ (0, ω) (finite difference, 1e−7 step).
    state = np.array([0.4, 1.1, -0.7])
    omega = np.array([0.3, -0.8, 1.2])
    rates = np.array(angles.euler_zxz_rates(state, omega))
    step = 1e-6
    q_dot = (quat.from_euler_zxz(state + step * rates)
             - quat.from_euler_zxz(state - step * rates)) / (2 * step)
    expected = 0.5 * quat.multiply(quat.from_euler_zxz(state), np.concatenate([[0.0], omega]))
    np.testing.assert_allclose(q_dot, expected, atol=1e-9)


def test_dcm_poisson_order_and_orthonormality(reference):
    errors, drift = [], {}
    for orthonormalize in (False, True):
        for n in (96, 192, 384):
            matrix = quat.to_matrix(INITIAL)
            h = DURATION / n
            for k in range(n):
                matrix = angles.dcm_poisson_rk4_step(matrix, generic_rate, k * h, h,
                                                     orthonormalize)
            u, _, vt = np.linalg.svd(matrix)
            if orthonormalize:
                errors.append(quat.attitude_error(quat.from_matrix(u @ vt), reference))
            drift[(orthonormalize, n)] = np.abs(matrix.T @ matrix - np.eye(3)).max()
    assert all(abs(order - 4.0) <= 0.3 for order in measured_orders(errors)), errors
    # RK4 does not keep AᵀA = I (drift O(h⁴) here, 1e−9 at n = 96); the projection does.
    assert drift[(False, 96)] > 1e-10
    assert drift[(True, 96)] <= 1e-14
