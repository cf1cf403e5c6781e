"""Hard case 4: zero, tiny and subnormal rates (docs/hard-cases.md §4).

A naive ``sin(|v|/2)/|v|`` divides 0 by 0 at ``v = 0``; a naive ``atan2(s, w)/s`` in log does
too; dexpinv's ``(1 − (a/2) cot(a/2))/a²`` cancels catastrophically below ``a ≈ 1e−4``. The
package switches to series below ``quaternion.SERIES_THRESHOLD`` (1e−4 rad). Here the series
branches are compared with 50-digit mpmath values of the same double inputs, and every path a
tiny rate can take (exp, log, the strapdown step, the propagators, the exact solution) runs
with NumPy's divide/invalid/overflow errors and Python warnings turned into exceptions.
"""

import math
import warnings

import mpmath
import numpy as np
import pytest

from rigid_body_attitude.core.attitude import kinematics
from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.batch import TorqueFreeBatch
from rigid_body_attitude.core.dynamics.euler import RigidBodyModel, rk4_step
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.attitude.integrators.kinematic import _dexpinv_exact as dexpinv
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene

mpmath.mp.dps = 50

#: One unit in the last place of numbers in [1/2, 1): the absolute rounding of a quaternion
#: component. Components are at most 1 in magnitude, so an absolute error of 1e−16 is below
#: one rounding of the largest component.
ABSOLUTE_BOUND = 1e-16
EPS = np.finfo(float).eps
SUBNORMAL = 5e-324
TINY_RATES = [
    (0.0, 0.0, 0.0),
    (1e-12, 0.0, 0.0),
    (1e-12, -1e-12, 1e-12),
    (SUBNORMAL, 0.0, 0.0),
    (SUBNORMAL, -SUBNORMAL, SUBNORMAL),
    (1e-310, 2e-310, -3e-310),
    (1e-300, 2e-300, 3e-300),
]


@pytest.fixture(autouse=True)
def strict_floating_point():
    """Division by zero, invalid operations and overflow raise; so does any warning.

    Underflow stays quiet: a subnormal result is the correct answer for subnormal input.
    """
    with np.errstate(divide='raise', invalid='raise', over='raise'), warnings.catch_warnings():
        warnings.simplefilter('error')
        yield


def mp_exp(rotation_vector):
    """``exp(v) = (cos(a/2), v sin(a/2)/a)`` of the double input, in 50-digit arithmetic."""
    v = [mpmath.mpf(float(x)) for x in rotation_vector]
    angle = mpmath.sqrt(sum(x * x for x in v))
    scale = mpmath.mpf(0.5) if angle == 0 else mpmath.sin(angle / 2) / angle
    return [mpmath.cos(angle / 2)] + [x * scale for x in v]


def mp_log(q):
    """``log(q) = 2 atan2(|vec|, w) vec/|vec|`` (sign chosen with w ≥ 0), 50 digits."""
    qm = [mpmath.mpf(float(x)) for x in q]
    if qm[0] < 0:
        qm = [-x for x in qm]
    s = mpmath.sqrt(sum(x * x for x in qm[1:]))
    scale = 2 / qm[0] if s == 0 else 2 * mpmath.atan2(s, qm[0]) / s
    return [x * scale for x in qm[1:]]


def mp_dexpinv(theta, omega):
    """``ω + ½ θ × ω + (1 − (a/2) cot(a/2))/a² θ × (θ × ω)`` (a = |θ|, 1/12 at 0), 50 digits."""
    t = [mpmath.mpf(float(x)) for x in theta]
    w = [mpmath.mpf(float(x)) for x in omega]
    angle = mpmath.sqrt(sum(x * x for x in t))
    factor = (mpmath.mpf(1) / 12 if angle == 0
              else (1 - (angle / 2) * mpmath.cot(angle / 2)) / angle ** 2)

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    first = cross(t, w)
    second = cross(t, first)
    return [a + b / 2 + factor * c for a, b, c in zip(w, first, second)]


def errors_against(values, reference):
    """Largest absolute error and largest relative error over the non-zero references."""
    absolute = max(abs(float(mpmath.mpf(float(v)) - r)) for v, r in zip(values, reference))
    relative = max((abs(float((mpmath.mpf(float(v)) - r) / r))
                    for v, r in zip(values, reference) if r != 0), default=0.0)
    return absolute, relative


def small_rotation_vectors(count, seed):
    """Random directions with angles log-uniform in [1e−17, SERIES_THRESHOLD)."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    angles = 10.0 ** rng.uniform(-17.0, math.log10(quat.SERIES_THRESHOLD), size=count)
    return directions * angles[:, None]


def test_exp_series_branch_matches_50_digit_values():
    vectors = small_rotation_vectors(400, seed=40)
    worst_absolute = worst_relative = 0.0
    for v in vectors:
        absolute, relative = errors_against(quat.exp(v), mp_exp(v))
        worst_absolute = max(worst_absolute, absolute)
        worst_relative = max(worst_relative, relative)
    # The series ½ − a²/48 + a⁴/3840 truncates at a⁶/645120 < 2e−30 below a = 1e−4; what is
    # left is the rounding of cos(a/2) and of one product: ≤ 1 ulp per component.
    assert worst_absolute <= ABSOLUTE_BOUND
    assert worst_relative <= EPS


def test_log_series_branch_matches_50_digit_values():
    vectors = small_rotation_vectors(400, seed=41)
    worst_absolute = worst_relative = 0.0
    for index, v in enumerate(vectors):
        q = quat.exp(v) * (-1.0 if index % 2 else 1.0)  # both signs of the double cover
        absolute, relative = errors_against(quat.log(q), mp_log(q))
        worst_absolute = max(worst_absolute, absolute)
        worst_relative = max(worst_relative, relative)
    # Series 1 − r²/3 + r⁴/5 of atan(r)/r truncates at r⁶/7 < 2e−25 for r < 1e−4; the result
    # carries the rounding of a division and two products: ≤ 2 ulps relative.
    assert worst_absolute <= ABSOLUTE_BOUND
    assert worst_relative <= 2.0 * EPS


def test_exp_and_log_agree_across_the_series_threshold():
    # Just below and just above the switch the two branches give the same numbers to a few
    # ulps: no step in the function at the threshold.
    direction = np.array([0.48, -0.6, 0.64])
    for factor in (1.0 - 1e-12, 1.0, 1.0 + 1e-12):
        v = direction * quat.SERIES_THRESHOLD * factor
        absolute, relative = errors_against(quat.exp(v), mp_exp(v))
        assert absolute <= ABSOLUTE_BOUND and relative <= 2.0 * EPS
        absolute, relative = errors_against(quat.log(quat.exp(v)), mp_log(quat.exp(v)))
        assert absolute <= ABSOLUTE_BOUND and relative <= 2.0 * EPS


def test_dexpinv_series_branch_matches_50_digit_values():
    # The inverse differential of exp used by the Bortz/RKMK methods. Its factor
    # (1 − (a/2) cot(a/2))/a² cancels catastrophically for small a, so below the threshold it
    # is the series 1/12 + a²/720 (truncation a⁴/30240 < 4e−21). Rates with components in
    # [−½, ½] keep the result below 1, where 1e−16 is one rounding of the final sum.
    rng = np.random.default_rng(43)
    worst = 0.0
    for theta in list(small_rotation_vectors(400, seed=44)) + [np.zeros(3), [SUBNORMAL] * 3]:
        omega = rng.uniform(-0.5, 0.5, size=3)
        absolute, _ = errors_against(dexpinv(tuple(theta), tuple(omega)),
                                     mp_dexpinv(theta, omega))
        worst = max(worst, absolute)
    assert worst <= ABSOLUTE_BOUND


def test_scalar_exp_step_series_branch_matches_50_digit_values():
    vectors = small_rotation_vectors(400, seed=42)
    worst = 0.0
    for v in vectors:
        absolute, _ = errors_against(quat.scalar_exp_step((1.0, 0.0, 0.0, 0.0), v, 1.0),
                                     mp_exp(v))
        worst = max(worst, absolute)
    # The hot path renormalises after the product: one more rounding of 1/√(Σq²), so the
    # bound is 2 ulps of 1 (4.4e−16) instead of the bare exponential's 1e−16.
    assert worst <= 2.0 * EPS


@pytest.mark.parametrize('rate', TINY_RATES)
def test_exp_log_of_tiny_and_subnormal_vectors(rate):
    q = quat.exp(rate)
    reference = mp_exp(rate)
    absolute, _ = errors_against(q, reference)
    assert absolute <= ABSOLUTE_BOUND
    assert quat.norm_error(q) == 0.0
    # log(exp(v)) returns v exactly for these (w = 1 exactly, scale 2/w · ½ = 1).
    np.testing.assert_array_equal(quat.log(q), np.asarray(rate) * 0.5 * 2.0)
    assert quat.attitude_error(quat.identity(), q) <= 2.0 * np.linalg.norm(rate) + 1e-300


@pytest.mark.parametrize('rate', TINY_RATES)
def test_strapdown_steps_with_tiny_rates(rate):
    # 10⁴ steps of 1 ms with a constant tiny rate: the attitude equals exp(ω t) to 1e−16
    # (with ω t ≤ 2e−11 rad every component is exact up to one rounding of 1).
    h, steps = 1e-3, 10_000
    expected = mp_exp([x * h * steps for x in rate])
    q_scalar = (1.0, 0.0, 0.0, 0.0)
    q_array = quat.identity()
    for _ in range(steps):
        q_scalar = quat.scalar_exp_step(q_scalar, rate, h)
    for _ in range(100):
        q_array = kinematics.exp_map_step(q_array, np.asarray(rate) * 100.0, h)
    assert errors_against(q_scalar, expected)[0] <= ABSOLUTE_BOUND
    assert errors_against(q_array, expected)[0] <= ABSOLUTE_BOUND
    q_rk4 = kinematics.rk4_quaternion_step(quat.identity(), lambda t: np.asarray(rate), 0.0,
                                           h * steps)
    assert errors_against(q_rk4, expected)[0] <= ABSOLUTE_BOUND


@pytest.mark.parametrize('rate', TINY_RATES)
def test_gyro_propagator_with_tiny_rates(rate):
    propagator = GyroPropagator(load_scene('strapdown'))
    propagator.start(0.0, rate)
    for k in range(1, 1001):
        propagator.update(k * 1e-3, rate)
    expected = mp_exp(list(rate))  # t = 1 s
    assert errors_against(propagator.state.attitude, expected)[0] <= ABSOLUTE_BOUND
    diagnostics = propagator.diagnostics()
    assert diagnostics.quaternion_norm_error <= EPS
    assert math.isfinite(diagnostics.energy_drift) and math.isfinite(diagnostics.momentum_drift)


@pytest.mark.parametrize('rate', TINY_RATES)
def test_dynamics_with_tiny_rates(rate):
    # Euler's equations: |ω̇| = |J⁻¹(ω × Jω)| ≤ (J_max/J_min)|ω|² ≤ 3 · 3e−24 rad/s², so over
    # 1 s the rate changes by less than 1e−23 and the attitude is exp(ω t) up to rounding.
    scene = load_scene('torque_free_box')
    tensor = scene.inertia.tensor
    rate_change = 1e-23
    model = RigidBodyModel(Inertia(tensor))
    attitude, omega = quat.identity(), np.array(rate)
    for _ in range(1000):
        attitude, omega = rk4_step(model, 0.0, attitude, omega, 1e-3)
    assert errors_against(attitude, mp_exp(list(rate)))[0] <= ABSOLUTE_BOUND
    np.testing.assert_allclose(omega, rate, rtol=0.0, atol=rate_change)

    propagator = DynamicsPropagator(scene)
    propagator.state.omega_body = np.array(rate)
    propagator.advance_to(1.0)
    assert errors_against(propagator.state.attitude, mp_exp(list(rate)))[0] <= ABSOLUTE_BOUND
    diagnostics = propagator.diagnostics()
    assert all(math.isfinite(x) for x in (diagnostics.energy_drift, diagnostics.momentum_drift,
                                          diagnostics.energy_balance_residual))

    # The batch integrates in principal axes: for ascending diagonal moments that frame is
    # the body frame and the result is exp(ω t) to rounding; for the box (moments descending)
    # q is carried as q ⊗ P with O(1) components, so each of the 1000 steps may round the
    # tiny increment once: ≤ 1000 ε ≈ 2.2e−13 absolute.
    for inertia, bound in (([1.0, 2.0, 3.0], ABSOLUTE_BOUND), (tensor, 1000 * EPS)):
        batch = TorqueFreeBatch(inertia, quat.identity((2,)), np.array([rate, rate]))
        batch.rk4(1e-3, 1000)
        for q in batch.attitude:
            assert errors_against(q, mp_exp(list(rate)))[0] <= bound
        np.testing.assert_allclose(batch.omega_body, [rate, rate], rtol=0.0,
                                   atol=rate_change)
        assert np.all(np.isfinite(batch.kinetic_energy()))
        assert np.all(np.isfinite(batch.world_angular_momentum()))
