"""Hard case 2: long runs, 10⁷ strapdown steps and 10⁶ dynamics steps (docs/hard-cases.md §2).

What breaks naively (Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., 2006,
§IV.2): an unnormalised quaternion drifts off the unit sphere
linearly in the number of steps; RK4's energy and momentum errors grow linearly in time;
implicit midpoint loses world H; round-off alone, if biased, accumulates like N·ε.

Bounds held here:

* strapdown (the node's method, 10⁷ steps of 10 ms, 28 h of gyro data): | |q| − 1 | ≤ 1e−12 and
  the constant-rate closed form to the round-off bound N(h|ω| + 4)u;
* the torque-free box (the ``torque_free_box`` scene, 10⁶ steps of 1 ms): | |q| − 1 | ≤ 1e−12
  for every method; world angular momentum and energy to ≤ 1e−12 relative with the exact
  solution (at all 10⁶ step times) and with the scene's RK4 (its error at h|ω| = 0.003 is below
  round-off); with the splitting methods (Strang, Yoshida-4) the energy is bounded with no
  secular trend (first vs last 10 % of the run) and world H is kept to 1e−12 as well.
"""

import math

import mpmath
import numpy as np
import pytest

from high_precision import mp_attitude_error

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene

mpmath.mp.dps = 40
EPS = np.finfo(float).eps
DYNAMICS_STEPS = 1_000_000
SAMPLES = 1000  # invariants are recorded every DYNAMICS_STEPS // SAMPLES steps


def box():
    """The torque-free box scene (near its intermediate axis; major-axis side, 14.3 s period)
    with its propagator's model: initial attitude, rate, tensor, H₀ and T₀."""
    propagator = DynamicsPropagator(load_scene('torque_free_box'))
    scene = propagator.scene
    tensor = scene.inertia.tensor
    q0, omega0 = scene.initial_attitude, scene.initial_omega_body
    world = quat.rotate(q0, tensor @ omega0)
    return propagator, q0, omega0, tensor, world, 0.5 * omega0 @ tensor @ omega0


def run_dynamics(name):
    """10⁶ steps of 1 ms with method ``name``; invariants every 1000 steps."""
    propagator, q0, omega0, tensor, world0, energy0 = box()
    integrator = dynamics_integrator(name)
    h = propagator.scene.step
    chunk = DYNAMICS_STEPS // SAMPLES
    q, omega = q0, omega0
    momentum_drift, energy_drift, norm_drift = [], [], []
    for k in range(SAMPLES):
        q, omega = integrator.integrate(q, omega, k * chunk * h, h, chunk, propagator.model)
        world = quat.rotate(q, tensor @ omega)
        momentum_drift.append(np.linalg.norm(world - world0) / np.linalg.norm(world0))
        energy_drift.append(0.5 * omega @ tensor @ omega / energy0 - 1.0)
        norm_drift.append(abs(np.linalg.norm(q) - 1.0))
    return np.array(momentum_drift), np.array(energy_drift), np.array(norm_drift)


def assert_no_secular_trend(energy_drift):
    """Energy bounded: the last 10 % of the run looks like the first 10 %.

    A linear drift d·t would move the mean by 0.9 d T between the two windows, about the
    whole excursion; a bounded oscillation keeps both means within a small fraction of it
    and the excursion in the last window no larger than in the first.
    """
    tenth = energy_drift.size // 10
    first, last = energy_drift[:tenth], energy_drift[-tenth:]
    excursion = np.max(np.abs(energy_drift))
    assert abs(np.mean(last) - np.mean(first)) <= 0.25 * excursion
    assert np.max(np.abs(last)) <= 1.5 * np.max(np.abs(first))


def test_ten_million_strapdown_steps():
    # 100 Hz gyro at |ω| = 1 rad/s for 10⁵ s (28 h), through the strapdown scene's method.
    method = GyroPropagator(load_scene('strapdown')).method
    steps, h = 10_000_000, 0.01
    axis = np.array([0.48, -0.6, 0.64])
    omega = tuple(axis.tolist())
    q = (1.0, 0.0, 0.0, 0.0)
    worst_norm = 0.0
    propagate = method.propagate
    for _ in range(100):
        for _ in range(steps // 100):
            q = propagate(q, omega, omega, h)
        worst_norm = max(worst_norm, abs(math.sqrt(sum(c * c for c in q)) - 1.0))
    assert worst_norm <= 1e-12
    # Closed form exp(ω N h) in 40 digits, compared with atan2 (acos of the dot product
    # would turn a 1e−16 norm error into 1.4e−8 rad). Round-off per step: the step quaternion
    # (cos(a/2), v sin(a/2)/a), a = h|ω|, has components within 3u (vector) and u/2 (scalar),
    # an angle error ≤ 7u sin(a/2) ≤ 3.5 a u that repeats every step; the product and the
    # renormalisation add ≤ 4u per step with changing sign. Bound N·3.5au + 4√N u = 4.0e−11
    # rad for N = 10⁷, a = 0.01 (measured 9.3e−12; linear in N, 9.3e−13 at 10⁶).
    norm = mpmath.sqrt(sum(mpmath.mpf(float(a)) ** 2 for a in axis))
    half = mpmath.mpf(h) * steps * norm / 2
    exact = [mpmath.cos(half)] + [mpmath.sin(half) * mpmath.mpf(float(a)) / norm for a in axis]
    u = EPS / 2
    assert mp_attitude_error(q, exact) <= steps * 3.5 * h * u + 4.0 * math.sqrt(steps) * u


def test_exact_solution_at_a_million_step_times():
    # The exact method's outputs at t_k = k h, k ≤ 10⁶ (evaluated from the initial state, as
    # the exact propagator does): H does not depend on the phase ψ, so it stays at round-off
    # (a few ulps: measured 2.8e−15 relative); T and |q| likewise.
    _, q0, omega0, tensor, world0, energy0 = box()
    motion = TorqueFreeMotion(tensor, q0, omega_body=omega0)
    worst_momentum = worst_energy = worst_norm = 0.0
    for chunk in range(10):
        times = np.arange(chunk * 100_000 + 1, (chunk + 1) * 100_000 + 1) * 1e-3
        q, omega = motion.state(times)
        world = quat.rotate(q, omega @ tensor)
        worst_momentum = max(worst_momentum, np.max(
            np.linalg.norm(world - world0, axis=1)) / np.linalg.norm(world0))
        energy = 0.5 * np.einsum('ni,ij,nj->n', omega, tensor, omega)
        worst_energy = max(worst_energy, np.max(np.abs(energy / energy0 - 1.0)))
        worst_norm = max(worst_norm, np.max(np.abs(np.linalg.norm(q, axis=1) - 1.0)))
    assert worst_momentum <= 1e-12
    assert worst_energy <= 1e-12
    assert worst_norm <= 1e-12


def test_exact_method_composed_over_many_steps():
    # The exact *step* restarts the closed form from the state it is given; composing 2000
    # steps accumulates only the round-off of each restart: ~10 products and rotations,
    # ≤ 8ε per restart in the attitude (measured 1.4e−12 rad after 2000, bound 3.6e−12).
    propagator, q0, omega0, tensor, world0, energy0 = box()
    integrator = dynamics_integrator('exact')
    q, omega = integrator.integrate(q0, omega0, 0.0, 1e-3, 2000, propagator.model)
    world = quat.rotate(q, tensor @ omega)
    assert np.linalg.norm(world - world0) <= 1e-12 * np.linalg.norm(world0)
    assert abs(0.5 * omega @ tensor @ omega / energy0 - 1.0) <= 1e-12
    reference, _ = TorqueFreeMotion(tensor, q0, omega_body=omega0).state(2.0)
    assert quat.attitude_error(q, reference) <= 2000 * 8.0 * EPS


def test_scene_rk4_over_a_million_steps():
    # The scene's own method at its own step: h|ω| = 0.003, RK4's O(h⁴) error per unit time is
    # below round-off, so H and T stay within 1e−12 (measured 2.1e−13 and 4.2e−14).
    momentum_drift, energy_drift, norm_drift = run_dynamics('rk4')
    assert np.max(norm_drift) <= 1e-12
    assert np.max(momentum_drift) <= 1e-12
    assert np.max(np.abs(energy_drift)) <= 1e-12


@pytest.mark.parametrize('name', ['strang', 'yoshida4'])
def test_splitting_over_a_million_steps(name):
    momentum_drift, energy_drift, norm_drift = run_dynamics(name)
    assert np.max(norm_drift) <= 1e-12
    # Energy: Strang's error oscillates with the momentum period (amplitude 1.1e−7, O(h²)) and
    # does not drift. Yoshida-4's O(h⁴) oscillation is at round-off level here, so the check
    # is its size: ≤ 2e−12 over the whole run (measured 1.3e−12; before, a linear round-off
    # drift reached −6e−11).
    if name == 'strang':
        assert np.max(np.abs(energy_drift)) <= 2e-7
        assert_no_secular_trend(energy_drift)
    else:
        assert np.max(np.abs(energy_drift)) <= 2e-12
    # World H: each axis rotation keeps H in exact arithmetic; the bound is 1e−12
    # after 10⁶ steps. Torque-free steps rotate the principal rate ω (ω_j ← ω_j c + (J_k/J_j)
    # ω_k s …) with cos θ = 1 − 2 sin²(θ/2): before, the m ↔ ω conversion of every step
    # (m/J and J ω round trips are biased for this box, +6e−18 per step) and the rounding of
    # cos²(θ/2) − sin²(θ/2) (≈ −(θ²/8)² per small rotation) drifted |m| linearly: 1.65e−11
    # (Strang) and 2.8e−11 (Yoshida-4, energy −6e−11). Measured now 2.4e−13 and 2.5e−13
    # (through DynamicsPropagator.step: 2.4e−13 both).
    assert np.max(momentum_drift) <= 1e-12
