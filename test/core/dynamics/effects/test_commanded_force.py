"""Tests of commanded_force: F_world = R(q) F_cmd from the `force` input, held, timed out.

With the body at rest the force is constant in the world frame while it is held, so the
translation reproduces x = x₀ + v₀ t + F t²/(2m) exactly (round-off, 1e−12 relative).
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping

MASS = 10.0
BODY = BodyProperties(Inertia([1.0, 1.0, 1.0]), MASS)
QUARTER_TURN_Z = quat.exp([0.0, 0.0, 0.5 * np.pi])


def test_force_rotated_to_world_and_timed_out():
    effect = EFFECTS['commanded_force']({'timeout': 0.5}, BODY)
    np.testing.assert_array_equal(effect.force_world(0.0, QUARTER_TURN_Z), [0.0, 0.0, 0.0])
    effect.accept_input('force', 1.0, np.array([2.0, 0.0, 1.0]))
    # body x is world y after a quarter turn about z
    np.testing.assert_allclose(effect.force_world(1.2, QUARTER_TURN_Z), [0.0, 2.0, 1.0],
                               atol=1e-15)
    np.testing.assert_array_equal(effect.force_world(1.51, QUARTER_TURN_Z), [0.0, 0.0, 0.0])
    assert effect.counters == {'stale': 1}
    effect.reset()
    np.testing.assert_array_equal(effect.force_world(1.2, QUARTER_TURN_Z), [0.0, 0.0, 0.0])


def test_held_force_moves_the_body_then_stops_pushing():
    propagator = DynamicsPropagator(scene_from_mapping({
        'name': 'pushed', 'rate_source': 'dynamics', 'step': 0.001,
        'body': {'mass': MASS, 'inertia': {'moments': [1, 1, 1]}},
        'initial_state': {'attitude': QUARTER_TURN_Z.tolist()},
        'effects': [{'translation': {'initial_velocity': [0.1, 0.0, 0.0]}},
                    {'commanded_force': {'timeout': 0.5}}]}))
    assert propagator.input_names == frozenset({'force'})
    force_world = np.array([0.0, 2.0, 0.0])            # F_body = (2, 0, 0)
    for k in range(10):                                  # re-commanded every 0.1 s: fresh
        propagator.command('force', 0.1 * k, [2.0, 0.0, 0.0])
        propagator.advance_to(0.1 * (k + 1))
    expected = np.array([0.1, 0.0, 0.0]) * 1.0 + force_world / (2 * MASS)
    np.testing.assert_allclose(propagator.state.position, expected, rtol=1e-12, atol=1e-15)
    assert propagator.counters() == {}
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.energy_balance_residual) <= 1e-12 * diagnostics.kinetic_energy
    propagator.advance_to(1.5)                           # the last command expired at 1.4 s
    assert propagator.counters() == {'commanded_force.stale': 1}
    velocity = propagator.stateful[0].velocity.copy()
    position = propagator.state.position.copy()
    propagator.advance_to(2.0)                           # no force: uniform motion
    np.testing.assert_allclose(propagator.state.position, position + 0.5 * velocity,
                               rtol=1e-13)
    np.testing.assert_array_equal(propagator.stateful[0].velocity, velocity)


def test_needs_translation():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'commanded_force' needs effect 'translation' in the same scene")):
        scene_from_mapping({'rate_source': 'dynamics', 'body': {'inertia': {'moments': [1, 1, 1]}},
                            'effects': [{'commanded_force': {'timeout': 1.0}}]})
