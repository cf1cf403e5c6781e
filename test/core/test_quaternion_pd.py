"""Tests of the quaternion-feedback PD law (core/control/quaternion_pd.py).

Tolerances: the law is a Hamilton product and a few multiply-adds, so values that are exact in
real arithmetic are checked to a few units of round-off (4e−16 for unit-size results); the
batch and plain-float paths evaluate the same operations in the same order and must agree
bit for bit. The closed loop runs the package's RK4 propagator at 1 ms with the torque held
over each step: the held torque perturbs ``V̇ = −k_d |ω|²`` by ``O(h)`` relative, so ``V`` is
checked to fall from every 10 ms sample to the next.
"""

import math
import re

import numpy as np
import pytest

from rigid_body_attitude.core import quaternion as quat
from rigid_body_attitude.core.control import pd_torque_body, pd_torque_floats
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.scene import scene_from_mapping

ROUND_OFF = 4e-16
IDENTITY = (1.0, 0.0, 0.0, 0.0)


def random_quaternions(count, seed=1):
    return quat.normalize(np.random.default_rng(seed).normal(size=(count, 4)))


def test_zero_error_and_zero_rate_give_zero_torque():
    q = random_quaternions(5)
    torque = pd_torque_body(q, np.zeros(3), q, 2.0, 0.5, 0.0)
    assert np.all(np.abs(torque) <= ROUND_OFF)
    assert np.array_equal(pd_torque_body(IDENTITY, [0, 0, 0], IDENTITY, 1.0, 1.0, 1.0),
                          np.zeros(3))


def test_small_rotation_about_z_gives_a_restoring_torque_about_z():
    # q_err = exp(θ e_z): τ_z = −k_p sin(θ/2); and a rate alone gives −k_d ω
    theta = 0.2
    torque = pd_torque_body(quat.exp([0, 0, theta]), [0, 0, 0], IDENTITY, 3.0, 0.0, 0.0)
    assert torque == pytest.approx([0.0, 0.0, -3.0 * math.sin(theta / 2)], abs=ROUND_OFF)
    rate_torque = pd_torque_body(IDENTITY, [0.1, -0.2, 0.3], IDENTITY, 3.0, [1.0, 2.0, 4.0], 0)
    assert rate_torque == pytest.approx([-0.1, 0.4, -1.2], abs=ROUND_OFF)


def test_error_is_taken_relative_to_the_target():
    # body at exp(0.5 e_x) ⊗ exp(0.3 e_y), target exp(0.5 e_x): error exp(0.3 e_y), body axes
    target = quat.exp([0.5, 0, 0])
    q = quat.multiply(target, quat.exp([0, 0.3, 0]))
    torque = pd_torque_body(q, [0, 0, 0], target, 1.0, 0.0, 0.0)
    assert torque == pytest.approx([0.0, -math.sin(0.15), 0.0], abs=ROUND_OFF)


def test_past_180_degrees_the_shorter_rotation_is_taken():
    # 200° about z is −160°: the torque pushes towards +z (the shorter way), not −z
    q = quat.exp([0, 0, math.radians(200.0)])
    assert q[0] < 0.0
    torque = pd_torque_body(q, [0, 0, 0], IDENTITY, 1.0, 0.0, 0.0)
    assert torque[2] == pytest.approx(math.sin(math.radians(80.0)), abs=ROUND_OFF)
    assert torque[2] > 0.0
    # exactly 180°: w = 0, sign(0) = +1, the torque −k_p e_z
    half_turn = np.array([0.0, 0.0, 0.0, 1.0])
    assert np.array_equal(pd_torque_body(half_turn, [0, 0, 0], IDENTITY, 2.0, 0.0, 0.0),
                          [-0.0, -0.0, -2.0])


def test_q_and_minus_q_give_the_same_torque():
    rng = np.random.default_rng(3)
    q, target = random_quaternions(200, 4), random_quaternions(200, 5)
    omega = rng.normal(size=(200, 3))
    for body in (q, -q):
        for aim in (target, -target):
            assert np.array_equal(pd_torque_body(body, omega, aim, [1.0, 2.0, 3.0], 0.4, 0.0),
                                  pd_torque_body(q, omega, target, [1.0, 2.0, 3.0], 0.4, 0.0))


@pytest.mark.parametrize('limit', [0.0, math.inf])
def test_zero_and_infinite_limits_do_not_limit(limit):
    torque = pd_torque_body(IDENTITY, [100.0, -50.0, 3.0], IDENTITY, 1.0, 1.0, limit)
    assert np.array_equal(torque, [-100.0, 50.0, -3.0])


def test_each_component_is_clipped_to_the_limit():
    torque = pd_torque_body(IDENTITY, [100.0, -50.0, 0.3], IDENTITY, 1.0, 1.0, 2.0)
    assert np.array_equal(torque, [-2.0, 2.0, -0.3])
    per_axis = pd_torque_body(IDENTITY, [100.0, -50.0, 0.3], IDENTITY, 1.0, 1.0, [5.0, 0.0, 0.1])
    assert np.array_equal(per_axis, [-5.0, 50.0, -0.1])


def test_batch_equals_a_loop_of_single_bodies():
    rng = np.random.default_rng(7)
    q, target = random_quaternions(300, 8), random_quaternions(300, 9)
    omega = rng.normal(size=(300, 3))
    kp, kd, limit = [0.5, 1.0, 2.0], [0.3, 0.2, 0.1], 0.6
    batch = pd_torque_body(q, omega, target, kp, kd, limit)
    loop = np.array([pd_torque_body(q[i], omega[i], target[i], kp, kd, limit)
                     for i in range(300)])
    floats = np.array([pd_torque_floats(q[i], omega[i], target[i], kp, kd, [limit] * 3)
                       for i in range(300)])
    assert np.array_equal(batch, loop)
    assert np.array_equal(batch, floats)
    assert np.any(np.abs(batch) == limit)  # some were clipped
    # one target broadcast over the batch
    one_target = pd_torque_body(q, omega, target[0], kp, kd, limit)
    assert np.array_equal(one_target[5], pd_torque_body(q[5], omega[5], target[0], kp, kd, limit))


@pytest.mark.parametrize('arguments, message', [
    (([1, 0, 0], [0, 0, 0], IDENTITY, 1, 1, 0), 'Expected `q_world_body` to have shape (..., 4)'),
    ((IDENTITY, [0, 0], IDENTITY, 1, 1, 0), 'Expected `omega_body` to have shape (..., 3)'),
    ((IDENTITY, [0, 0, 0], [1, 0, 0, math.nan], 1, 1, 0),
     'Expected `q_world_target` to be finite'),
    ((IDENTITY, [math.inf, 0, 0], IDENTITY, 1, 1, 0), 'Expected `omega_body` to be finite'),
    ((IDENTITY, [0, 0, 0], IDENTITY, -1, 1, 0), 'Expected `kp` to be finite and ≥ 0'),
    ((IDENTITY, [0, 0, 0], IDENTITY, 1, math.inf, 0), 'Expected `kd` to be finite and ≥ 0'),
    ((IDENTITY, [0, 0, 0], IDENTITY, [1, 2], 1, 0), 'Expected `kp` to be a number or 3 numbers'),
    ((IDENTITY, [0, 0, 0], IDENTITY, 1, 1, -1.0), 'Expected `torque_limit` to be ≥ 0'),
    ((IDENTITY, [0, 0, 0], IDENTITY, 1, 1, math.nan), 'Expected `torque_limit` to be ≥ 0'),
    ((IDENTITY, [0, 0, 0], IDENTITY, 1, 1, 'fast'), 'Expected `torque_limit` to be a number'),
    ((random_quaternions(3), np.zeros((2, 3)), IDENTITY, 1, 1, 0),
     'Expected batch shapes that broadcast, got q_world_body (3, 4), omega_body (2, 3)'),
])
def test_bad_inputs_are_rejected_with_what_was_expected(arguments, message):
    with pytest.raises(InputError, match=re.escape(message)):
        pd_torque_body(*arguments)


def lyapunov(q, omega, inertia, target, kp):
    """``½ ωᵀ J ω + 2 k_p (1 − |q_err,w|)``."""
    error_w = quat.multiply(quat.conjugate(target), q)[0]
    return 0.5 * omega @ inertia @ omega + 2.0 * kp * (1.0 - abs(error_w))


def test_closed_loop_on_the_propagator_converges_and_v_decreases():
    # the commanded_torque scene's box, 60° off a target about a skew axis, tumbling slowly
    scene = scene_from_mapping({
        'name': 'loop', 'rate_source': 'dynamics', 'integrator': 'rk4', 'step': 0.001,
        'body': {'mass': 2.0, 'inertia': {'box': {'edges': [0.1, 0.2, 0.3], 'about': 'centre'}}},
        'initial_state': {'attitude': [1.0, 0.0, 0.0, 0.0], 'omega_body': [0.2, -0.1, 0.3]},
        'effects': [{'commanded_torque': {'timeout': 0.5}}]})
    propagator = DynamicsPropagator(scene)
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    target = quat.exp(math.radians(60.0) * axis)
    kp, kd, inertia = 0.1, 0.04, scene.inertia.tensor
    values = []
    for k in range(8000):
        state = propagator.state
        if k % 10 == 0:
            values.append(lyapunov(state.attitude, state.omega_body, inertia, target, kp))
        torque = pd_torque_body(state.attitude, state.omega_body, target, kp, kd, 0.0)
        propagator.command('torque', k * 0.001, torque)
        propagator.advance_to((k + 1) * 0.001)
    # slowest mode (x axis, J = 0.0217 kg m²): decay rate k_d / (2 J) = 0.92 /s, so after 8 s
    # the 60° error is down to about 60° · e^−7.4 = 0.04°
    assert math.degrees(quat.attitude_error(propagator.state.attitude, target)) < 0.1
    assert np.linalg.norm(propagator.state.omega_body) < 1e-3
    assert np.all(np.diff(values) < 0.0)
    assert values[-1] < 1e-5 * values[0]
