"""magnetorquers: m × B with clipped rods, held dipole commands, dumping of wheel momentum."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.propagator import DynamicsPropagator

ORBIT = {'altitude': 500000.0, 'inclination_deg': 97.4, 'epoch': '2025-01-01T00:00:00Z'}


def scene(effects, omega=(0.0, 0.0, 0.0), step=0.1):
    return scene_from_mapping({
        'rate_source': 'dynamics', 'step': step, 'body': {'inertia': {'moments': [
            0.05, 0.1, 0.14]}}, 'initial_state': {'omega_body': list(omega)}, 'orbit': ORBIT,
        'magnetic_field': {'model': 'tilted_dipole'}, 'effects': effects})


def test_the_torque_is_the_held_dipole_across_the_field():
    propagator = DynamicsPropagator(scene([{'magnetorquers': {'max_dipole': 0.2}}]))
    rods = propagator.effects[0]
    propagator.command('dipole', 0.0, [0.1, -0.3, 0.05])
    q = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    rods.hold(0.0, 0.1, tuple(q), (0.0, 0.0, 0.0))
    assert rods.dipole == (0.1, -0.2, 0.05)  # the y rod clipped
    assert propagator.counters()['magnetorquers.dipole_limit'] == 1
    field = quaternion.rotate_inverse(q, propagator.scene.magnetic_field.field_world(5.0))
    np.testing.assert_allclose(rods.torque_body(5.0, q, [0, 0, 0]),
                               np.cross([0.1, -0.2, 0.05], field), rtol=1e-14)
    assert abs(np.dot(rods.torque_body(5.0, q, [0, 0, 0]), field)) < 1e-20


def test_skewed_rods_share_the_dipole_by_the_pseudo_inverse():
    axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]]
    propagator = DynamicsPropagator(scene([{'magnetorquers': {'max_dipole': 1.0,
                                                              'axes': axes}}]))
    given, clipped = propagator.effects[0].rods((0.3, 0.2, -0.1))
    np.testing.assert_allclose(given, [0.3, 0.2, -0.1], atol=1e-15)
    assert not clipped


def test_dumping_takes_the_wheels_momentum_out():
    effects = [{'reaction_wheels': {'axes': [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                    'spin_inertia': 1e-4, 'max_torque': 0.005,
                                    'max_speed': 600.0, 'initial_speed': [300.0, -200.0, 250.0]}},
               {'attitude_pd': {'kp': 0.002, 'kd': 0.02, 'control_period': 0.2,
                                'actuator': 'reaction_wheels'}},
               {'magnetorquers': {'max_dipole': 0.2, 'dumping_gain': 0.002}}]
    propagator = DynamicsPropagator(scene(effects, step=0.2))
    wheels, rods = propagator.effects[0], propagator.effects[2]
    stored = np.linalg.norm(wheels.stored_momentum())
    propagator.advance_to(12000.0)  # about two orbits
    assert np.linalg.norm(wheels.stored_momentum()) < 0.1 * stored
    assert np.linalg.norm(propagator.state.omega_body) < 1e-3
    assert rods.torque_impulse > 0.5 * stored


def test_bdot_detumbles_the_example_cubesat_from_10_to_half_a_degree_per_second():
    from rigid_body_attitude.core.dynamics.scene import load_scene
    propagator = DynamicsPropagator(load_scene('bdot_detumbling'))
    rate = math.degrees(np.linalg.norm(propagator.state.omega_body))
    assert rate == pytest.approx(10.0, abs=0.01)
    reached = None
    for tick in range(1, 1001):
        propagator.advance_to(10.0 * tick)
        if math.degrees(np.linalg.norm(propagator.state.omega_body)) < 0.5:
            reached = 10.0 * tick
            break
    # docs/scenes.md: 3 140 s, 0.55 of the 5 677 s orbit
    assert reached == 3140.0


def test_the_residual_dipole_torque_is_its_cross_product_with_the_field():
    propagator = DynamicsPropagator(scene([{'residual_dipole': {'dipole': [0.01, 0.0, -0.02]}}]))
    q = quaternion.normalize(np.array([0.5, 0.5, -0.5, 0.1]))
    field = quaternion.rotate_inverse(q, propagator.scene.magnetic_field.field_world(12.0))
    np.testing.assert_allclose(propagator.effects[0].torque_body(12.0, q, [0, 0, 0]),
                               np.cross([0.01, 0.0, -0.02], field), rtol=1e-14)


@pytest.mark.parametrize('effects, match', [
    ([{'magnetorquers': {}}], "missing parameter 'max_dipole'"),
    ([{'magnetorquers': {'max_dipole': -1}}], "'max_dipole'"),
    ([{'magnetorquers': {'max_dipole': 1, 'axes': [[0, 0, 0]]}}], "'axes'"),
    ([{'magnetorquers': {'max_dipole': 1, 'dumping_gain': 0.1}}], 'needs reaction_wheels'),
    ([{'bdot': {'gain': 1.0, 'control_period': 1.0}}], "needs effect 'magnetorquers'"),
    ([{'magnetorquers': {'max_dipole': 1}}, {'bdot': {'gain': 1.0, 'control_period': 0.15}}],
     'whole number of steps'),
    ([{'residual_dipole': {'dipole': [1e300, 0, 0]}}], "'dipole'"),
])
def test_hostile_magnetic_effects_are_one_scene_error(effects, match):
    with pytest.raises(SceneError, match=match) as raised:
        scene(effects)
    assert '\n' not in str(raised.value)
