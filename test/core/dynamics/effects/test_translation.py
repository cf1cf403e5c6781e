"""Tests of the translation effect: m a = F for the centre of mass (world frame).

The update x⁺ = x + h v + h² (2 a₀ + a₁)/6, v⁺ = v + h (a₀ + a₁)/2 is exact for a force
linear in time over the step, so free fall and a ramped force are reproduced to round-off
(1e−12 relative); the force's work h (v₀·F₀ + v₁·F₁)/2 is exact for a constant force.
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

MASS = 3.0
BODY = BodyProperties(Inertia([1.0, 2.0, 3.0]), MASS)
X0 = np.array([1.0, -2.0, 10.0])
V0 = np.array([0.5, 0.25, 3.0])


def test_ramped_force_is_integrated_exactly():
    # F(t) = F₀ + F₁ t: x(t) = x₀ + v₀ t + F₀ t²/(2m) + F₁ t³/(6m), v = v₀ + (F₀ t + F₁ t²/2)/m
    translation = EFFECTS['translation']({'initial_position': X0.tolist(),
                                          'initial_velocity': V0.tolist()}, BODY)
    f0, f1 = np.array([0.3, -0.6, 1.2]), np.array([-0.9, 0.15, 0.45])

    def force(t, attitude):
        return f0 + f1 * t

    t, h = 0.0, 0.05
    for _ in range(40):
        translation.advance(t, h, quat.identity(), quat.identity(), force)
        t += h
    position = X0 + V0 * t + f0 * t * t / (2 * MASS) + f1 * t ** 3 / (6 * MASS)
    velocity = V0 + (f0 * t + f1 * t * t / 2) / MASS
    np.testing.assert_allclose(translation.position, position, rtol=1e-13)
    np.testing.assert_allclose(translation.velocity, velocity, rtol=1e-13)
    assert translation.kinetic_energy() == pytest.approx(0.5 * MASS * velocity @ velocity,
                                                         rel=1e-13)
    outputs = translation.outputs()
    np.testing.assert_array_equal(outputs['position'], translation.position)
    translation.reset()
    np.testing.assert_array_equal(translation.position, X0)
    np.testing.assert_array_equal(translation.velocity, V0)


def free_flight(effects, omega=(0.0, 0.0, 0.5)):
    return DynamicsPropagator(scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001,
        'body': {'mass': MASS, 'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': list(omega)},
        'effects': [{'translation': {'initial_position': X0.tolist(),
                                     'initial_velocity': V0.tolist()}}] + effects}))


def test_free_fall_closed_form():
    # uniform gravity: x(t) = x₀ + v₀ t + g t²/2 exactly (1e−12), whatever the rotation does
    propagator = free_flight(['uniform_gravity'], omega=(0.3, 1.5, -0.2))
    gravity = np.array([0.0, 0.0, -9.80665])
    for t in (0.5, 1.0, 2.0):
        propagator.advance_to(t)
        np.testing.assert_allclose(propagator.state.position,
                                   X0 + V0 * t + 0.5 * gravity * t * t, rtol=1e-12)
        translation = propagator.stateful[0]
        np.testing.assert_allclose(translation.velocity, V0 + gravity * t, rtol=1e-12)
    # energy: T includes ½ m v²; gravity's work −m g Δz closes the balance to round-off
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.energy_balance_residual) <= 1e-12 * diagnostics.kinetic_energy
    assert propagator.has_translation


def test_without_forces_moves_uniformly():
    propagator = free_flight([])
    propagator.advance_to(1.5)
    np.testing.assert_allclose(propagator.state.position, X0 + 1.5 * V0, rtol=1e-13)
    assert propagator.diagnostics().energy_drift == pytest.approx(0.0, abs=1e-13)


def test_set_attitude_moves_the_position():
    propagator = free_flight([])
    propagator.advance_to(0.1)
    propagator.set_attitude([1.0, 0.0, 0.0, 0.0], position=[5.0, 6.0, 7.0])
    np.testing.assert_array_equal(propagator.state.position, [5.0, 6.0, 7.0])
    propagator.advance_to(0.2)
    np.testing.assert_allclose(propagator.state.position, np.array([5.0, 6.0, 7.0]) + 0.1 * V0,
                               rtol=1e-13)
    propagator.reset()
    np.testing.assert_array_equal(propagator.state.position, X0)


def test_bad_initial_velocity():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'translation': parameter 'initial_velocity' must be a list of 3 numbers, "
            "got 1.0")):
        EFFECTS['translation']({'initial_velocity': 1.0}, BODY)
