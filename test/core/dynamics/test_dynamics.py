"""Tests of Euler's equations and the RK4 baseline (dynamics.py) against closed forms.

References (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36): fixed body axis with a constant
torque, θ = ω₀ t + M t²/(2 J_k);
the axisymmetric torque-free body, a regular precession; the box about a corner (Goldstein,
Poole & Safko, *Classical Mechanics*, 3rd ed., 2002, §5.3); RK4 on the test body of Hairer &
Vilmart, "Preprocessed discrete Moser–Veselov algorithm for the full dynamics of a rigid body", J.
Phys. A 39, 2006. RK4 is order 4: its global error is
C h⁴, so halving h divides it by 16; the bounds below are the measured error at the stated
step with a margin below the next power of two, and the ratio is checked too.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.euler import euler_rate, RigidBodyModel, rk4_step
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping

E_Z = np.array([0.0, 0.0, 1.0])


def dynamics_scene(inertia, omega_body, attitude=(1.0, 0.0, 0.0, 0.0), step=0.001,
                   effects=(), mass=1.0):
    return scene_from_mapping({
        'rate_source': 'dynamics', 'step': step, 'body': {'mass': mass, 'inertia': inertia},
        'initial_state': {'attitude': list(attitude), 'omega_body': list(omega_body)},
        'effects': list(effects)})


def run(scene, duration):
    propagator = DynamicsPropagator(scene)
    propagator.advance_to(duration)
    return propagator


# --- the right-hand side --------------------------------------------------------------------

def test_euler_rate_hand_computation():
    # J = diag(1, 2, 3), ω = (1, 2, 3): ω × Jω = (1, 2, 3) × (1, 4, 9) = (6, −6, 2)
    inertia = Inertia([1.0, 2.0, 3.0])
    omega = np.array([1.0, 2.0, 3.0])
    np.testing.assert_allclose(euler_rate(inertia, omega, np.zeros(3)), [-6.0, 3.0, -2.0 / 3.0],
                               rtol=1e-15)
    # with torque M = (1, 1, 1), rotor h = (0, 1, 0), ḣ = (0.5, 0, 0):
    # ω × (Jω + h) = (1, 2, 3) × (1, 5, 9) = (3, −6, 3); M − ḣ − that = (−2.5, 7, −2)
    rate = euler_rate(inertia, omega, np.ones(3), np.array([0.0, 1.0, 0.0]),
                      np.array([0.5, 0.0, 0.0]))
    np.testing.assert_allclose(rate, [-2.5, 3.5, -2.0 / 3.0], rtol=1e-15)


def test_euler_rate_full_tensor_matches_linear_solve():
    inertia = Inertia.box(2.0, [0.1, 0.2, 0.3], about='corner')
    omega = np.array([0.3, -1.0, 2.0])
    torque = np.array([0.01, 0.02, -0.03])
    expected = np.linalg.solve(inertia.tensor, torque - np.cross(omega, inertia.tensor @ omega))
    np.testing.assert_allclose(euler_rate(inertia, omega, torque), expected, rtol=1e-13)


def test_model_sums_torques_and_rotors():
    inertia = Inertia([1.0, 2.0, 3.0])
    model = RigidBodyModel(
        inertia,
        (lambda t, q, w: np.array([t, 0.0, 0.0]), lambda t, q, w: -w),
        (lambda t: (np.array([0.0, 0.0, t]), np.array([0.0, 0.0, 1.0])),
         lambda t: (np.array([1.0, 0.0, 0.0]), np.zeros(3))))
    omega = np.array([0.1, 0.2, 0.3])
    assert not model.torque_free and RigidBodyModel(inertia).torque_free
    np.testing.assert_array_equal(model.torque_body(2.0, quat.identity(), omega),
                                  [1.9, -0.2, -0.3])
    momentum, rate = model.rotor_momentum(2.0)
    np.testing.assert_array_equal(momentum, [1.0, 0.0, 2.0])
    np.testing.assert_array_equal(rate, [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(model.external_torque(2.0, quat.identity(), omega),
                                  [1.9, -0.2, -1.3])
    np.testing.assert_allclose(
        model.omega_dot(2.0, quat.identity(), omega),
        euler_rate(inertia, omega, np.array([1.9, -0.2, -0.3]), momentum, rate), rtol=1e-15)


# --- RK4 on the Hairer–Vilmart body (Hairer & Vilmart 2006)
# ------------------------------------------

def test_rk4_reproduces_the_reference_table():
    # J = (0.6, 0.8, 1.0), m₀ = (1.8, 0.4, −0.9), q₀ = 1, T = 10; reference q(10) from §2.5.
    # The table's RK4 column (attitude error) has two digits, so agree to 4 %.
    moments = np.array([0.6, 0.8, 1.0])
    final_attitude = [-0.736061364160793, -0.570786951240351, -0.299388571830791,
                      -0.206839086104672]
    model = RigidBodyModel(Inertia(moments))
    table = {100: 1.7e-4, 400: 6.7e-7, 1600: 2.6e-9, 3200: 1.6e-10}
    for steps, expected_error in table.items():
        h = 10.0 / steps
        attitude, omega = quat.identity(), np.array([1.8, 0.4, -0.9]) / moments
        for k in range(steps):
            attitude, omega = rk4_step(model, k * h, attitude, omega, h)
        error = quat.attitude_error(attitude, final_attitude)
        assert error == pytest.approx(expected_error, rel=0.04)
        assert quat.norm_error(attitude) <= 4.4e-16


# --- fixed axis, constant torque (Landau & Lifshitz 1976, §36)
# -------------------------------------------

@pytest.mark.parametrize('step, bound', [(0.01, 5e-10), (0.005, 5e-10 / 16)])
def test_constant_torque_about_principal_axis(step, bound):
    # J = diag(2, 3, 5), ω₀ = 1.5 e_z, M = 0.6 e_z (constant_torque effect):
    # θ(t) = ω₀ t + M t²/(2 J₃); ω linear in t, which RK4 integrates exactly (round-off only);
    # the attitude error is O(h⁴): measured 3.5e−10 at h = 0.01 and 2.2e−11 at 0.005
    q0 = quat.normalize([0.9, 0.1, 0.2, -0.3])
    scene = dynamics_scene({'moments': [2.0, 3.0, 5.0]}, [0.0, 0.0, 1.5], q0, step,
                           [{'constant_torque': {'torque': [0.0, 0.0, 0.6]}}])
    propagator = run(scene, 4.0)
    t = propagator.state.time
    assert t == pytest.approx(4.0, abs=1e-12)
    angle = 1.5 * t + 0.6 * t * t / (2.0 * 5.0)
    assert quat.attitude_error(propagator.state.attitude,
                               quat.multiply(q0, quat.exp(angle * E_Z))) <= bound
    np.testing.assert_allclose(propagator.state.omega_body, [0.0, 0.0, 1.5 + 0.6 * t / 5.0],
                               rtol=0, atol=1e-13)


# --- axisymmetric torque-free body: regular precession (Landau & Lifshitz 1976, §36)
# ----------------

TRANSVERSE, AXIAL = 2.0, 3.0
AXI_OMEGA0 = np.array([0.4, -0.3, 2.0])
AXI_Q0 = quat.normalize([0.9, 0.1, 0.2, -0.3])
AXI_MOMENTUM = np.array([TRANSVERSE, TRANSVERSE, AXIAL]) * AXI_OMEGA0
AXI_G = np.linalg.norm(AXI_MOMENTUM)
AXI_H_HAT = quat.rotate(AXI_Q0, AXI_MOMENTUM) / AXI_G
BODY_NUTATION_RATE = AXI_OMEGA0[2] * (AXIAL - TRANSVERSE) / TRANSVERSE   # Ω_b


def axisymmetric_exact(t):
    """§2.4: q(t) = exp((G/J_t) t ĥ) ⊗ q₀ ⊗ exp(−Ω_b t e₃), ω₁ + iω₂ rotating at Ω_b."""
    attitude = quat.multiply(quat.multiply(quat.exp(AXI_G / TRANSVERSE * t * AXI_H_HAT), AXI_Q0),
                             quat.exp(-BODY_NUTATION_RATE * t * E_Z))
    transverse = (AXI_OMEGA0[0] + 1j * AXI_OMEGA0[1]) * np.exp(1j * BODY_NUTATION_RATE * t)
    return attitude, np.array([transverse.real, transverse.imag, AXI_OMEGA0[2]])


def test_axisymmetric_closed_form_is_a_regular_precession():
    # §2.2 with ω_p = G/J_t about ĥ and ω_s = −Ω_b about e₃: the body rate ω_p R(q)ᵀ ĥ + ω_s e₃
    # is the §2.4 rate, to round-off
    for t in (0.0, 1.3, 7.9):
        attitude, omega = axisymmetric_exact(t)
        precession = (AXI_G / TRANSVERSE * quat.rotate_inverse(attitude, AXI_H_HAT)
                      - BODY_NUTATION_RATE * E_Z)
        np.testing.assert_allclose(precession, omega, atol=1e-14)


def test_axisymmetric_torque_free_dynamics_order_four():
    errors = []
    for step in (0.01, 0.005):
        scene = dynamics_scene({'moments': [TRANSVERSE, TRANSVERSE, AXIAL]}, AXI_OMEGA0, AXI_Q0,
                               step)
        propagator = run(scene, 10.0)
        attitude, omega = axisymmetric_exact(propagator.state.time)
        errors.append(max(quat.attitude_error(propagator.state.attitude, attitude),
                          np.max(np.abs(propagator.state.omega_body - omega))))
    # measured 2.0e−9 at h = 0.01 (1000 steps, |ω| h = 0.02): bound 4e−9; order 4 → ratio 16
    assert errors[0] <= 4e-9
    assert 14.0 <= errors[0] / errors[1] <= 18.0


# --- box about a corner (Goldstein 2002, §5.3): full tensor, principal decomposition -------------

BOX_EDGES = [0.1, 0.2, 0.3]
BOX_OMEGA0 = np.array([1.0, -2.0, 3.0])
BOX_Q0 = quat.normalize([0.7, 0.1, 0.5, -0.2])


def box_corner_scene():
    return dynamics_scene({'box': {'edges': BOX_EDGES, 'about': 'corner'}}, BOX_OMEGA0, BOX_Q0,
                          mass=2.0)


def test_box_corner_same_motion_as_in_principal_axes():
    # The same body described in its principal axes: q' = q ⊗ P, ω' = Pᵀ ω (P principal →
    # body). RK4 is covariant under linear changes of variables, so both runs agree to
    # round-off (5000 steps × ~1e−16 → 1e−12 bound), while the tensor is far from diagonal.
    inertia = Inertia.box(2.0, BOX_EDGES, about='corner')
    rotation = inertia.principal_rotation
    principal = dynamics_scene({'moments': inertia.principal_moments.tolist()},
                               inertia.principal_axes.T @ BOX_OMEGA0,
                               quat.multiply(BOX_Q0, rotation))
    body_run, principal_run = run(box_corner_scene(), 5.0), run(principal, 5.0)
    back = quat.multiply(principal_run.state.attitude, quat.conjugate(rotation))
    assert quat.attitude_error(body_run.state.attitude, back) <= 1e-12
    np.testing.assert_allclose(body_run.state.omega_body,
                               inertia.principal_axes @ principal_run.state.omega_body,
                               atol=1e-12)


def test_box_corner_against_dop853_and_invariants():
    inertia = Inertia.box(2.0, BOX_EDGES, about='corner')

    def euler_poisson(t, y):
        omega = y[4:]
        return np.r_[0.5 * quat.multiply(y[:4], np.r_[0.0, omega]),
                     np.linalg.solve(inertia.tensor, -np.cross(omega, inertia.tensor @ omega))]

    reference = solve_ivp(euler_poisson, (0.0, 5.0), np.r_[BOX_Q0, BOX_OMEGA0],
                          method='DOP853', rtol=1e-13, atol=1e-14).y[:, -1]
    propagator = run(box_corner_scene(), 5.0)
    # RK4 at 1 ms, |ω| ≤ 4 rad/s, 5 s: measured 9e−12 against DOP853 (itself ~1e−12)
    assert quat.attitude_error(propagator.state.attitude, reference[:4]) <= 5e-11
    np.testing.assert_allclose(propagator.state.omega_body, reference[4:], atol=5e-11)
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.energy_drift) <= 1e-12
    assert diagnostics.momentum_drift <= 1e-11
