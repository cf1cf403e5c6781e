"""Tests of the rotor effect: a gyrostat, J ω̇ + ω × (J ω + h) = M − ḣ.

Invariants: with no external torque the total world momentum R(q)(J ω + h) is constant whether
h is constant or driven by the motor (the motor torque is internal); with constant h the
kinetic energy ½ ωᵀ J ω is constant too, and with a driven rotor it changes by the work of
−ḣ, which the energy balance accounts for. RK4 at 1 ms keeps these to ~1e−14 here (local error
(h|ω|)⁵/120 ≈ 1e−16 per step); bounds are 1e−12.
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping

BODY = BodyProperties(Inertia([1.0, 2.0, 3.0]), 1.0)
MOMENTUM = [0.3, -0.5, 0.8]


def gyrostat(commanded):
    return DynamicsPropagator(scene_from_mapping({
        'name': 'gyrostat_test', 'rate_source': 'dynamics', 'step': 0.001,
        'body': {'inertia': {'box': {'edges': [1.0, 2.0, 1.5], 'about': 'corner'}}, 'mass': 1.0},
        'initial_state': {'attitude': [0.8, 0.2, -0.4, 0.1], 'omega_body': [0.7, -1.1, 0.4]},
        'effects': [{'rotor': {'momentum': MOMENTUM, 'commanded': commanded, 'timeout': 0.5}}]}))


def test_rotor_momentum_piecewise_linear():
    rotor = EFFECTS['rotor']({'momentum': [0.0, 1.0, 0.0], 'commanded': True, 'timeout': 0.5},
                             BODY)
    momentum, rate = rotor.rotor_momentum(3.0)
    np.testing.assert_array_equal(momentum, [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(rate, [0.0, 0.0, 0.0])
    rotor.accept_input('rotor_torque', 1.0, np.array([0.2, 0.0, -0.4]))
    momentum, rate = rotor.rotor_momentum(1.25)              # held: h grows at u
    np.testing.assert_allclose(momentum, [0.05, 1.0, -0.1], rtol=1e-15)
    np.testing.assert_array_equal(rate, [0.2, 0.0, -0.4])
    assert rotor.counters == {}
    momentum, rate = rotor.rotor_momentum(2.0)               # timed out at 1.5: h frozen
    np.testing.assert_allclose(momentum, [0.1, 1.0, -0.2], rtol=1e-15)
    np.testing.assert_array_equal(rate, [0.0, 0.0, 0.0])
    assert rotor.counters == {'stale': 1}
    rotor.rotor_momentum(2.5)
    assert rotor.counters == {'stale': 1}                    # one expiry counts once
    rotor.accept_input('rotor_torque', 2.0, np.array([0.0, 1.0, 0.0]))
    momentum, _ = rotor.rotor_momentum(2.1)                  # continuous at the new command
    np.testing.assert_allclose(momentum, [0.1, 1.1, -0.2], rtol=1e-15)
    rotor.reset()
    np.testing.assert_array_equal(rotor.rotor_momentum(2.1)[0], [0.0, 1.0, 0.0])


def test_constant_rotor_conserves_momentum_and_energy():
    propagator = gyrostat(commanded=False)
    energy, momentum = propagator.energy(), propagator.world_momentum()
    propagator.advance_to(2.0)
    assert abs(propagator.energy() - energy) <= 1e-12 * energy
    np.testing.assert_allclose(propagator.world_momentum(), momentum,
                               atol=1e-12 * np.linalg.norm(momentum))
    # h really acts: without it the body would be elsewhere
    plain = DynamicsPropagator(propagator.scene.with_overrides(
        effect_parameters={'rotor': {'momentum': [0.0, 0.0, 0.0]}}))
    plain.advance_to(2.0)
    assert quat.attitude_error(plain.state.attitude, propagator.state.attitude) > 0.1


def test_uncommanded_rotor_takes_no_input():
    propagator = gyrostat(commanded=False)
    assert propagator.input_names == frozenset()
    with pytest.raises(InputError, match=re.escape(
            "Scene 'gyrostat_test' takes no input 'rotor_torque'; inputs: (none)")):
        propagator.command('rotor_torque', 0.0, [1.0, 0.0, 0.0])


def test_commanded_rotor_conserves_total_momentum():
    # motor torque u in a non-principal direction, re-commanded every 0.1 s for 1 s: the body
    # feels −u, the rotor +u, the total momentum R(q)(J ω + h) does not change
    propagator = gyrostat(commanded=True)
    assert propagator.input_names == frozenset({'rotor_torque'})
    energy, momentum = propagator.energy(), propagator.world_momentum()
    motor_torque = np.array([0.3, -0.2, 0.5])
    for k in range(10):
        propagator.command('rotor_torque', 0.1 * k, motor_torque)
        propagator.advance_to(0.1 * (k + 1))
    np.testing.assert_allclose(propagator.rotor_momentum(1.0), np.array(MOMENTUM) + motor_torque,
                               rtol=1e-14)
    np.testing.assert_allclose(propagator.world_momentum(), momentum,
                               atol=1e-12 * np.linalg.norm(momentum))
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.kinetic_energy - energy) > 0.01 * energy    # the motor did work
    assert abs(diagnostics.energy_balance_residual) <= 1e-12 * diagnostics.kinetic_energy
    assert propagator.counters() == {}
    propagator.advance_to(1.5)                     # the last command expires at 0.9 + 0.5 s
    assert propagator.counters() == {'rotor.stale': 1}
    np.testing.assert_allclose(propagator.rotor_momentum(1.5), np.array(MOMENTUM) + 1.4 *
                               motor_torque, rtol=1e-14)
    # the propagator ends a step exactly at the expiry and evaluates each step with the command
    # in force inside it, so RK4 never samples ḣ across the jump: conserved to round-off
    np.testing.assert_allclose(propagator.world_momentum(), momentum,
                               atol=1e-12 * np.linalg.norm(momentum))
    # after the switch h is frozen and the gyrostat is torque-free again: conserved to 1e−12
    after_switch = propagator.world_momentum()
    propagator.advance_to(2.0)
    np.testing.assert_allclose(propagator.world_momentum(), after_switch,
                               atol=1e-12 * np.linalg.norm(momentum))


def test_commands_stamped_ahead_and_inside_steps_conserve_momentum():
    # commands stamped ahead of the propagated time and in the middle of a step: each acts from
    # its stamp (h(t) continuous, ḣ switching there) and the propagator ends a step at every
    # switch, so the total momentum is conserved to round-off (before: 3.1e−3 N m s lost for a
    # command 5 ms ahead, h|u|/3 per switch inside a step)
    propagator = gyrostat(commanded=True)
    momentum = propagator.world_momentum()
    propagator.advance_to(0.1003)
    propagator.command('rotor_torque', 0.1053, [0.3, -0.5, 0.2])
    propagator.advance_to(0.4)
    propagator.command('rotor_torque', 0.40037, [-0.1, 0.2, 0.6])
    propagator.advance_to(1.2)
    np.testing.assert_allclose(propagator.world_momentum(), momentum,
                               atol=1e-12 * np.linalg.norm(momentum))
    np.testing.assert_allclose(
        propagator.rotor_momentum(1.2),
        np.array(MOMENTUM) + 0.29507 * np.array([0.3, -0.5, 0.2])
        + 0.5 * np.array([-0.1, 0.2, 0.6]), rtol=1e-12)
    assert propagator.counters() == {'rotor.stale': 1}


def test_gyrostat_scene_spin_is_stable():
    # linearised about ω = (0, Ω, 0) with h = (0, h, 0): ε̈₁ = −k ε₁,
    # k = ((J₂ − J₃)Ω + h)((J₂ − J₁)Ω + h)/(J₁ J₃) = (−1 + 2)(1 + 2)/3 = 1 rad²/s², so from
    # ε₁(0) = 1e−3: ω₁ = 1e−3 cos t, ω₃ = −1e−3 sin t (without the wheel the body flips; with
    # h = 1 N m s, k = 0 and ω₃ drifts linearly). Nonlinear terms are O(ε²) = 1e−6 relative to
    # Ω, so the closed form holds to ~1e−8 over 30 s (measured 5e−9); RK4 at 10 ms adds 1e−11.
    propagator = DynamicsPropagator(load_scene('gyrostat').with_overrides(step=0.01))
    worst = 0.0
    for k in range(1, 61):
        t = 0.5 * k
        propagator.advance_to(t)
        omega = propagator.state.omega_body
        worst = max(worst, abs(omega[0] - 1e-3 * np.cos(t)), abs(omega[2] + 1e-3 * np.sin(t)))
    assert worst <= 1e-7


@pytest.mark.parametrize('params, message', [
    ({}, "Effect 'rotor': missing parameter 'momentum'"),
    ({'momentum': [0, 1, 0], 'commanded': 'yes'},
     "parameter 'commanded' must be true or false, got 'yes'"),
    ({'momentum': [0, 1, 0], 'timeout': 0}, "parameter 'timeout' must be a number > 0, got 0"),
])
def test_bad_parameters(params, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        EFFECTS['rotor'](params, BODY)
