"""Hard case 1: fast spin, |ω| = 100 and 1000 rad/s with h|ω| up to 2 (docs/hard-cases.md §1).

What breaks naively (Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., 2006,
§IV.2): raw Euler grows |q| by (h|ω|)²/8 per step, RK4 shrinks it
by (h|ω|)⁶/9216, Euler + normalise lags (h|ω|)³/12 rad per step, and explicit RK4 on Euler's
equations diverges once h|λ| > 2√2 (|λ| ≤ |ω| for a torque-free body).

Bounds held here:

* every strapdown method and every dynamics method keeps | |q| − 1 | ≤ 1e−12 (they renormalise
  each step, so the error is that of the last step, ≤ 2.2e−16, after any number of steps);
* the node's strapdown step (the exp map, constant rate) stays within 1e−9 rad of the closed
  form q₀ ⊗ exp(ω t) after 10⁶ steps (round-off bound below);
* every strapdown method follows its own per-step rotation formula at h|ω| = 2 (no method
  drifts away silently);
* explicit dynamics methods declare their stability limit (``max_rotation_per_step``, held
  only by the integrator; the propagator asks it): their own ``step`` and ``integrate`` refuse a
  step above it with an ``IntegratorError`` (before, they diverged silently until overflow),
  the propagator takes equal substeps instead and refuses only when that would need more than
  ``MAX_SUBSTEPS``; the implicit-free splitting and exact methods need neither.
"""

import math

import mpmath
import numpy as np
import pytest

from high_precision import mp_attitude_error

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.dynamics.integrators import (
    DYNAMICS_INTEGRATORS, dynamics_integrator, SimpleBodyModel)
from rigid_body_attitude.core.attitude.integrators.strapdown import (
    STRAPDOWN_METHODS, strapdown_method)
from rigid_body_attitude.core.propagator import (
    DynamicsPropagator, GyroPropagator, MAX_SUBSTEPS)
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping

#: The explicit Runge–Kutta methods: the dynamics integrators with a finite stability limit.
LIMITED_METHODS = sorted(name for name, cls in DYNAMICS_INTEGRATORS.items()
                         if cls.max_rotation_per_step < math.inf)

mpmath.mp.dps = 40
EPS = np.finfo(float).eps
AXIS = np.array([0.48, -0.6, 0.64])  # unit body axis of the constant spin
Q0 = quat.normalize([0.8, -0.2, 0.3, 0.4])

#: Methods whose rotation vector is exactly h ω for a constant rate (the coning and
#: higher-order terms vanish when successive rates are parallel).
EXACT_FOR_CONSTANT_RATE = {'exp_map', 'exp_midpoint', 'trapezoid_coning', 'magnus4',
                           'simpson_coning', 'delta_single', 'delta_one_plus_previous',
                           'delta_two_sample', 'delta_three_sample'}


def method_step_angle(name, rotation):
    """Rotation angle [rad] one step of a strapdown method makes for a constant rate.

    ``rotation = h|ω|``. Exact methods turn by h|ω|; Euler + normalise by 2 atan(h|ω|/2)
    (the normalised q ⊗ (1, hω/2)); RK4 on q by the angle of its degree-4 Taylor polynomial
    of exp, q ⊗ (1 − y²/2 + y⁴/24, (y − y³/6) ω̂), y = h|ω|/2.
    """
    x = mpmath.mpf(rotation)
    if name in EXACT_FOR_CONSTANT_RATE:
        return x
    if name == 'euler_normalize':
        return 2 * mpmath.atan(x / 2)
    if name == 'rk4_quaternion':
        y = x / 2
        return 2 * mpmath.atan2(y - y ** 3 / 6, 1 - y ** 2 / 2 + y ** 4 / 24)
    raise AssertionError(f'no per-step formula for strapdown method {name!r}')


def mp_closed_form(q0, axis, angle):
    """``q₀ ⊗ exp(angle · axis)`` in 40-digit arithmetic (axis a unit double vector)."""
    half = mpmath.mpf(angle) / 2
    e = [mpmath.cos(half)] + [mpmath.sin(half) * mpmath.mpf(float(a)) for a in axis]
    norm = mpmath.sqrt(sum(mpmath.mpf(float(a)) ** 2 for a in axis))
    e = [e[0]] + [c / norm for c in e[1:]]
    p = [mpmath.mpf(float(c)) for c in q0]
    return [p[0] * e[0] - p[1] * e[1] - p[2] * e[2] - p[3] * e[3],
            p[0] * e[1] + p[1] * e[0] + p[2] * e[3] - p[3] * e[2],
            p[0] * e[2] - p[1] * e[3] + p[2] * e[0] + p[3] * e[1],
            p[0] * e[3] + p[1] * e[2] - p[2] * e[1] + p[3] * e[0]]


def norm_error(q):
    """| |q| − 1 | of a 4-sequence."""
    return abs(math.sqrt(sum(c * c for c in q)) - 1.0)


@pytest.mark.parametrize('rate', [100.0, 1000.0])
def test_node_strapdown_step_matches_closed_form_after_a_million_steps(rate):
    # The method the strapdown scene (and so the node) uses, called as the propagator calls it.
    method = GyroPropagator(load_scene('strapdown')).method
    steps, rotation = 1_000_000, 2.0
    h = rotation / rate
    omega = tuple((rate * AXIS).tolist())
    q = tuple(Q0.tolist())
    propagate = method.propagate
    for _ in range(steps):
        q = propagate(q, omega, omega, h)
    error = mp_attitude_error(q, mp_closed_form(Q0, omega, mpmath.mpf(h) * steps * rate))
    # Round-off budget per step: the step quaternion (cos(a/2), v sin(a/2)/a), a = h|ω|, has
    # components within 3u (vector: h·ω, the angle, sin and the scale) and u/2 (scalar): an
    # angle error ≤ 7u sin(a/2) that repeats every step, plus the product and renormalisation
    # (≤ 4u per step, changing sign, √N growth). 7u sin(1) N + 4√N u = 6.5e−10 for N = 10⁶,
    # a = 2. Measured 1.6e−10 rad for both rates.
    assert error <= 1e-9
    assert norm_error(q) <= 1e-12


@pytest.mark.parametrize('name', sorted(STRAPDOWN_METHODS))
def test_every_strapdown_method_follows_its_step_formula_at_fast_spin(name):
    # |ω| = 1000 rad/s, h|ω| = 2: each method's attitude after N steps is q₀ ⊗ exp(N α ω̂),
    # α its per-step angle (method_step_angle). A method that drifted, lost the norm or
    # blew up would miss this by far more than the round-off bound N(h|ω| + 8)u.
    method = strapdown_method(name)
    steps, rate, rotation = 120_000, 1000.0, 2.0  # 120000: whole groups for 2- and 3-sample
    h = rotation / rate
    omega = tuple((rate * AXIS).tolist())
    q = tuple(Q0.tolist())
    worst_norm = 0.0
    for k in range(steps):
        q = method.propagate(q, omega, omega, h)
        if k % 1000 == 0:
            worst_norm = max(worst_norm, norm_error(q))
    expected = mp_closed_form(Q0, AXIS, steps * method_step_angle(name, rotation))
    assert mp_attitude_error(q, expected) <= steps * (rotation + 8.0) * EPS / 2
    assert max(worst_norm, norm_error(q)) <= 1e-12


def coning_rate(t, cone_angle, frequency):
    """Classical coning body rate (Savage 1998)."""
    return (-2.0 * frequency * math.sin(0.5 * cone_angle) ** 2,
            -frequency * math.sin(cone_angle) * math.sin(frequency * t),
            frequency * math.sin(cone_angle) * math.cos(frequency * t))


@pytest.mark.parametrize('name', sorted(STRAPDOWN_METHODS))
def test_every_strapdown_method_keeps_the_norm_under_fast_coning(name):
    # A rate that turns as fast as it spins (cone half-angle 1 rad, |ω| = 1000 rad/s,
    # Ωh ≈ 2.1): the coning corrections are at their largest. The attitude is then wrong by
    # O(1) for every method (that is what h|ω| = 2 means), but it must stay a unit
    # quaternion and finite.
    method = strapdown_method(name)
    cone_angle = 1.0
    frequency = 1000.0 / (2.0 * math.sin(0.5 * cone_angle))  # |ω| = 2Ω sin(a/2) = 1000
    h = 2.0 / 1000.0
    q = tuple(Q0.tolist())
    previous = coning_rate(0.0, cone_angle, frequency)
    worst = 0.0
    for k in range(1, 30_001):
        current = coning_rate(k * h, cone_angle, frequency)
        q = method.propagate(q, previous, current, h)
        previous = current
        worst = max(worst, norm_error(q))
    assert all(math.isfinite(c) for c in q)
    assert worst <= 1e-12


def test_gyro_propagator_end_to_end_at_fast_spin():
    # The whole gyro path (rate corrections, method, state) for 10⁵ samples at |ω| = 1000,
    # h|ω| = 2 with stamps k·h: closed form within the round-off bound of the first test.
    propagator = GyroPropagator(load_scene('strapdown'))
    rate, rotation, steps = 1000.0, 2.0, 100_000
    h = rotation / rate
    omega = rate * AXIS
    propagator.start(0.0, omega)
    for k in range(1, steps + 1):
        propagator.update(k * h, omega)
    # Stamps k·h are rounded, so each interval differs from h by up to ulp(k h)/h ≈ 2e−13
    # relative at k = 10⁵: the sum telescopes to t_N = N h (rounded once), not N rounded h.
    exact = mp_closed_form(quat.identity(), AXIS, mpmath.mpf(steps * h) * rate)
    assert mp_attitude_error(propagator.state.attitude, exact) <= steps * (rotation + 8) * EPS
    assert propagator.diagnostics().quaternion_norm_error <= 1e-12


# ---------------------------------------------------------------- dynamics (Euler's equations)

INERTIA = np.array([1.0, 2.0, 3.0])
SPIN_DIRECTION = np.array([0.6, 0.1, 0.8]) / np.linalg.norm([0.6, 0.1, 0.8])  # a tumble

#: Steps per method at h|ω| = 2 (the adaptive method, the per-step exact solution and the
#: RKN splittings with an exact triaxial free flow cost ~1-2 ms per step; the other methods
#: 4-70 µs). rk4, the scenes' default, runs 10⁶ steps at 1000 rad/s.
DYNAMICS_STEPS = {'rk4': 100_000, 'rkmk4': 100_000, 'strang': 100_000, 'yoshida4': 100_000,
                  'casimir6': 40_000, 'casimir8': 20_000, 'dopri45': 500, 'exact': 1000,
                  'rkn4': 1000, 'rkn6': 1000}
#: Methods whose sub-flows are exact rotations of m (|m| and world H kept to round-off).
EXACT_ROTATION_METHODS = {'strang', 'yoshida4', 'casimir6', 'casimir8', 'rkn4', 'rkn6',
                          'exact'}
#: Runge–Kutta-type methods: |m|, H and T only to the method's error.
RUNGE_KUTTA_METHODS = {'rk4', 'rkmk4', 'dopri45'}


def test_every_dynamics_method_is_classified():
    # A new method must be added to one of the two sets (and so to the checks below).
    assert set(DYNAMICS_INTEGRATORS) == EXACT_ROTATION_METHODS | RUNGE_KUTTA_METHODS


def body_state(rate):
    """Initial attitude, body rate, momentum norm and energy of the tumbling test body."""
    omega = rate * SPIN_DIRECTION
    momentum = INERTIA * omega
    return Q0, omega, float(np.linalg.norm(momentum)), float(0.5 * np.sum(momentum * omega))


@pytest.mark.parametrize('rate', [100.0, 1000.0])
@pytest.mark.parametrize('name', sorted(DYNAMICS_INTEGRATORS))
def test_every_dynamics_method_is_stable_at_fast_spin(name, rate):
    steps = DYNAMICS_STEPS[name] * (10 if name == 'rk4' and rate == 1000.0 else 1)
    h = 2.0 / rate
    q0, omega0, momentum_norm, energy = body_state(rate)
    model = SimpleBodyModel(INERTIA)
    q, omega = dynamics_integrator(name).integrate(q0, omega0, 0.0, h, steps, model)
    momentum = INERTIA * omega
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(omega))
    assert abs(np.linalg.norm(q) - 1.0) <= 1e-12
    # No growth: |m| and T never exceed their start (RK4-type methods damp the nutation at
    # this step: measured −9.3% in |m|, −27% in T, bounded), and T never exceeds the largest
    # energy a body with this |m| can have, G²/(2 J_min) (yoshida4's energy error is O(1)
    # at h|ω| = 2, measured +107%, but bounded by this since |m| is exact).
    assert np.linalg.norm(momentum) <= momentum_norm * (1.0 + 1e-12)
    assert 0.5 * np.sum(momentum * omega) <= momentum_norm ** 2 / (2.0 * INERTIA.min())
    if name in EXACT_ROTATION_METHODS:
        # Each sub-flow rotates m and q by the same angle: |m| and H = R(q) m change by
        # round-off only, ≤ 5 roundings per step (measured ≤ 5.1e−12 after 10⁵ steps).
        world = quat.rotate(q, momentum)
        world0 = quat.rotate(q0, INERTIA * omega0)
        assert np.linalg.norm(world - world0) <= 1e-11 * momentum_norm
    else:
        assert 0.5 * np.sum(momentum * omega) <= energy * (1.0 + 1e-9)


def near_axis_state(rate):
    """Spin close to the major axis (small nutation): RK4's nutation mode has |λ| ≈ |ω|."""
    direction = np.array([0.01, 0.02, 1.0]) / np.linalg.norm([0.01, 0.02, 1.0])
    omega = rate * direction
    return Q0, omega, float(0.5 * np.sum(INERTIA * omega * omega))


@pytest.mark.parametrize('name', LIMITED_METHODS)
def test_direct_step_refuses_above_the_stability_limit(name):
    # RK4 on Euler's equations at h|ω| = 3 > 2√2 multiplies the nutation by |R(3i)| ≈ 1.4 per
    # step: the energy grew 11-fold in 10 steps and overflowed in the next 10, reported only
    # then. The integrator now refuses the step itself, naming h, |ω| and the limit, and
    # leaves its inputs alone.
    q0, omega0, _ = near_axis_state(1000.0)
    integrator = dynamics_integrator(name)
    assert integrator.max_rotation_per_step == 2.0
    model = SimpleBodyModel(INERTIA)
    attitude, omega = q0.copy(), omega0.copy()
    message = (rf"'{name}' is stable only for h·\|ω\| <= 2\.0 rad; got h = 0\.003 s at "
               r"\|ω\| = 1000 rad/s, h·\|ω\| = 3 rad.*DynamicsPropagator \(it splits such "
               r"steps into substeps\).*exact")
    with pytest.raises(IntegratorError, match=message):
        integrator.step(attitude, omega, 0.0, 3e-3, model)
    with pytest.raises(IntegratorError, match=r'h·\|ω\| = 3 rad \(step 1 of the run\)'):
        integrator.integrate(attitude, omega, 0.0, 3e-3, 10, model)
    np.testing.assert_array_equal(attitude, q0)
    np.testing.assert_array_equal(omega, omega0)
    # At the limit (h|ω| = 2, up to the propagator's rounding) the step is taken.
    q, _ = integrator.step(attitude, omega, 0.0, 2e-3 * (1.0 + 1e-9), model)
    assert abs(np.linalg.norm(q) - 1.0) <= 1e-15


@pytest.mark.parametrize('name', LIMITED_METHODS)
def test_integrate_refuses_the_first_step_whose_rate_passes_the_limit(name):
    # Spin about the major axis under a constant torque about it: ω₃ = 1905 + 10⁴ t rad/s
    # (ω × Jω = 0, so RK4 is exact up to round-off). With h = 1 ms, h|ω| = 1.995 after 9
    # steps and 2.005 after 10: the 11th step is refused.
    spin_up = 1e4 * INERTIA[2]
    model = SimpleBodyModel(INERTIA, torque_body=lambda t, q, w: np.array([0.0, 0.0, spin_up]))
    integrator = dynamics_integrator(name)
    q, omega = integrator.integrate(Q0, [0.0, 0.0, 1905.0], 0.0, 1e-3, 10, model)
    assert omega[2] == pytest.approx(2005.0, rel=1e-12)
    with pytest.raises(IntegratorError, match=r'\|ω\| = 2005 rad/s.*\(step 11 of the run\)'):
        integrator.integrate(Q0, [0.0, 0.0, 1905.0], 0.0, 1e-3, 11, model)


def scene_with(integrator, step, inertia, omega_body):
    """A torque-free scene with the given body and step."""
    return scene_from_mapping({
        'rate_source': 'dynamics', 'integrator': integrator, 'step': step,
        'body': {'inertia': {'moments': list(inertia)}},
        'initial_state': {'attitude': Q0.tolist(), 'omega_body': list(omega_body)}})


@pytest.mark.parametrize('name', LIMITED_METHODS)
@pytest.mark.parametrize('factor', [5, 50])
def test_propagator_splits_a_step_into_equal_substeps_within_the_limit(name, factor):
    # A sphere keeps |ω| constant to the bit (ω × Jω = 0), so a step of h|ω| = 2·factor is
    # exactly `factor` substeps of h|ω| = 2: the run with the small step, up to the rounding
    # of the substep lengths (h/factor vs the literal small step, a few ulps each): at most
    # 4ε·h|ω| rad per substep (measured 3.5e−14 and 4.2e−13 for 200 and 2000 substeps).
    omega = (1000.0 * SPIN_DIRECTION).tolist()
    coarse = DynamicsPropagator(scene_with(name, 2.0 * factor / 1000.0, [2.0] * 3, omega))
    fine = DynamicsPropagator(scene_with(name, 2.0 / 1000.0, [2.0] * 3, omega))
    assert coarse.rotation_limit == 2.0
    for _ in range(40):
        coarse.step(coarse.scene.step)
        for _ in range(factor):
            fine.step(fine.scene.step)
    assert coarse.substeps_taken == 40 * (factor - 1)
    assert fine.substeps_taken == 0
    substeps = 40 * factor
    assert quat.attitude_error(coarse.state.attitude, fine.state.attitude) <= (
        substeps * 4.0 * EPS * 2.0)
    np.testing.assert_array_equal(coarse.state.omega_body, fine.state.omega_body)
    assert coarse.state.time == pytest.approx(40 * coarse.scene.step, rel=1e-14)


@pytest.mark.parametrize('name', LIMITED_METHODS)
@pytest.mark.parametrize('rotation', [3.0, 10.0, 100.0])
def test_propagator_keeps_explicit_methods_stable_above_their_limit(name, rotation):
    # The body and step that make bare RK4 blow up (test above): through the propagator the
    # steps are split, the run stays finite and the invariants do not grow.
    q0, omega0, energy = near_axis_state(1000.0)
    propagator = DynamicsPropagator(scene_with(name, rotation / 1000.0, INERTIA, omega0))
    for _ in range(200):
        propagator.step(propagator.scene.step)
    assert propagator.substeps_taken >= 200 * (math.ceil(rotation / 2.0) - 1) * 0.9
    omega = propagator.state.omega_body
    assert np.all(np.isfinite(propagator.state.attitude)) and np.all(np.isfinite(omega))
    assert propagator.diagnostics().quaternion_norm_error <= 1e-12
    assert 0.5 * np.sum(INERTIA * omega * omega) <= energy * (1.0 + 1e-9)
    assert np.linalg.norm(INERTIA * omega) <= np.linalg.norm(INERTIA * omega0) * (1.0 + 1e-12)


def test_propagator_refuses_a_step_needing_too_many_substeps():
    _, omega0, _ = near_axis_state(1000.0)
    propagator = DynamicsPropagator(scene_with('rk4', 1e-3, INERTIA, omega0))
    propagator.step(1e-3)
    before = (propagator.state.time, propagator.state.attitude.copy(),
              propagator.state.omega_body.copy(), propagator.tracker.work)
    h = 4.0 * MAX_SUBSTEPS / 1000.0  # about 2·MAX_SUBSTEPS substeps of 2 rad
    with pytest.raises(IntegratorError, match=r"'rk4' is stable only for h·\|ω\| <= 2\.0 rad.*"
                       r"more than 1000000 substeps.*strang, yoshida4, dopri45 or exact"):
        propagator.step(h)
    assert propagator.state.time == before[0]
    np.testing.assert_array_equal(propagator.state.attitude, before[1])
    np.testing.assert_array_equal(propagator.state.omega_body, before[2])
    assert propagator.tracker.work == before[3]


@pytest.mark.parametrize('name', ['strang', 'yoshida4'])
def test_splitting_needs_no_substeps_at_any_step(name):
    # Exact sub-flows: unconditionally stable. h|ω| = 20 keeps |m| and world H to round-off.
    integrator = dynamics_integrator(name)
    assert integrator.max_rotation_per_step == math.inf
    assert name not in LIMITED_METHODS
    q0, omega0, momentum_norm, _ = body_state(1000.0)
    q, omega = integrator.integrate(q0, omega0, 0.0, 0.02, 10_000, SimpleBodyModel(INERTIA))
    world = quat.rotate(q, INERTIA * omega)
    assert np.linalg.norm(world - quat.rotate(q0, INERTIA * omega0)) <= 1e-11 * momentum_norm
