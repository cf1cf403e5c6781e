"""Tests of commanded_torque: the `torque` input held from its stamp for `timeout`, then zero.

On a sphere (J = j I) ω × Jω = 0, so ω̇ = M/j: ω grows linearly while the command is held
(RK4 integrates a linear ω exactly: round-off only) and stays constant once it has expired.
The energy balance with a non-principal torque is in test_propagator.py.
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping

BODY = BodyProperties(Inertia([1.0, 1.0, 1.0]), 1.0)
TORQUE = np.array([0.2, -0.1, 0.4])


def test_held_then_zero_and_counted_once():
    effect = EFFECTS['commanded_torque']({'timeout': 0.5}, BODY)
    q, omega = quat.identity(), np.zeros(3)
    np.testing.assert_array_equal(effect.torque_body(0.0, q, omega), [0.0, 0.0, 0.0])
    assert effect.counters == {}                   # nothing was ever commanded: nothing stale
    effect.accept_input('torque', 1.0, TORQUE)
    for t in (1.0, 1.3, 1.5):                      # held through stamp + timeout inclusive
        np.testing.assert_array_equal(effect.torque_body(t, q, omega), TORQUE)
    np.testing.assert_array_equal(effect.torque_body(1.6, q, omega), [0.0, 0.0, 0.0])
    assert effect.counters == {'stale': 1}
    effect.torque_body(1.7, q, omega)
    assert effect.counters == {'stale': 1}
    effect.accept_input('torque', 2.0, -TORQUE)    # a new command, and its own expiry
    np.testing.assert_array_equal(effect.torque_body(2.1, q, omega), -TORQUE)
    effect.torque_body(2.6, q, omega)
    assert effect.counters == {'stale': 2}
    effect.reset()
    np.testing.assert_array_equal(effect.torque_body(2.1, q, omega), [0.0, 0.0, 0.0])


def test_timeout_zeroes_torque_in_propagation():
    moment = 0.5
    propagator = DynamicsPropagator(scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001,
        'body': {'inertia': {'moments': [moment] * 3}},
        'initial_state': {'omega_body': [0.1, 0.0, 0.0]},
        'effects': [{'commanded_torque': {'timeout': 0.3}}]}))
    omega0 = propagator.state.omega_body.copy()
    propagator.command('torque', 0.0, TORQUE)
    propagator.advance_to(0.25)
    np.testing.assert_allclose(propagator.state.omega_body, omega0 + TORQUE * 0.25 / moment,
                               rtol=0, atol=1e-14)
    assert propagator.counters() == {}
    propagator.advance_to(0.4)
    assert propagator.counters() == {'commanded_torque.stale': 1}
    omega_after = propagator.state.omega_body.copy()
    # The switch at 0.3 s falls on a step boundary up to round-off: RK4 samples the torque on
    # both sides of it, which can cost up to h|M|/(3j) of ω (test_rotor.py); afterwards ω is
    # constant.
    np.testing.assert_allclose(omega_after, omega0 + TORQUE * 0.3 / moment,
                               atol=0.001 * np.linalg.norm(TORQUE) / (3 * moment))
    propagator.advance_to(1.0)
    np.testing.assert_array_equal(propagator.state.omega_body, omega_after)
    assert propagator.counters() == {'commanded_torque.stale': 1}


def test_bad_timeout():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'commanded_torque': parameter 'timeout' must be a number > 0, got 0")):
        EFFECTS['commanded_torque']({'timeout': 0}, BODY)


def test_switch_inside_a_step_keeps_the_energy_balance():
    # a new command stamped between two step boundaries: the step is split at its stamp and
    # each side is integrated with its own torque, so the power theorem holds to round-off
    # (a step straddling the jump would cost O(h |ΔM| |ω|) of energy balance)
    propagator = DynamicsPropagator(load_scene('commanded_torque'))
    propagator.command('torque', 0.0, [0.01, 0.02, 0.005])
    propagator.advance_to(0.2345)
    propagator.command('torque', 0.2399, [0.0, -0.01, 0.02])
    propagator.advance_to(1.0)
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.energy_balance_residual) <= 1e-12 * diagnostics.kinetic_energy
    assert propagator.counters() == {'commanded_torque.stale': 1}
