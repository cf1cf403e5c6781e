"""Tests of the fused composition loop for axisymmetric bodies (integrators/axisymmetric.py).

The Casimir and RKN splittings run it for an axisymmetric body under a rate-independent torque
without rotor. References: DOP853 at rtol 1e−13 on the heavy top below (a plain-float
gravity torque, the case the fused loop serves), the general per-stage path of the same
methods, a relabelled copy of the same top, and the top's conservation laws.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator, SimpleBodyModel

FUSED_METHODS = ['casimir6', 'casimir8', 'rkn4', 'rkn6']
START = np.concatenate([quat.exp([0.3, 0.0, 0.0]), [0.0, 0.5, 25.0]])
MOMENTS = (0.05, 0.05, 0.02)  # symmetric top about its pivot [kg m²]
MGL = 9.81 * 0.1  # m g l [N m]


def heavy_top_torque(t, attitude, omega_body):
    """Gravity about the pivot, centre of mass at l e₃: ``m g l e₃ × R(q)ᵀ(−ẑ)`` [N m],
    taking plain floats or arrays (the effect gravity_about_pivot, written in floats)."""
    qw, qx, qy, qz = (float(x) for x in attitude)
    # R(q)ᵀ(−ẑ) = −(2(xz − wy), 2(yz + wx), 1 − 2(x² + y²)); e₃ × g = (−g_y, g_x, 0).
    return (MGL * 2.0 * (qy * qz + qw * qx), -MGL * 2.0 * (qx * qz - qw * qy), 0.0)


def heavy_top_rhs(t, y):
    """Euler + Poisson equations of the top, ``y = (q, ω)``."""
    q, w = y[:4], y[4:]
    moments = np.array(MOMENTS)
    w_dot = (np.array(heavy_top_torque(t, q, w)) - np.cross(w, moments * w)) / moments
    return np.concatenate([0.5 * quat.multiply(q, np.concatenate([[0.0], w])), w_dot])


def heavy_top_energy(q, w):
    """Kinetic plus potential energy ``½ωᵀJω + m g l (R e₃)·ẑ`` [J]."""
    height = 1.0 - 2.0 * (q[1] ** 2 + q[2] ** 2)
    return float(0.5 * np.sum(np.array(MOMENTS) * w * w) + MGL * height)


def test_heavy_top_torque_is_gravity_about_pivot():
    attitude = quat.normalize([0.7, 0.2, -0.4, 0.3])
    force_body = quat.rotate_inverse(attitude, [0.0, 0.0, -1.0])
    np.testing.assert_allclose(heavy_top_torque(0.0, attitude, None),
                               MGL * np.cross([0.0, 0.0, 1.0], force_body), atol=1e-15)


def top_model(moments=MOMENTS, torque=heavy_top_torque, takes_floats=True):
    """The heavy top (gravity ignores ω, no rotor): the fused loop applies."""
    return SimpleBodyModel(moments, torque_body=torque, torque_depends_on_rate=False,
                           torque_takes_floats=takes_floats)


@pytest.fixture(scope='module')
def reference():
    """DOP853 at rtol 1e−13 over 2 s (global error ~1e−12 here)."""
    return solve_ivp(heavy_top_rhs, (0.0, 2.0), START, method='DOP853', rtol=1e-13,
                     atol=1e-15).y[:4, -1]


@pytest.mark.parametrize('name, steps, order', [
    ('casimir6', (40, 80), 6), ('casimir8', (24, 32), 8), ('rkn4', (40, 80), 4),
    ('rkn6', (20, 40), 6)])
def test_integrate_heavy_top_order_with_plain_float_torque(name, steps, order, reference):
    errors = []
    for n in steps:
        q, omega = dynamics_integrator(name).integrate(START[:4], START[4:], 0.0, 2.0 / n, n,
                                                       top_model())
        # The same torque called with arrays (the default) gives the same floats: the
        # plain-float call only saves the conversions.
        q_arrays, omega_arrays = dynamics_integrator(name).integrate(
            START[:4], START[4:], 0.0, 2.0 / n, n, top_model(takes_floats=False))
        np.testing.assert_array_equal(q, q_arrays)
        np.testing.assert_array_equal(omega, omega_arrays)
        errors.append(quat.attitude_error(q, reference))
    measured = math.log(errors[0] / errors[1]) / math.log(steps[1] / steps[0])
    # Errors ≥ 3e−11 against a reference good to ~1e−12; ±0.3 covers the reference and the
    # pre-asymptotic excess (8.14 measured for casimir8, 3.84 for rkn4).
    assert abs(measured - order) <= 0.3, errors


@pytest.mark.parametrize('name', ['casimir6', 'casimir8'])
def test_integrate_fused_loop_matches_general_path(name):
    # One moment one ulp larger: the body is no longer exactly axisymmetric, so the method
    # takes its general per-stage path (Casimir sweep, one exact kick per stage); the
    # dynamics differ by ~1e−16 relative, so both paths must agree to round-off (~1e−14
    # measured over 40 steps of 17 stages).
    triaxial = (MOMENTS[0], float(np.nextafter(MOMENTS[1], 1.0)), MOMENTS[2])
    q_fused, omega_fused = dynamics_integrator(name).integrate(START[:4], START[4:], 0.0, 0.05,
                                                               40, top_model())
    q_general, omega_general = dynamics_integrator(name).integrate(
        START[:4], START[4:], 0.0, 0.05, 40, top_model(triaxial))
    assert quat.attitude_error(q_fused, q_general) <= 1e-12
    np.testing.assert_allclose(omega_fused, omega_general, rtol=0.0, atol=1e-12)


def test_integrate_spin_axis_first_matches_relabelled_top():
    # The same top with body axes relabelled e₁' = e₃, e₂' = e₁, e₃' = e₂ (v' = P v, R' = R Pᵀ):
    # the symmetry axis is now first, so the loop works in a relabelled spin frame and calls
    # the (array) torque through the frame conversion. Same motion up to round-off.
    relabel = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])

    def relabelled_torque(t, attitude, omega_body):
        return MGL * np.cross([1.0, 0.0, 0.0], quat.rotate_inverse(attitude, [0.0, 0.0, -1.0]))
    moments = (MOMENTS[2], MOMENTS[0], MOMENTS[1])
    attitude = quat.from_matrix(quat.to_matrix(START[:4]) @ relabel.T)
    q, omega = dynamics_integrator('casimir8').integrate(
        attitude, relabel @ START[4:], 0.0, 0.05, 40,
        top_model(moments, relabelled_torque, takes_floats=False))
    q_top, omega_top = dynamics_integrator('casimir8').integrate(START[:4], START[4:], 0.0, 0.05,
                                                                 40, top_model())
    expected = quat.from_matrix(quat.to_matrix(q_top) @ relabel.T)
    assert quat.attitude_error(q, expected) <= 1e-12  # ~1e−14 measured
    np.testing.assert_allclose(omega, relabel @ omega_top, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize('name', FUSED_METHODS)
def test_step_repeated_equals_integrate(name):
    # integrate merges the last kick of a step with the first of the next (same t and q);
    # separate steps apply them one after the other: equal up to round-off.
    model = top_model()
    integrator = dynamics_integrator(name)
    q, omega = START[:4], START[4:]
    for k in range(20):
        q, omega = integrator.step(q, omega, 0.1 * k, 0.1, model)
    q_all, omega_all = dynamics_integrator(name).integrate(START[:4], START[4:], 0.0, 0.1, 20,
                                                           model)
    assert quat.attitude_error(q, q_all) <= 1e-13
    np.testing.assert_allclose(omega, omega_all, rtol=0.0, atol=1e-12)


def test_integrate_heavy_top_keeps_vertical_momentum_spin_and_energy():
    # Gravity's torque is horizontal in the world frame and has no component on the
    # symmetry axis, so each kick keeps the world vertical momentum L_z and m₃ = J₃ω₃ exactly;
    # the free flows keep the world momentum and m₃ exactly. Only round-off remains: 0 for
    # ω₃ (M₃ = 0.0 exactly), ~1e−15 for L_z over 2000 steps of 17 stages. The method is
    # symplectic: the energy error stays bounded (2e−14 measured at h = 0.05, order 8).
    model = top_model()
    integrator = dynamics_integrator('casimir8')
    moments = np.array(MOMENTS)
    q, omega = START[:4], START[4:]
    vertical = quat.rotate(q, moments * omega)[2]
    energy = heavy_top_energy(q, omega)
    for _ in range(40):
        q, omega = integrator.integrate(q, omega, 0.0, 0.05, 50, model)  # 100 s in all
        assert abs(quat.rotate(q, moments * omega)[2] - vertical) <= 1e-13 * abs(vertical)
        assert abs(omega[2] - START[6]) <= 4.0 * np.spacing(START[6])
        assert abs(heavy_top_energy(q, omega) / energy - 1.0) <= 1e-12
        assert abs(np.linalg.norm(q) - 1.0) <= 1e-15


def test_integrate_upright_top_at_rest_stays_at_rest():
    # Centre of mass straight above the pivot, no rate: zero torque and zero momentum, so
    # every free flow has a zero rotation angle (the series branch) and nothing moves.
    q, omega = dynamics_integrator('casimir8').integrate([1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                                                         0.0, 0.1, 10, top_model())
    np.testing.assert_array_equal(q, [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(omega, [0.0, 0.0, 0.0])


@pytest.mark.parametrize('name', FUSED_METHODS)
def test_integrate_non_finite_torque_raises(name):
    def broken_torque(t, attitude, omega_body):
        return (math.inf, 0.0, 0.0) if t > 0.25 else (0.0, 0.0, 0.0)
    attitude = START[:4].copy()
    with pytest.raises(IntegratorError, match='(non-finite|finite non-zero)'):
        dynamics_integrator(name).integrate(attitude, START[4:], 0.0, 0.1, 10,
                                            top_model(torque=broken_torque))
    np.testing.assert_array_equal(attitude, START[:4])
