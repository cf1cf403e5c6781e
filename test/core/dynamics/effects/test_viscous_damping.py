"""Tests of viscous_damping: M = −c ∘ ω.

For a sphere (J = j I) Euler's equations decouple into ω̇ = −(c/j) ω, so ω(t) = ω₀ e^{−ct/j}
and T(t) = T₀ e^{−2ct/j}, about a fixed axis (Shuster, "A survey of attitude representations", J.
Astronaut. Sci. 41(4), 1993: q(t) = q₀ ⊗ exp(θ(t) e) with
θ = |ω₀| j/c (1 − e^{−ct/j})). RK4 reproduces the exponential with relative error
(ch/j)⁵/120 per step: at c h/j = 1e−3 over 2000 steps that is ~2e−16 per step, so round-off
(1e−13 bound) dominates.
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

BODY = BodyProperties(Inertia([1.0, 2.0, 3.0]), 1.0)


def test_torque_hand_values():
    scalar = EFFECTS['viscous_damping']({'coefficient': 0.5}, BODY)
    np.testing.assert_array_equal(scalar.torque_body(0.0, quat.identity(), np.array([1, -2, 4.0])),
                                  [-0.5, 1.0, -2.0])
    per_axis = EFFECTS['viscous_damping']({'coefficient': [0.0, 1.0, 2.0]}, BODY)
    np.testing.assert_array_equal(
        per_axis.torque_body(0.0, quat.identity(), np.array([1, -2, 4.0])), [0.0, 2.0, -8.0])


def test_sphere_energy_decays_exponentially():
    coefficient, moment = 0.2, 0.4           # c/j = 0.5 1/s
    omega0 = np.array([0.6, -0.8, 1.2])
    q0 = quat.normalize([0.9, -0.1, 0.3, 0.2])
    scene = scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.002, 'body': {'inertia': {'moments': [moment] * 3}},
        'initial_state': {'attitude': q0.tolist(), 'omega_body': omega0.tolist()},
        'effects': [{'viscous_damping': {'coefficient': coefficient}}]})
    propagator = DynamicsPropagator(scene)
    initial_energy = propagator.energy()
    rate = coefficient / moment
    for t in (1.0, 2.0, 4.0):
        propagator.advance_to(t)
        energy_ratio = propagator.energy() / initial_energy
        assert energy_ratio == pytest.approx(np.exp(-2 * rate * t), rel=1e-13)
        np.testing.assert_allclose(propagator.state.omega_body, omega0 * np.exp(-rate * t),
                                   rtol=1e-13)
    # fixed axis: the attitude turned by ∫|ω| dt about ω₀'s direction
    speed = np.linalg.norm(omega0)
    angle = speed / rate * (1.0 - np.exp(-rate * 4.0))
    expected = quat.multiply(q0, quat.exp(angle * omega0 / speed))
    assert quat.attitude_error(propagator.state.attitude, expected) <= 1e-13
    # the damping's (negative) work is accounted for: T − T₀ − W closes up to the O(h⁴)
    # error of the Hermite midpoint in the per-step Simpson rule (~1e−14 T₀ here)
    diagnostics = propagator.diagnostics()
    assert abs(diagnostics.energy_balance_residual) <= 1e-13 * initial_energy
    assert diagnostics.energy_drift == pytest.approx(np.exp(-4.0) - 1.0, rel=1e-13)


@pytest.mark.parametrize('value, message', [
    (-0.1, "parameter 'coefficient' must be a number >= 0, got -0.1"),
    ([1.0, 2.0], "parameter 'coefficient' must be one number or a list of 3 numbers >= 0"),
    ('strong', "parameter 'coefficient' must be a number, got 'strong'"),
])
def test_bad_coefficient(value, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        EFFECTS['viscous_damping']({'coefficient': value}, BODY)
