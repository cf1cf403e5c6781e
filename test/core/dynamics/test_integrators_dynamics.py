"""Tests of the dynamics integrators (rk4, rkmk4, strang, yoshida4, dopri45, exact).

References: errors at T = 10 on the test body of Hairer & Vilmart, "Preprocessed discrete
Moser–Veselov algorithm for the full dynamics of a rigid body", J. Phys. A 39, 2006, the exact
torque-free motion,
closed forms with torque (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36), conservation laws of
the gyrostat, and DOP853 at
rtol 1e−13 for the heavy top.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import InputError, IntegratorError
from rigid_body_attitude.core.dynamics.integrators import (
    DYNAMICS_INTEGRATORS, dynamics_integrator, SimpleBodyModel, TorqueFreeMotion)

HV_MOMENTS = np.array([0.6, 0.8, 1.0])
HV_OMEGA = np.array([1.8, 0.4, -0.9]) / HV_MOMENTS
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
TORQUE_METHODS = ['rk4', 'rkmk4', 'strang', 'yoshida4', 'dopri45']

# Hairer–Vilmart body (Hairer & Vilmart 2006): error at T = 10 for N = 100 / 400 / 1600 steps.
HV_TABLE = {
    'rk4': (1.7e-4, 6.7e-7, 2.6e-9),
    'rkmk4': (2.1e-5, 7.9e-8, 3.0e-10),
    'strang': (2.5e-2, 1.5e-3, 9.6e-5),
    'yoshida4': (2.5e-3, 1.0e-5, 3.9e-8),
}


@pytest.fixture(scope='module')
def hv_exact():
    """Exact attitude and rate of the Hairer–Vilmart body at T = 10."""
    return TorqueFreeMotion(HV_MOMENTS, IDENTITY, omega_body=HV_OMEGA).state(10.0)


@pytest.mark.parametrize('name', sorted(HV_TABLE))
def test_integrate_hairer_vilmart_table(name, hv_exact):
    model = SimpleBodyModel(HV_MOMENTS)
    errors = []
    for steps, published in zip((100, 400, 1600), HV_TABLE[name]):
        q, _ = dynamics_integrator(name).integrate(IDENTITY, HV_OMEGA, 0.0, 10.0 / steps,
                                                   steps, model)
        errors.append(quat.attitude_error(q, hv_exact[0]))
        # Same method, same body: within 2× of the published errors (the splitting's sweep
        # order changes its constant by up to ~3×; ours is 0.6× the table).
        assert published / 2.0 <= errors[-1] <= 2.0 * published, (steps, errors)
    order = math.log(errors[1] / errors[2]) / math.log(4.0)
    assert abs(order - dynamics_integrator(name).order) <= 0.3, errors


@pytest.mark.parametrize('name', ['strang', 'yoshida4', 'casimir6', 'casimir8'])
def test_splitting_keeps_world_momentum_and_norm(name):
    model = SimpleBodyModel(HV_MOMENTS)
    integrator = dynamics_integrator(name)
    q, omega = IDENTITY, HV_OMEGA
    world = quat.rotate(q, HV_MOMENTS * omega)
    energy = 0.5 * np.sum(HV_MOMENTS * omega * omega)
    worst_energy = 0.0
    for k in range(50):
        q, omega = integrator.integrate(q, omega, 0.0, 0.05, 40, model)  # 100 s in all
        drift = np.linalg.norm(quat.rotate(q, HV_MOMENTS * omega) - world)
        # Every sub-flow is a rotation of (q, m) that keeps q ⊗ m ⊗ q*: only round-off
        # (~2000 steps × 1e−16 relative each) can move it.
        assert drift <= 1e-13 * np.linalg.norm(world), (k, drift)
        assert abs(np.linalg.norm(q) - 1.0) <= 1e-15
        worst_energy = max(worst_energy,
                           abs(0.5 * np.sum(HV_MOMENTS * omega * omega) / energy - 1.0))
    # Symplectic: energy error bounded (Hairer, Lubich & Wanner 2006, §IX.8: 4.4e−4 at h = 0.05
    # over 1000 s).
    assert worst_energy <= 1e-3


@pytest.mark.parametrize('name', sorted(DYNAMICS_INTEGRATORS))
def test_step_agrees_with_exact_solution_at_small_steps(name):
    tensor = np.array([[2.0, 0.3, -0.1], [0.3, 3.0, 0.2], [-0.1, 0.2, 3.5]])
    model = SimpleBodyModel(tensor)
    attitude = quat.normalize([0.3, -0.5, 0.7, 0.2])
    omega = np.array([0.9, -1.3, 0.6])
    expected_q, expected_omega = TorqueFreeMotion(tensor, attitude, omega_body=omega).state(2.0)
    q, w = dynamics_integrator(name).integrate(attitude, omega, 0.0, 2.0 / 400, 400, model)
    # h|ω| ≈ 0.009: order-2 methods reach ~1e−6 here, order 4 ~1e−10, exact/dopri45 1e−9.
    tolerance = 1e-5 if dynamics_integrator(name).order == 2 else 1e-8
    assert quat.attitude_error(q, expected_q) <= tolerance
    np.testing.assert_allclose(w, expected_omega, rtol=0, atol=tolerance)


def test_exact_one_step_any_length(hv_exact):
    model = SimpleBodyModel(HV_MOMENTS)
    q, w = dynamics_integrator('exact').step(IDENTITY, HV_OMEGA, 0.0, 10.0, model)
    assert quat.attitude_error(q, hv_exact[0]) <= 1e-13
    np.testing.assert_allclose(w, hv_exact[1], atol=1e-13)


def test_exact_refuses_torque_and_rotor():
    with_torque = SimpleBodyModel(HV_MOMENTS, torque_body=lambda t, q, w: np.zeros(3))
    with_rotor = SimpleBodyModel(HV_MOMENTS,
                                 rotor_momentum=lambda t: (np.zeros(3), np.zeros(3)))
    for model in (with_torque, with_rotor):
        with pytest.raises(IntegratorError, match="'exact' handles torque-free bodies only"):
            dynamics_integrator('exact').step(IDENTITY, HV_OMEGA, 0.0, 0.1, model)


@pytest.mark.parametrize('name', ['rkmk4', 'strang', 'yoshida4'])
def test_step_constant_torque_about_principal_axis_exact(name):
    # Landau & Lifshitz 1976, §36: ω ∥ e₂ and M ∥ e₂ keep the axis fixed, θ = ω₀ t + M t²/(2J₂).
    # RKMK4
    # integrates θ̇ = ω (linear in t) exactly, and the splitting's kick is exact for a constant
    # torque, so only round-off remains.
    model = SimpleBodyModel([1.0, 2.0, 2.5], torque_body=lambda t, q, w: np.array([0, 0.6, 0]))
    q, w = dynamics_integrator(name).integrate(IDENTITY, [0.0, 1.5, 0.0], 0.0, 0.1, 30, model)
    theta = 1.5 * 3.0 + 0.6 * 9.0 / (2.0 * 2.0)
    assert quat.attitude_error(q, quat.exp([0.0, theta, 0.0])) <= 1e-12
    np.testing.assert_allclose(w, [0.0, 1.5 + 0.3 * 3.0, 0.0], atol=1e-12)


def test_step_constant_torque_about_principal_axis_rk4_and_dopri45():
    model = SimpleBodyModel([1.0, 2.0, 2.5], torque_body=lambda t, q, w: np.array([0, 0.6, 0]))
    expected = quat.exp([0.0, 1.5 * 3.0 + 0.6 * 9.0 / 4.0, 0.0])
    errors = [quat.attitude_error(dynamics_integrator('rk4').integrate(
        IDENTITY, [0.0, 1.5, 0.0], 0.0, 3.0 / n, n, model)[0], expected) for n in (30, 60)]
    # RK4 on q is not exact for the exponential: fourth order (5e−6 at h|ω| = 0.2).
    assert abs(math.log2(errors[0] / errors[1]) - 4.0) <= 0.3, errors
    q, _ = dynamics_integrator('dopri45', rtol=1e-11, atol=1e-14).step(
        IDENTITY, [0.0, 1.5, 0.0], 0.0, 3.0, model)
    assert quat.attitude_error(q, expected) <= 1e-9


def gyrostat_model(rotor_rate):
    """Triaxial body with a rotor of momentum h(t) = (0.2, 0, 0.5 + rotor_rate·sin t)."""
    def rotor(t):
        return (np.array([0.2, 0.0, 0.5 + rotor_rate * math.sin(t)]),
                np.array([0.0, 0.0, rotor_rate * math.cos(t)]))
    return SimpleBodyModel([0.6, 0.8, 1.0], rotor_momentum=rotor), rotor


@pytest.mark.parametrize('name', TORQUE_METHODS + ['casimir6', 'casimir8'])
def test_step_gyrostat_keeps_total_world_momentum(name):
    # J ω̇ + ω × (Jω + h) = −ḣ with no external torque: the total momentum Jω + h is constant
    # in the world frame, whatever h(t) does.
    model, rotor = gyrostat_model(0.3)
    integrator = dynamics_integrator(name)
    q, omega = IDENTITY, HV_OMEGA
    total = quat.rotate(q, HV_MOMENTS * omega + rotor(0.0)[0])
    q, omega = integrator.integrate(q, omega, 0.0, 0.01, 500, model)
    drift = np.linalg.norm(quat.rotate(q, HV_MOMENTS * omega + rotor(5.0)[0]) - total)
    # h|ω| ≈ 0.03: the order-2 splitting's error is ~1e−5 here, the others ≤ 1e−8.
    tolerance = 1e-4 if integrator.order == 2 else 1e-7
    assert drift <= tolerance * np.linalg.norm(total)


def test_step_gyrostat_constant_rotor_energy():
    # With constant h the kinetic energy ½ωᵀJω is a first integral (ω·(ω × (Jω + h)) = 0).
    model, _ = gyrostat_model(0.0)
    energy = 0.5 * np.sum(HV_MOMENTS * HV_OMEGA ** 2)
    for name in TORQUE_METHODS:
        errors = []
        for steps in (500, 1000):
            _, omega = dynamics_integrator(name).integrate(IDENTITY, HV_OMEGA, 0.0, 5.0 / steps,
                                                           steps, model)
            errors.append(abs(0.5 * np.sum(HV_MOMENTS * omega ** 2) / energy - 1.0))
        if name == 'strang':
            # Order 2 with the gyroscopic term in the kick: 1.3e−4 ≈ 1.3 h² at h = 0.01, and
            # a quarter of that at h/2.
            assert errors[0] <= 3.0 * 0.01 ** 2 and errors[1] <= errors[0] / 3.0, errors
        elif name == 'dopri45':
            assert max(errors) <= 1e-8, errors  # adaptive, rtol 1e−9
        else:
            # Order 4 (3e−8 for yoshida4 at h = 0.01, less for RK4/RKMK4), 16× less at h/2.
            assert errors[0] <= 1e-7, (name, errors)
            assert abs(math.log2(errors[0] / errors[1]) - 4.0) <= 0.3, (name, errors)


def heavy_top_torque(t, attitude, omega_body):
    """Gravity about the pivot: r_cm × R(q)ᵀ (0, 0, −m g), m g = 9.81 N, r_cm = (0, 0, 0.1)."""
    force_body = quat.rotate_inverse(attitude, [0.0, 0.0, -9.81])
    return np.cross([0.0, 0.0, 0.1], force_body)


@pytest.fixture(scope='module')
def heavy_top_reference():
    """DOP853 at rtol 1e−13 (global error ~1e−11 over 2 s here)."""
    tensor = np.diag([0.05, 0.05, 0.02])

    def rhs(t, y):
        q, w = y[:4], y[4:]
        torque = heavy_top_torque(t, q, w)
        w_dot = np.linalg.solve(tensor, torque - np.cross(w, tensor @ w))
        return np.concatenate([0.5 * quat.multiply(q, np.concatenate([[0.0], w])), w_dot])

    start = np.concatenate([quat.exp([0.3, 0.0, 0.0]), [0.0, 0.5, 25.0]])
    solution = solve_ivp(rhs, (0.0, 2.0), start, method='DOP853', rtol=1e-13, atol=1e-14)
    return start, solution.y[:4, -1], solution.y[4:, -1]


@pytest.mark.parametrize('name', TORQUE_METHODS)
def test_step_heavy_top_converges_to_reference(name, heavy_top_reference):
    start, expected_q, expected_omega = heavy_top_reference
    model = SimpleBodyModel([0.05, 0.05, 0.02], torque_body=heavy_top_torque)
    integrator = dynamics_integrator(name)
    errors = []
    for steps in (400, 800):
        q, _ = integrator.integrate(start[:4], start[4:], 0.0, 2.0 / steps, steps, model)
        errors.append(quat.attitude_error(q, expected_q))
    if name == 'dopri45':
        # Adaptive: error set by the tolerance (rtol 1e−9) whatever the output step.
        assert errors[1] <= 1e-7
        return
    order = math.log2(errors[0] / errors[1])
    # Smallest error ~1e−9 ≫ reference 1e−11, so the ratio measures the method.
    assert abs(order - integrator.order) <= 0.3, errors


@pytest.mark.parametrize('name, steps, order', [
    ('casimir6', (40, 80), 6), ('casimir8', (24, 32), 8), ('rkn4', (40, 80), 4),
    ('rkn6', (20, 40), 6)])
def test_casimir_splitting_heavy_top_order(name, steps, order, heavy_top_reference):
    # Gravity does not depend on ω, so the kicks are exact and the composition keeps its
    # order; the spin (25 rad/s) is integrated exactly by the Casimir free flow.
    start, expected_q, _ = heavy_top_reference
    model = SimpleBodyModel([0.05, 0.05, 0.02], torque_body=heavy_top_torque,
                            torque_depends_on_rate=False)
    errors = [quat.attitude_error(dynamics_integrator(name).integrate(
        start[:4], start[4:], 0.0, 2.0 / n, n, model)[0], expected_q) for n in steps]
    measured = math.log(errors[0] / errors[1]) / math.log(steps[1] / steps[0])
    # Errors ≥ 3e−11 against a reference good to ~1e−12: ±0.3 covers both the reference and
    # the pre-asymptotic excess (8.15 measured for casimir8).
    assert abs(measured - order) <= 0.3, errors


@pytest.mark.parametrize('name, steps, order', [('rkn4', (16, 32), 4), ('rkn6', (4, 8), 6)])
def test_rkn_splitting_triaxial_commanded_torque_order(name, steps, order):
    # Triaxial body: the RKN methods use the exact (elliptic) free flow, and a time-dependent,
    # rate-independent torque keeps the RKN order conditions ([B,[B,[B,A]]] = 0).
    moments = np.array([0.6, 0.8, 1.0])

    def torque(t, q, w):
        return (0.2 * math.sin(1.1 * t), 0.1 * math.cos(0.7 * t), 0.05)

    def rhs(t, y):
        w = y[4:]
        w_dot = (np.array(torque(t, y[:4], w)) - np.cross(w, moments * w)) / moments
        return np.concatenate([0.5 * quat.multiply(y[:4], np.concatenate([[0.0], w])), w_dot])
    expected = solve_ivp(rhs, (0.0, 2.0), np.concatenate([IDENTITY, HV_OMEGA]),
                         method='DOP853', rtol=1e-13, atol=1e-14).y[:4, -1]
    model = SimpleBodyModel(moments, torque_body=torque, torque_depends_on_rate=False)
    errors = [quat.attitude_error(dynamics_integrator(name).integrate(
        IDENTITY, HV_OMEGA, 0.0, 2.0 / n, n, model)[0], expected) for n in steps]
    measured = math.log(errors[0] / errors[1]) / math.log(steps[1] / steps[0])
    # Errors ≥ 1e−10 against a reference good to ~1e−12.
    assert abs(measured - order) <= 0.3, errors


@pytest.mark.parametrize('name', ['casimir6', 'casimir8', 'rkn4', 'rkn6'])
def test_casimir_free_flow_exact_for_axisymmetric_body(name):
    # With two equal moments the Casimir split has two commuting exact pieces: one step of
    # any length is the exact solution (up to round-off of ~17 rotations).
    for moments in ([1.0, 1.0, 2.0], [3.0, 1.5, 1.5]):
        q, w = dynamics_integrator(name).step(IDENTITY, [0.3, -0.2, 7.0], 0.0, 3.7,
                                              SimpleBodyModel(moments))
        expected_q, expected_w = TorqueFreeMotion(moments, IDENTITY,
                                                  omega_body=[0.3, -0.2, 7.0]).state(3.7)
        assert quat.attitude_error(q, expected_q) <= 1e-13
        np.testing.assert_allclose(w, expected_w, atol=1e-13)


def test_dopri45_tolerance_controls_error(hv_exact):
    model = SimpleBodyModel(HV_MOMENTS)
    errors = []
    for rtol in (1e-6, 1e-9):
        integrator = dynamics_integrator('dopri45', rtol=rtol, atol=1e-3 * rtol)
        q, _ = integrator.step(IDENTITY, HV_OMEGA, 0.0, 10.0, model)
        errors.append(quat.attitude_error(q, hv_exact[0]))
        assert integrator.steps_taken > 10 and integrator.evaluations >= 6 * integrator.steps_taken
    # Global error roughly proportional to the tolerance (≈ 1e−6 and 1e−8 measured).
    assert errors[0] <= 1e-5 and errors[1] <= 1e-7 and errors[1] < errors[0] / 20.0


def test_dopri45_rejects_bad_tolerance_and_unknown_option():
    with pytest.raises(IntegratorError, match='positive finite tolerances'):
        dynamics_integrator('dopri45', rtol=-1.0)
    with pytest.raises(IntegratorError, match="options \\['order'\\]"):
        dynamics_integrator('rk4', order=5)


def test_step_bad_input_raises_and_leaves_input_alone():
    model = SimpleBodyModel(HV_MOMENTS)
    attitude = IDENTITY.copy()
    with pytest.raises(IntegratorError, match='finite step'):
        dynamics_integrator('rk4').step(attitude, HV_OMEGA, 0.0, float('nan'), model)
    with pytest.raises(InputError, match='omega_body'):
        dynamics_integrator('rk4').step(attitude, [1.0, np.inf, 0.0], 0.0, 0.1, model)
    with pytest.raises(IntegratorError, match="Unknown dynamics integrator 'rk5'"):
        dynamics_integrator('rk5')
    np.testing.assert_array_equal(attitude, IDENTITY)


def test_step_unstable_rk4_reports_instead_of_nan():
    # Explicit methods on a huge step of a fast spin overflow; the integrator must say so.
    model = SimpleBodyModel(HV_MOMENTS)
    with pytest.raises(IntegratorError):
        dynamics_integrator('rk4').integrate(IDENTITY, [300.0, 250.0, -400.0], 0.0, 5.0, 200,
                                             model)


def test_registry_documents_every_integrator():
    for name, cls in DYNAMICS_INTEGRATORS.items():
        assert cls.name == name and isinstance(cls.supports_torque, bool)
        assert 'Order' in cls.__doc__ and 'Source' in cls.__doc__, name


def test_integrators_accept_the_package_rigid_body_model():
    # The propagator's model (rigid_body_attitude.core.dynamics.euler) satisfies the BodyModel
    # protocol.
    from rigid_body_attitude.core.dynamics.euler import RigidBodyModel
    from rigid_body_attitude.core.dynamics.inertia import Inertia
    model = RigidBodyModel(Inertia(np.diag(HV_MOMENTS)), (heavy_top_torque,))
    simple = SimpleBodyModel(HV_MOMENTS, torque_body=heavy_top_torque)
    for name in TORQUE_METHODS:
        expected = dynamics_integrator(name).step(IDENTITY, HV_OMEGA, 0.0, 0.05, simple)
        actual = dynamics_integrator(name).step(IDENTITY, HV_OMEGA, 0.0, 0.05, model)
        np.testing.assert_allclose(actual[0], expected[0], atol=1e-15)
        np.testing.assert_allclose(actual[1], expected[1], atol=1e-14)


@pytest.mark.parametrize('tensor', [[1.0, 2.0, 3.0],
                                    [[2.0, 0.1, 0.0], [0.1, 3.0, -0.2], [0.0, -0.2, 4.0]]])
@pytest.mark.parametrize('terms', ['free', 'torque', 'rotor', 'torque+rotor'])
def test_written_out_rk4_step_is_the_generic_step(tensor, terms):
    # rk4_kernel inlines the same arithmetic term by term (a diagonal tensor's zero products
    # left out, which are exact zeros): same floats as the generic step, and the same work.
    from rigid_body_attitude.core.dynamics.euler import RigidBodyModel
    from rigid_body_attitude.core.dynamics.inertia import Inertia
    from rigid_body_attitude.core.dynamics.integrators.rk4_kernel import rk4_work_step
    from rigid_body_attitude.core.dynamics.integrators.rk4_kernel import rk4_kernel
    torques = [lambda t, q, w: (0.1 * q[1], -0.2 * w[0], 0.3 * t)] if 'torque' in terms else []
    rotors = ([lambda t: ((0.0, 0.3 + 0.1 * t, 0.0), (0.0, 0.1, 0.0))] if 'rotor' in terms
              else [])
    model = RigidBodyModel(Inertia(tensor), float_torques=torques, float_rotors=rotors)
    state = (0.7, -0.1, 0.4, 0.2, 0.9, -1.2, 2.5)
    kernel_state, kernel_work = rk4_kernel(model)(0.3, state, 0.01)
    generic_state, generic_work = rk4_work_step(model, 0.3, state, 0.01)
    assert kernel_state == generic_state
    assert kernel_work == generic_work
    assert (kernel_work != 0.0) == (terms != 'free')
