"""SceneBatch with reaction wheels, magnetorquers and B-dot: each body as the single-body
propagator, dispersed wheel parameters and axis misalignments included."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_attitude.core.dynamics.batch import SceneBatch
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.propagator import DynamicsPropagator

ORBIT = {'altitude': 500000.0, 'inclination_deg': 97.4, 'epoch': '2025-01-01T00:00:00Z'}
WHEELS = {'axes': [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.577, 0.577, 0.577]],
          'spin_inertia': [2e-4, 2e-4, 2e-4, 3e-4], 'max_torque': 0.004, 'max_speed': 600.0,
          'coulomb_friction': 2e-5, 'viscous_friction': 1e-8,
          'initial_speed': [100.0, -50.0, 80.0, 30.0]}


def spacecraft(step=0.1):
    return scene_from_mapping({
        'rate_source': 'dynamics', 'step': step,
        'body': {'mass': 10.0, 'inertia': {'box': {'edges': [0.1, 0.22, 0.34]}}},
        'initial_state': {'omega_body': [0.01, -0.02, 0.015]}, 'orbit': ORBIT,
        'magnetic_field': {'model': 'tilted_dipole'},
        'effects': [{'reaction_wheels': WHEELS},
                    {'attitude_pd': {'kp': 0.002, 'kd': 0.02, 'control_period': 0.2,
                                     'target_rpy': [0.2, 0.1, -0.3],
                                     'actuator': 'reaction_wheels'}},
                    {'magnetorquers': {'max_dipole': 0.2, 'dumping_gain': 0.002}},
                    {'residual_dipole': {'dipole': [0.005, 0.0, -0.002]}}]})


def single(scene, attitude, omega, overrides):
    """The single-body propagator of one dispersed body."""
    changed = scene.with_overrides(effect_parameters=overrides)
    propagator = DynamicsPropagator(changed)
    propagator.state.attitude = attitude
    propagator.state.omega_body = omega
    for wheel in propagator.wheels:
        wheel.start(tuple(omega))
    return propagator


def test_every_body_with_dispersed_wheels_matches_its_own_propagator():
    scene = spacecraft()
    rng = np.random.default_rng(7)
    count = 3
    axes = np.array(WHEELS['axes'], dtype=float) + rng.normal(0.0, 0.01, (count, 4, 3))
    spin = np.array(WHEELS['spin_inertia']) * (1 + 0.05 * rng.standard_normal((count, 4)))
    max_torque = 0.004 * (1 + 0.1 * rng.standard_normal(count))
    attitude = np.tile(scene.initial_attitude, (count, 1))
    omega = scene.initial_omega_body + rng.normal(0.0, 0.005, (count, 3))
    batch = SceneBatch(scene, attitude, omega, effect_parameters={'reaction_wheels': {
        'axes': axes, 'spin_inertia': spin, 'max_torque': max_torque}})
    batch.advance_to(300.0)
    totals = batch.effect_totals('reaction_wheels')
    for body in range(count):
        propagator = single(scene, attitude[body], omega[body], {'reaction_wheels': {
            'axes': axes[body].tolist(), 'spin_inertia': spin[body].tolist(),
            'max_torque': float(max_torque[body])}})
        propagator.advance_to(300.0)
        np.testing.assert_allclose(batch.attitude[body], propagator.state.attitude,
                                   atol=1e-12)
        np.testing.assert_allclose(batch.omega_body[body], propagator.state.omega_body,
                                   atol=1e-12)
        wheels = propagator.effects[0]
        assert totals['peak_speed'][body] == pytest.approx(wheels.peak_speed, rel=1e-12)
        assert totals['motor_work'][body] == pytest.approx(wheels.motor_work, rel=1e-9)
        assert totals['friction_loss'][body] == pytest.approx(wheels.friction_loss, rel=1e-9)
        np.testing.assert_allclose(batch.momentum_body()[body] @ np.eye(3),
                                   _body_momentum(propagator), atol=1e-12)
        assert batch.kinetic_energy()[body] == pytest.approx(propagator.energy(), rel=1e-12)
    assert batch.effect_totals('magnetorquers')['torque_impulse'].min() > 0.0
    with pytest.raises(InputError, match="no wheel array or magnetorquers 'bdot'"):
        batch.effect_totals('bdot')


def _body_momentum(propagator):
    from rigid_body_attitude.core.attitude import quaternion
    return quaternion.rotate_inverse(propagator.state.attitude, propagator.world_momentum())


def test_bdot_in_the_batch_matches_the_single_body_detumbling():
    scene = load_scene('bdot_detumbling')
    propagator = DynamicsPropagator(scene)
    batch = SceneBatch(scene, np.tile(scene.initial_attitude, (2, 1)),
                       np.tile(scene.initial_omega_body, (2, 1)))
    for t in (200.0, 1000.0):
        propagator.advance_to(t)
        batch.advance_to(t)
    np.testing.assert_allclose(batch.omega_body, np.tile(propagator.state.omega_body, (2, 1)),
                               atol=1e-12)
    used, peak = batch.torque_used('bdot')
    assert peak[0] == pytest.approx(propagator.effects[1].torque_used(1000.0)[1], rel=1e-9)
