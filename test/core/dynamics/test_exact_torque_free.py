"""Tests of the closed-form torque-free motion (integrators/exact_torque_free.py).

References: the test body and its numbers of Hairer & Vilmart, "Preprocessed discrete Moser–Veselov
algorithm for the full dynamics of a rigid body", J. Phys. A 39, 2006, conservation laws, the ODEs
themselves (finite differences) and scipy's DOP853 at rtol 1e−13 on Euler + Poisson equations.
"""

import math

import mpmath
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import InertiaError, InputError
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import (
    jacobi_elliptic, principal_frame, torque_free_invariants, TorqueFreeMotion)

EPS = np.finfo(float).eps
HV_MOMENTS = np.array([0.6, 0.8, 1.0])
HV_MOMENTUM = np.array([1.8, 0.4, -0.9])
HV_MOMENTUM_10 = np.array([1.765962508518209, -0.695464197033084, 0.779554981481874])
HV_ATTITUDE_10 = np.array([-0.736061364160793, -0.570786951240351, -0.299388571830791,
                           -0.206839086104672])


def euler_poisson_rhs(t, y, inertia):
    """Euler's equations and q̇ = ½ q ⊗ (0, ω) for a full inertia tensor."""
    q, omega = y[:4], y[4:]
    omega_dot = np.linalg.solve(inertia, -np.cross(omega, inertia @ omega))
    q_dot = 0.5 * quat.multiply(q, np.concatenate([[0.0], omega]))
    return np.concatenate([q_dot, omega_dot])


def dop853_reference(inertia, attitude, omega_body, duration):
    """High-accuracy numerical reference (global error ~1e−12 over tens of seconds)."""
    tensor = np.diag(inertia) if np.ndim(inertia) == 1 else np.asarray(inertia)
    solution = solve_ivp(euler_poisson_rhs, (0.0, duration),
                         np.concatenate([attitude, omega_body]), method='DOP853',
                         rtol=1e-13, atol=1e-14, args=(tensor,))
    return solution.y[:4, -1], solution.y[4:, -1]


def test_state_hairer_vilmart_reference():
    motion = TorqueFreeMotion(HV_MOMENTS, quat.identity(), momentum_body=HV_MOMENTUM)
    attitude, omega = motion.state(10.0)
    assert motion.kind == 'minor_axis'
    # The published values have 15 digits; the closed form is exact up to a few ulps of
    # ψ(10) ≈ 20 rad, i.e. ~1e−14.
    np.testing.assert_allclose(omega * HV_MOMENTS, HV_MOMENTUM_10, rtol=0, atol=1e-12)
    np.testing.assert_allclose(attitude, HV_ATTITUDE_10, rtol=0, atol=1e-12)


def test_state_hairer_vilmart_permuted_axes():
    # The same physical body with its axes relabelled (x, y, z) -> (y, z, x): a cyclic
    # relabelling conjugates the attitude by the permutation rotation.
    order = [2, 0, 1]
    motion = TorqueFreeMotion(HV_MOMENTS[order], quat.identity(),
                              momentum_body=HV_MOMENTUM[order])
    attitude, omega = motion.state(10.0)
    np.testing.assert_allclose(omega * HV_MOMENTS[order], HV_MOMENTUM_10[order], atol=1e-12)
    np.testing.assert_allclose(attitude, HV_ATTITUDE_10[[0] + [i + 1 for i in order]],
                               atol=1e-12)


def test_world_momentum_and_energy_constant_over_1000_s():
    motion = TorqueFreeMotion(HV_MOMENTS, quat.identity(), momentum_body=HV_MOMENTUM)
    times = np.linspace(0.0, 1000.0, 5001)
    attitude, omega = motion.state(times)
    world = quat.rotate(attitude, omega * HV_MOMENTS)
    reference = motion.world_angular_momentum()
    drift = np.linalg.norm(world - reference, axis=-1) / np.linalg.norm(reference)
    energy = 0.5 * np.sum(omega * omega * HV_MOMENTS, axis=-1)
    # H does not depend on the phase ψ (the only quantity whose error grows with t), so it
    # is kept at round-off: a few ulps per product, < 1e−13 relative.
    assert np.max(drift) <= 1e-13
    assert np.max(np.abs(energy / motion.energy() - 1.0)) <= 1e-13
    assert np.max(quat.norm_error(attitude)) <= 1e-14


@pytest.mark.parametrize('inertia, omega_body, kind', [
    ([1.0, 1.0, 2.0], [0.3, 0.2, 1.0], 'axisymmetric'),          # J1 = J2, oblate
    ([1.0, 2.0, 2.0], [1.3, 0.2, -0.4], 'axisymmetric'),         # J2 = J3, prolate
    ([2.0, 1.0, 1.0], [1.3, 0.2, -0.4], 'axisymmetric'),         # unsorted moments
    ([1.0, 1.0, 1.0], [0.3, -0.2, 0.5], 'steady'),               # sphere
    ([1.0, 2.0, 3.0], [0.0, 1.0, 0.0], 'steady'),                # intermediate-axis equilibrium
    ([1.0, 2.0, 3.0], [1e-4, 1.0, 0.0], 'minor_axis'),           # near the separatrix
    ([1.0, 2.0, 3.0], [0.0, 1.0, 1e-4], 'major_axis'),
    ([1.0, 2.0, 3.0], [1e-4, 1.0, 2e-4 / 3.0], 'major_axis'),        # Δ2 = 1/3e−8
    ([3.0, 3.75, 5.0], [0.5 / 3.0, 1.0 / 3.75, 0.1], 'separatrix'),  # Δ2 = 0 exactly
    ([3.0, 3.75, 5.0], [-0.5 / 3.0, 1.0 / 3.75, 0.1], 'separatrix'),
    ([1.0, 1.0 + 1e-9, 2.0], [0.3, 0.2, 1.0], 'major_axis'),     # nearly axisymmetric
    ([1.0, 1.0 + 1e-9, 2.0], [1.0, 0.2, 1e-5], 'minor_axis'),
])
def test_state_matches_dop853(inertia, omega_body, kind):
    attitude = quat.normalize([0.9, 0.1, -0.3, 0.2])
    motion = TorqueFreeMotion(inertia, attitude, omega_body=omega_body)
    expected_attitude, expected_omega = dop853_reference(
        np.asarray(inertia), attitude, np.asarray(omega_body, dtype=float), 20.0)
    actual_attitude, actual_omega = motion.state(20.0)
    assert motion.kind == kind
    assert np.all(np.isfinite(actual_attitude)) and np.all(np.isfinite(actual_omega))
    # DOP853 at rtol 1e−13 accumulates ~1e−12 over 20 s here; near the separatrix the saddle
    # amplifies it (e^{σt} during each pass), so 1e−9 bounds the reference, not the solution.
    assert quat.attitude_error(actual_attitude, expected_attitude) <= 1e-9
    np.testing.assert_allclose(actual_omega, expected_omega, rtol=0, atol=1e-9)


def test_separatrix_exact_tends_to_intermediate_axis():
    momentum = np.array([0.5, 1.0, 0.5])  # J = (3, 3.75, 5): Δ2 = −0.25 m1² + 0.25 m3² = 0
    motion = TorqueFreeMotion([3.0, 3.75, 5.0], quat.identity(), momentum_body=momentum)
    assert torque_free_invariants([3.0, 3.75, 5.0], momentum)[1] == 0.0
    late = motion.momentum_body(1000.0)
    # On the homoclinic orbit m → ±G e2 like sech(λt), λ = 0.0816/s here: after 1000 s m1 and
    # m3 are ~1e−35.
    assert abs(abs(late[1]) - np.linalg.norm(momentum)) <= 1e-14
    assert abs(late[0]) <= 1e-20 and abs(late[2]) <= 1e-20


def test_near_separatrix_both_sides_match_dop853():
    for offset in (1e-4, -1e-4):
        omega_body = np.array([0.5 / 3.0 * (1.0 + offset), 1.0 / 3.75, 0.1])
        motion = TorqueFreeMotion([3.0, 3.75, 5.0], quat.identity(), omega_body=omega_body)
        expected_attitude, expected_omega = dop853_reference(
            np.array([3.0, 3.75, 5.0]), quat.identity(), omega_body, 40.0)
        attitude, omega = motion.state(40.0)
        assert motion.kind == ('minor_axis' if offset > 0 else 'major_axis')
        # Same justification as test_state_matches_dop853: the reference limits this.
        assert quat.attitude_error(attitude, expected_attitude) <= 1e-9
        np.testing.assert_allclose(omega, expected_omega, rtol=0, atol=1e-9)


@pytest.mark.parametrize('difference', [1e-13, 1e-11, 1e-9, 1e-7])
def test_state_nearly_axisymmetric_minor_side(difference):
    # J1 ≈ J2 with m3 tiny: Δ2 < 0, the thin minor-axis band where the Carlson closed form
    # of ψ loses digits like eps·√|n| (n ≈ −1/difference); the quadrature must not.
    attitude = quat.normalize([0.9, 0.1, -0.3, 0.2])
    omega_body = [1.0, 0.2, 1e-9]
    nearly = TorqueFreeMotion([1.0, 1.0 + difference, 2.0], attitude, omega_body=omega_body)
    exactly = TorqueFreeMotion([1.0, 1.0, 2.0], attitude, omega_body=omega_body)
    assert nearly.kind == 'minor_axis' and exactly.kind == 'axisymmetric'
    q_nearly, omega_nearly = nearly.state(20.0)
    q_exactly, omega_exactly = exactly.state(20.0)
    # The two bodies' motions differ by ~difference·|ω|·t = 20·difference; 1e−12 on top
    # bounds the round-off of both closed forms.
    bound = 40.0 * difference + 1e-12
    assert quat.attitude_error(q_nearly, q_exactly) <= bound
    np.testing.assert_allclose(omega_nearly, omega_exactly, rtol=0, atol=bound)


def random_bodies(count):
    """Seeded random triaxial bodies with states on both sides of the separatrix."""
    rng = np.random.default_rng(20240611)
    cases = []
    for _ in range(count):
        moments = np.sort(rng.uniform(0.5, 2.0, size=3))
        momentum = rng.normal(size=3)
        cases.append((moments, quat.normalize(rng.normal(size=4)), momentum))
    return cases


def finite_difference(function, t, step):
    """Fourth-order central difference (truncation ~step⁴/30 |f⁽⁵⁾|, round-off ~eps/step)."""
    return (function(t - 2 * step) - 8 * function(t - step) + 8 * function(t + step)
            - function(t + 2 * step)) / (12 * step)


def test_state_satisfies_euler_and_poisson_equations():
    kinds = set()
    times = np.array([0.3, 2.7, 11.0, 57.5])
    for moments, attitude, momentum in random_bodies(10):
        motion = TorqueFreeMotion(moments, attitude, momentum_body=momentum)
        kinds.add(motion.kind)
        q, omega = motion.state(times)
        m = omega * moments
        q_dot = finite_difference(motion.attitude, times, 1e-3)
        m_dot = finite_difference(motion.momentum_body, times, 1e-3)
        # With step 1e−3 the difference quotient is good to ~1e−11 for these O(1) rates.
        np.testing.assert_allclose(m_dot, np.cross(m, omega), rtol=0, atol=1e-9)
        np.testing.assert_allclose(
            q_dot, 0.5 * quat.multiply(q, np.concatenate([np.zeros((4, 1)), omega], -1)),
            rtol=0, atol=1e-9)
    assert {'minor_axis', 'major_axis'} <= kinds


def test_state_general_tensor_matches_rotated_principal_problem():
    rotation_quaternion = quat.normalize([0.3, -0.5, 0.7, 0.2])
    rotation = quat.to_matrix(rotation_quaternion)
    moments = np.array([0.6, 0.8, 1.0])
    tensor = rotation @ np.diag(moments) @ rotation.T
    # Body vectors of the tensor frame are rotation @ principal vectors, so the attitude of
    # the principal frame is q ⊗ rotation_quaternion.
    attitude = quat.normalize([0.1, 0.2, 0.3, 0.9])
    general = TorqueFreeMotion(tensor, attitude, momentum_body=rotation @ HV_MOMENTUM)
    principal = TorqueFreeMotion(moments, quat.multiply(attitude, rotation_quaternion),
                                 momentum_body=HV_MOMENTUM)
    q_general, omega_general = general.state(7.0)
    q_principal, omega_principal = principal.state(7.0)
    # eigh recovers the axes to ~1e−15; the solutions are exact, so 1e−12 is generous.
    np.testing.assert_allclose(omega_general, rotation @ omega_principal, atol=1e-12)
    assert quat.attitude_error(quat.multiply(q_general, rotation_quaternion),
                               q_principal) <= 1e-12


def test_state_vectorised_equals_scalar():
    motion = TorqueFreeMotion(HV_MOMENTS, quat.identity(), momentum_body=HV_MOMENTUM)
    times = np.array([[0.0, 1.5], [3.25, 100.0]])
    attitudes, omegas = motion.state(times)
    assert attitudes.shape == (2, 2, 4) and omegas.shape == (2, 2, 3)
    for index in np.ndindex(times.shape):
        attitude, omega = motion.state(times[index])
        np.testing.assert_allclose(attitudes[index], attitude, atol=1e-15)
        np.testing.assert_allclose(omegas[index], omega, atol=1e-15)
    np.testing.assert_allclose(attitudes[0, 0], quat.identity(), atol=1e-15)


def test_momentum_period_returns_momentum():
    motion = TorqueFreeMotion(HV_MOMENTS, quat.identity(), momentum_body=HV_MOMENTUM)
    period = motion.momentum_period
    # m(t) is periodic; only the attitude carries the secular phase ψ.
    np.testing.assert_allclose(motion.momentum_body(period), HV_MOMENTUM, atol=1e-13)
    assert np.linalg.norm(motion.momentum_body(0.5 * period) - HV_MOMENTUM) > 0.1


@pytest.mark.parametrize('complementary', [1e-14, 1e-8, 0.3, 0.999999])
def test_jacobi_elliptic_matches_mpmath(complementary):
    mpmath.mp.dps = 40
    parameter = mpmath.mpf(1) - mpmath.mpf(complementary)
    u = np.linspace(-40.0, 40.0, 17)
    sn, cn, dn = jacobi_elliptic(u, complementary)
    expected = np.array([[float(mpmath.ellipfun(name, x, m=parameter)) for x in u]
                         for name in ('sn', 'cn', 'dn')])
    # Bulirsch's algorithm with the complement passed directly: a few ulps (scipy's ellipj
    # at 1 − m = 1e−14 is off by ~1e−3 in cn near K).
    np.testing.assert_allclose(np.array([sn, cn, dn]), expected, rtol=0, atol=1e-14)


def test_principal_frame_right_handed_and_sorted():
    moments, axes = principal_frame([3.0, 1.0, 2.0])
    np.testing.assert_array_equal(moments, [1.0, 2.0, 3.0])
    assert np.linalg.det(axes) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, np.diag([3.0, 1.0, 2.0]),
                               atol=1e-15)


#: Powers of two: ω·2^k at time t/2^k is the same motion as ω at t, bit for bit once the
#: closed form scales the momentum back to O(1) (module docstring); 2^−1074 puts the smallest
#: component of HV_OMEGA_TINY below the subnormal threshold's precision, so it is checked
#: separately. Before the scaling, 2^−530 (ω ≈ 3e−160) gave |q| − 1 = 1.5e−6 and 2^−1000
#: raised ZeroDivisionError.
SCALES = [-530, -1000]


@pytest.mark.parametrize('exponent', SCALES)
@pytest.mark.parametrize('kind_of_orbit, moments, omega_body', [
    ('minor_axis', [0.6, 0.8, 1.0], HV_MOMENTUM / HV_MOMENTS),
    ('major_axis', [1.0, 2.0, 3.0], [0.1, 0.3, 1.0]),
    ('axisymmetric', [1.0, 1.0, 2.0], [0.3, -0.4, 1.1]),
    ('steady', [1.0, 2.0, 3.0], [0.0, 0.0, 1.5]),
])
def test_state_tiny_rates_are_the_scaled_motion(exponent, kind_of_orbit, moments, omega_body):
    scale = 2.0 ** exponent
    omega_body = np.array(omega_body, dtype=float)
    times = np.array([0.0, 0.7, 13.0])
    attitude = quat.normalize([0.9, 0.1, -0.3, 0.2])
    unit = TorqueFreeMotion(moments, attitude, omega_body=omega_body)
    tiny = TorqueFreeMotion(moments, attitude, omega_body=omega_body * scale)
    assert tiny.kind == unit.kind == kind_of_orbit
    q_unit, omega_unit = unit.state(times)
    q_tiny, omega_tiny = tiny.state(times / scale)
    np.testing.assert_array_equal(q_tiny, q_unit)
    np.testing.assert_array_equal(omega_tiny, omega_unit * scale)
    # At ordinary times a rate of 1e−160 rad/s does not move the body (beyond round-off).
    q_now, _ = tiny.state(times)
    assert np.max(np.abs(np.linalg.norm(q_now, axis=-1) - 1.0)) <= 2.0 * EPS
    assert np.max([quat.attitude_error(q, attitude) for q in q_now]) <= 4.0 * EPS


@pytest.mark.parametrize('omega_body', [[0.0, 0.0, 0.0], [5e-324, 0.0, 0.0],
                                        [5e-324, -1e-320, 3e-310], [1e-300, 2e-300, -3e-300]])
def test_state_zero_and_subnormal_rates(omega_body):
    # Squares of these components underflow (before: 0/0 → ZeroDivisionError, or NaN).
    attitude = quat.normalize([0.9, 0.1, -0.3, 0.2])
    motion = TorqueFreeMotion([1.0, 2.0, 3.0], attitude, omega_body=omega_body)
    times = np.array([0.0, 1.0, 1e6])
    q, omega = motion.state(times)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(omega))
    # The rotation |ω| t ≤ 4e−294 rad is below round-off: q stays q₀ to a few ulps; the
    # rate keeps its magnitude (|m| is an invariant; math.hypot does not underflow) to
    # round-off and to the subnormal spacing 5e−324 of the output.
    assert max(quat.attitude_error(x, attitude) for x in q) <= 4.0 * EPS
    moments = np.array([1.0, 2.0, 3.0])
    momentum_norm = math.hypot(*(moments * omega_body))
    for rate in omega:
        assert abs(math.hypot(*(moments * rate)) - momentum_norm) <= (
            1e-15 * momentum_norm + 1e-322)
    # ω(0) is recomputed from sn, cn, dn at u₀: a few ulps of |ω| (or the subnormal spacing).
    np.testing.assert_allclose(motion.omega_body(0.0), omega_body, rtol=0.0,
                               atol=4.0 * EPS * np.max(np.abs(omega_body)) + 1e-322)


def test_state_intermediate_axis_with_a_1e_300_perturbation():
    # Spin about the middle axis with components 1e−300 off it: their squares underflow, so
    # Δ₂ would be 0 (the separatrix) and the body would never leave the axis. Until they
    # reach ~1e−8 (t ≲ 1100 s here) the off-axis rates follow the linearised equations,
    # ω̇₁ = −ω₃, ω̇₃ = −ω₁/3 (J = 1, 2, 3, ω₂ = 1), to double precision:
    # ω₁ = ω₁₀ cosh σt − (ω₃₀/σ) sinh σt, ω₃ = ω₃₀ cosh σt − σ ω₁₀ sinh σt, σ = 1/√3.
    attitude = quat.normalize([0.9, 0.1, -0.3, 0.2])
    start = np.array([1e-300, 1.0, 3e-301])
    motion = TorqueFreeMotion([1.0, 2.0, 3.0], attitude, omega_body=start)
    assert motion.kind == 'minor_axis'
    sigma = 1.0 / np.sqrt(3.0)
    times = np.array([10.0, 300.0, 900.0])
    q, omega = motion.state(times)
    cosh, sinh = np.cosh(sigma * times), np.sinh(sigma * times)
    expected_1 = start[0] * cosh - start[2] / sigma * sinh
    expected_3 = start[2] * cosh - sigma * start[0] * sinh
    # Relative error of the tiny components: u = u₀ + λt is known to ε(|u₀| + λt) ≈ 1e−13
    # and they go like e^{±u}; measured ≤ 2.6e−14. Bound 1e−12.
    np.testing.assert_allclose(omega[:, 0], expected_1, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(omega[:, 2], expected_3, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(omega[:, 1], 1.0, rtol=2.0 * EPS, atol=0.0)
    # The attitude is the spin about e₂ up to the off-axis wobble (≤ 1e−150 rad). The phase
    # is [F(u) − F(u₀)]/λ with |u₀| ≈ K = ln(4/k') ≈ 690 here, so its round-off is a few ulps
    # of (2K + |λ| t)/|λ| = period/2 + t rad: bound 8ε(period/2 + t) (measured ≤ 3.4e−13).
    half_period = 0.5 * motion.momentum_period
    for time, attitude_t in zip(times, q):
        spin = quat.multiply(attitude, quat.exp([0.0, time, 0.0]))
        assert quat.attitude_error(attitude_t, spin) <= 8.0 * EPS * (half_period + time)
    # The motion then leaves the axis: after the first flip m₂ has changed sign.
    assert motion.momentum_body(2000.0)[1] < 0.0


def test_state_tensor_with_tiny_products_of_inertia():
    # Off-diagonal terms of 1e−239 (their squares underflow): the motion is that of the
    # diagonal body to round-off, whichever way eigh resolves the axes.
    tensor = np.array([[1.0, 1e-239, 0.0], [1e-239, 2.0, 1e-239], [0.0, 1e-239, 3.0]])
    attitude = quat.normalize([0.9, 0.1, -0.3, 0.2])
    for omega_body in ([0.0, 0.0, 1.0], [0.1, 0.3, 1.0], [1e-200, 1.0, 0.0]):
        general = TorqueFreeMotion(tensor, attitude, omega_body=omega_body)
        diagonal = TorqueFreeMotion([1.0, 2.0, 3.0], attitude, omega_body=omega_body)
        q, omega = general.state(np.array([1.0, 50.0]))
        q_diagonal, omega_diagonal = diagonal.state(np.array([1.0, 50.0]))
        assert np.all(np.isfinite(q)) and np.all(np.isfinite(omega))
        np.testing.assert_allclose(omega, omega_diagonal, rtol=0.0, atol=1e-14)
        for a, b in zip(q, q_diagonal):
            assert quat.attitude_error(a, b) <= 1e-13


def test_state_refuses_an_overflowing_rotation_angle():
    motion = TorqueFreeMotion([1.0, 2.0, 3.0], quat.identity(), omega_body=[1e300, 0.0, 2e300])
    q, omega = motion.state(1e-300)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(omega))
    with pytest.raises(InputError, match='rotation angle'):
        motion.state(1e300)


def test_bad_inertia_raises():
    with pytest.raises(InertiaError, match='symmetric'):
        TorqueFreeMotion([[1, 0.1, 0], [0, 1, 0], [0, 0, 1]], quat.identity(),
                         omega_body=[1, 0, 0])
    with pytest.raises(InertiaError, match='positive definite'):
        TorqueFreeMotion([1.0, -2.0, 3.0], quat.identity(), omega_body=[1, 0, 0])
    with pytest.raises(InertiaError, match='shape'):
        TorqueFreeMotion([1.0, 2.0], quat.identity(), omega_body=[1, 0, 0])


def test_bad_state_raises():
    with pytest.raises(InputError, match='exactly one'):
        TorqueFreeMotion([1, 2, 3], quat.identity(), omega_body=[1, 0, 0],
                         momentum_body=[1, 0, 0])
    with pytest.raises(InputError, match='omega_body'):
        TorqueFreeMotion([1, 2, 3], quat.identity(), omega_body=[1, np.nan, 0])
    with pytest.raises(InputError, match='attitude'):
        TorqueFreeMotion([1, 2, 3], [1, 0, 0], omega_body=[1, 0, 0])
    motion = TorqueFreeMotion([1, 2, 3], quat.identity(), omega_body=[1, 0.1, 0])
    with pytest.raises(InputError, match='finite'):
        motion.state(np.inf)
