"""Hard case 6: Euler (ZXZ) and Bryant (XYZ) angle kinematics at their singularities.

The angle rates (Wittenburg, *Dynamics of Multibody Systems*, 2nd ed., 2008, §2.2; Euler, ψ̇ = (ω_x
sin φ + ω_y cos φ)/sin θ; Bryant,
α̇₁ = (ω_x cos α₃ − ω_y sin α₃)/cos α₂) divide by sin θ and cos α₂. A naive integrator of
these forms returns inf/NaN on the singularity and garbage near it (rates of order
|ω|/δ for a closest approach δ). The package's angle forms
(:mod:`rigid_body_attitude.core.attitude.integrators.angles`) refuse a step that reaches the
singularity
with an :class:`IntegratorError` telling the user to use quaternions; near it their error grows
like 1/δ. The quaternion and direction-cosine paths integrate the same motion with an error
that does not depend on δ. (docs/hard-cases.md §6.)
"""

import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.attitude.integrators import angles
from rigid_body_attitude.core.attitude.integrators.kinematic import rk4_quaternion_step

OMEGA = np.array([1.0, 0.0, 0.0])  # constant body rate about body x [rad/s]
STEP = 0.01
STEPS = 60
CLOSEST_APPROACH_TIME = 0.3  # [s]; the path is built so the lock is nearest at STEPS/2


def rate(t):
    """The constant body rate (angle and quaternion integrators take ω(t))."""
    return OMEGA


def path_start(form, delta):
    """Initial attitude whose path under OMEGA passes ``delta`` rad from the singularity.

    ZXZ is singular when body z is along world ±z (θ = 0, π); XYZ when body z is along world
    ±x (α₂ = ±π/2). Rotating about body x for 0.3 s carries exp(−0.3 e_x)'s body z back to
    its own z; the left factor then places that point ``delta`` from the singular direction,
    across the path (body z moves along ∓world y there), so the path misses it by ``delta``.
    """
    back = quat.exp(-CLOSEST_APPROACH_TIME * OMEGA)
    if form == 'euler_zxz':
        tilt = quat.multiply(quat.exp([0.0, 0.0, 0.7]), quat.exp([0.0, delta, 0.0]))
    else:
        tilt = quat.exp([0.0, 0.5 * math.pi - delta, 0.0])
    return quat.multiply(tilt, back)


FORMS = {
    'euler_zxz': (quat.as_euler_zxz, quat.from_euler_zxz, angles.euler_zxz_rates,
                  angles.euler_zxz_rk4_step),
    'bryant_xyz': (quat.as_bryant_xyz, quat.from_bryant_xyz, angles.bryant_xyz_rates,
                   angles.bryant_xyz_rk4_step),
}


def integrate_three_ways(form, q0):
    """Angles (RK4 on the Euler and Bryant rate forms), quaternion (RK4 on q̇) and DCM (RK4 on Ȧ =
    A ω̃), STEPS steps.

    Returns the three attitude errors against the closed form q₀ ⊗ exp(ω t) (Shuster, "A survey of
    attitude representations", J. Astronaut. Sci. 41(4), 1993)
    and the largest angle rate met; the angle error is None if the step was refused.
    """
    to_angles, from_angles, rates, angle_step = FORMS[form]
    exact = quat.multiply(q0, quat.exp(STEPS * STEP * OMEGA))
    angle_values = tuple(to_angles(q0))
    q, matrix = tuple(q0), quat.to_matrix(q0)
    largest_rate = 0.0
    angle_error = None
    try:
        for k in range(STEPS):
            largest_rate = max(largest_rate, max(abs(r) for r in rates(angle_values, OMEGA)))
            angle_values = angle_step(angle_values, rate, k * STEP, STEP)
        angle_error = quat.attitude_error(from_angles(angle_values), exact)
    finally:
        for k in range(STEPS):
            q = rk4_quaternion_step(q, rate, k * STEP, STEP)
            matrix = angles.dcm_poisson_rk4_step(matrix, rate, k * STEP, STEP)
    quaternion_error = quat.attitude_error(np.array(q), exact)
    dcm_error = quat.attitude_error(quat.from_matrix(matrix), exact)
    return angle_error, quaternion_error, dcm_error, largest_rate


@pytest.mark.parametrize('form', sorted(FORMS))
def test_angle_error_grows_like_one_over_the_closest_approach(form):
    far_error, far_q, far_dcm, far_rate = integrate_three_ways(form, path_start(form, 0.5))
    near_error, near_q, near_dcm, near_rate = integrate_three_ways(form, path_start(form, 1e-3))
    # Far from the lock the angle form is as good as RK4 gets (measured 3.6e−10 rad); 1e−3 rad
    # from it the rates reach |ω|/δ ≈ 380 rad/s, h·rate ≈ 4 per step, and RK4 on the angles
    # misses by 1.4e−2 rad (measured, both forms): a 4e7-fold loss for the same motion.
    assert far_error <= 1e-8
    assert near_rate >= 100.0 * far_rate
    assert near_error >= 1e-3
    assert near_error >= 1e4 * far_error
    # The quaternion and DCM paths do not see the lock: RK4's global error C h⁴ t with
    # derivatives |ω|ⁿ = 1 is ~1e−11 (measured 3.1e−12 and 5.0e−11 rad) at both distances.
    for error in (far_q, near_q, far_dcm, near_dcm):
        assert error <= 1e-10
    assert near_q == pytest.approx(far_q, rel=1e-2)
    assert near_dcm == pytest.approx(far_dcm, rel=1e-2)


@pytest.mark.parametrize('form', sorted(FORMS))
def test_a_path_through_the_singularity_is_refused_with_a_clear_error(form):
    # δ = 0: a stage lands on the singularity (sin θ or cos α₂ ≈ 1e−17); the step is refused
    # instead of returning inf or NaN angles, and the message says what to do.
    with pytest.raises(IntegratorError, match=r'singular at (sin θ|cos α₂) = 0.*use quaternions'):
        integrate_three_ways(form, path_start(form, 0.0))


@pytest.mark.parametrize('form', sorted(FORMS))
def test_quaternion_and_dcm_paths_through_the_singularity(form):
    # The same δ = 0 motion without the angle form: exactly through the lock.
    q0 = path_start(form, 0.0)
    exact = quat.multiply(q0, quat.exp(STEPS * STEP * OMEGA))
    q, matrix = tuple(q0), quat.to_matrix(q0)
    for k in range(STEPS):
        q = rk4_quaternion_step(q, rate, k * STEP, STEP)
        matrix = angles.dcm_poisson_rk4_step(matrix, rate, k * STEP, STEP, orthonormalize=True)
    assert quat.attitude_error(np.array(q), exact) <= 1e-10
    assert quat.attitude_error(quat.from_matrix(matrix), exact) <= 1e-10
    np.testing.assert_allclose(matrix.T @ matrix, np.eye(3), rtol=0.0, atol=1e-15)


@pytest.mark.parametrize('form, singular_attitude', [
    ('euler_zxz', quat.identity()),                          # θ = 0: the identity itself
    ('euler_zxz', quat.from_euler_zxz([0.4, math.pi, -1.0])),  # θ = π
    ('bryant_xyz', quat.from_bryant_xyz([0.0, 0.5 * math.pi, 0.0])),   # α₂ = π/2
    ('bryant_xyz', quat.from_bryant_xyz([0.3, -0.5 * math.pi, 1.2])),  # α₂ = −π/2
])
def test_angle_rates_at_the_singularity_raise(form, singular_attitude):
    to_angles, _, rates, _ = FORMS[form]
    with pytest.raises(IntegratorError, match='use quaternions'):
        rates(tuple(to_angles(singular_attitude)), (0.3, -0.2, 0.1))


@pytest.mark.parametrize('form', sorted(FORMS))
@pytest.mark.parametrize('offset, bound', [
    (0.0, 4e-15), (1e-15, 4e-15), (1e-9, 4e-15), (1e-6, 4e-15), (1e-3, 4e-15),
    # Inside the lock band (sin of the middle angle < 1e−12) the convention sets the last
    # angle to 0 and keeps the middle one, dropping a rotation of at most ~2 sin θ ≤ 2e−12 rad
    # (measured 1.9e−12 at θ = 1e−12): a bounded step, not a blow-up.
    (1e-12, 2.5e-12),
])
def test_conversions_stay_continuous_at_the_lock(form, offset, bound):
    # Quaternion → angles → quaternion at and next to gimbal lock: only ψ ± φ (α₁ ± α₃) is
    # defined there, but the attitude comes back to round-off (a few ulps of 1 rad).
    to_angles, from_angles, _, _ = FORMS[form]
    rng = np.random.default_rng(6)
    for lock in (0.0, math.pi) if form == 'euler_zxz' else (0.5 * math.pi, -0.5 * math.pi):
        for _ in range(20):
            first, last = rng.uniform(-math.pi, math.pi, size=2)
            middle = lock - math.copysign(offset, lock) if lock else offset
            q = from_angles([first, middle, last])
            back = from_angles(to_angles(q))
            assert quat.attitude_error(q, back) <= bound
