"""TorqueFreeBatch and SceneBatch (N bodies at once) against the single body, body by body.

The batch integrates each body in its principal frame with the same classical RK4 and
renormalisation as
:class:`~rigid_body_attitude.core.dynamics.integrators.rigid_body_rk4.RigidBodyRk4`; RK4
commutes with a constant linear change of variables, so each body must match the single-body
result up to round-off. The issue asks for 1e-12.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.batch import SceneBatch, TorqueFreeBatch
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import Scene, scene_from_mapping
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator
from rigid_body_attitude.core.dynamics.integrators.base import SimpleBodyModel

#: Bodies per test, step [s] and steps: 0.2 s of motion at |ω| up to 3 rad/s.
BODIES = 40
STEP = 1e-3
STEPS = 200
#: Round-off only: the principal-frame change of variables (eigh: axes and moments to a few ε
#: relative for the well-separated moments drawn here) and a different operation order,
#: each step rounding O(1) components a few times: 200 steps × ~10 ε ≈ 4e-13 < 1e-12.
AGREEMENT = 1e-12


def dispersion(count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Monte-Carlo dispersion: per-body inertia tensors (random principal moments with gaps
    ≥ 0.2 kg m² and random principal axes), unit attitudes and body rates up to 3 rad/s."""
    rng = np.random.default_rng(seed)
    tensors = np.empty((count, 3, 3))
    for index in range(count):
        moments = np.array([1.0, 1.2, 1.4]) + np.sort(rng.uniform(0.0, 0.5, 3)) * [1, 1.4, 1.8]
        axes = quaternion.to_matrix(quaternion.normalize(rng.normal(size=4)))
        tensors[index] = axes @ np.diag(moments) @ axes.T
    attitudes = quaternion.normalize(rng.normal(size=(count, 4)))
    omegas = rng.uniform(-1.0, 1.0, (count, 3)) * 3.0 / np.sqrt(3.0)
    return tensors, attitudes, omegas


def single_body(tensor: np.ndarray, attitude: np.ndarray, omega: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The ``rk4`` integrator on one body for the same steps."""
    return dynamics_integrator('rk4').integrate(attitude, omega, 0.0, STEP, STEPS,
                                                SimpleBodyModel(tensor))


@pytest.mark.parametrize('chunk', [7, 4096])  # several chunks with a ragged last one, and one
def test_batch_matches_single_body_rk4_per_body(chunk):
    tensors, attitudes, omegas = dispersion(BODIES, seed=7)
    batch = TorqueFreeBatch(tensors, attitudes, omegas, chunk=chunk)
    batch.rk4(STEP, STEPS)
    for index in range(BODIES):
        attitude, omega = single_body(tensors[index], attitudes[index], omegas[index])
        assert np.max(np.abs(batch.attitude[index] - attitude)) <= AGREEMENT, index
        assert np.max(np.abs(batch.omega_body[index] - omega)) <= AGREEMENT, index


def test_batch_with_one_inertia_for_all_bodies_matches_single_body_rk4():
    tensors, attitudes, omegas = dispersion(BODIES, seed=8)
    batch = TorqueFreeBatch(tensors[0], attitudes, omegas)
    batch.rk4(STEP, STEPS // 2)
    batch.rk4(STEP, STEPS // 2)  # two calls give the steps of one
    for index in range(BODIES):
        attitude, omega = single_body(tensors[0], attitudes[index], omegas[index])
        assert np.max(np.abs(batch.attitude[index] - attitude)) <= AGREEMENT, index
        assert np.max(np.abs(batch.omega_body[index] - omega)) <= AGREEMENT, index


def test_batch_invariants_agree_with_the_single_body_state():
    tensors, attitudes, omegas = dispersion(BODIES, seed=9)
    batch = TorqueFreeBatch(tensors, attitudes, omegas)
    batch.rk4(STEP, STEPS)
    for index in range(BODIES):
        attitude, omega = single_body(tensors[index], attitudes[index], omegas[index])
        energy = 0.5 * omega @ tensors[index] @ omega
        momentum = quaternion.rotate(attitude, tensors[index] @ omega)
        # Energies of ~5 J and momenta of ~5 N m s from states equal to 1e-12 (above):
        # relative 1e-12 of the size, the same round-off argument.
        assert batch.kinetic_energy()[index] == pytest.approx(energy, rel=1e-12)
        np.testing.assert_allclose(batch.world_angular_momentum()[index], momentum,
                                   rtol=0.0, atol=1e-11)


# --- SceneBatch: any dynamics scene, effects included ------------------------------------------

#: Scene batches: 0.3 s of 1 ms RK4 steps with held commands switching inside (steps end at
#: the switches); same round-off argument as above (300 steps × ~10 ε ≈ 7e-13 < 1e-12).
SCENE_STEPS_END = 0.3


def scene_dispersion(count: int, seed: int) -> dict[str, np.ndarray]:
    """Per-body inertia, mass, attitude, rate, damping coefficients and centre of mass."""
    tensors, attitudes, omegas = dispersion(count, seed)
    rng = np.random.default_rng(seed + 1)
    return {'inertia': tensors, 'attitude': attitudes, 'omega': omegas,
            'mass': rng.uniform(1.0, 3.0, count),
            'coefficient': rng.uniform(0.0, 0.2, (count, 3)),
            'centre_of_mass': rng.uniform(-0.1, 0.1, (count, 3))}


def body_scene(scene: Scene, values: dict[str, np.ndarray], index: int) -> Scene:
    """The single-body scene of body ``index``: its inertia, mass, state and parameters."""
    overrides = {'viscous_damping': {'coefficient': values['coefficient'][index].tolist()},
                 'gravity_about_pivot': {
                     'centre_of_mass': values['centre_of_mass'][index].tolist()}}
    scene = scene.with_overrides('rk4', effect_parameters=overrides)
    return dataclasses.replace(scene, inertia=Inertia(values['inertia'][index]),
                               mass=float(values['mass'][index]),
                               initial_attitude=values['attitude'][index],
                               initial_omega_body=values['omega'][index])


def command_both(target, t: float) -> None:
    """The same commands for the batch and each single body (they switch at 0.1 s)."""
    for name in sorted(target.input_routes):
        target.command(name, t, [0.05 * np.sin(7 * t + 1), 0.03, -0.04 * np.cos(3 * t)])


SCENE_EFFECTS = {
    'gravity_gradient_damped': [{'gravity_gradient': {'orbit_radius': 7.0e6}},
                                {'viscous_damping': {'coefficient': 0.1}}],
    'heavy_top_damped': [{'gravity_about_pivot': {'centre_of_mass': [0.0, 0.0, 0.1]}},
                         {'viscous_damping': {'coefficient': [0.1, 0.0, 0.2]}}],
    'commanded_gyrostat': [{'rotor': {'momentum': [0.0, 2.0, 0.0], 'commanded': True}},
                           {'commanded_torque': {'timeout': 0.15}},
                           {'constant_torque': {'torque': [0.0, 0.1, 0.0], 'frame': 'world'}}],
    'free_flyer': [{'translation': {'initial_velocity': [0.1, 0.0, 0.0]}},
                   {'commanded_force': {'timeout': 0.15}}, {'uniform_gravity': {}},
                   {'commanded_torque': {'timeout': 0.15}}],
}


@pytest.mark.parametrize('name', sorted(SCENE_EFFECTS))
def test_scene_batch_matches_the_single_body_propagator_per_body(name):
    scene = scene_from_mapping({'name': name, 'rate_source': 'dynamics', 'integrator': 'rk4',
                                'step': STEP, 'body': {'inertia': {'moments': [1, 2, 3]}},
                                'effects': SCENE_EFFECTS[name]})
    values = scene_dispersion(12, seed=3)
    dispersed = {'viscous_damping': {'coefficient': values['coefficient']},
                 'gravity_about_pivot': {'centre_of_mass': values['centre_of_mass']}}
    batch = SceneBatch(scene, values['attitude'], values['omega'], inertia=values['inertia'],
                       mass=values['mass'], chunk=5,
                       effect_parameters={k: v for k, v in dispersed.items()
                                          if k in dict(scene.effects)})
    singles = [DynamicsPropagator(body_scene(scene, values, i)) for i in range(12)]
    for t in (0.0, 0.1, 0.2):
        for target in [batch] + singles:
            command_both(target, t)
            target.advance_to(t + 0.1)
    for index, single in enumerate(singles):
        assert np.max(np.abs(batch.attitude[index] - single.state.attitude)) <= AGREEMENT
        assert np.max(np.abs(batch.omega_body[index] - single.state.omega_body)) <= AGREEMENT
        if batch.translation is not None:
            assert np.max(np.abs(batch.position[:, index] - single.state.position)) <= (
                AGREEMENT)
    assert batch.time == singles[0].state.time == pytest.approx(SCENE_STEPS_END)
    # the effects acted: the rates moved away from the torque-free motion
    free = SceneBatch(scene_from_mapping({'rate_source': 'dynamics', 'step': STEP,
                                          'body': {'inertia': {'moments': [1, 2, 3]}}}),
                      values['attitude'], values['omega'], inertia=values['inertia'])
    free.advance_to(SCENE_STEPS_END)
    assert np.min(np.max(np.abs(free.omega_body - batch.omega_body), axis=1)) > 1e-4


def test_scene_batch_refuses_bad_dispersions():
    scene = scene_from_mapping({'rate_source': 'dynamics',
                                'body': {'inertia': {'moments': [1, 2, 3]}},
                                'effects': [{'viscous_damping': {'coefficient': 0.1}}]})
    attitude, omega = np.tile([1.0, 0, 0, 0], (4, 1)), np.zeros((4, 3))
    with pytest.raises(InputError, match=r'viscous_damping.coefficient as finite values of '
                       r'shape \(4, 3\)'):
        SceneBatch(scene, attitude, omega,
                   effect_parameters={'viscous_damping': {'coefficient': np.ones(4)}})
    with pytest.raises(InputError, match="no parameter 'gain'"):
        SceneBatch(scene, attitude, omega,
                   effect_parameters={'viscous_damping': {'gain': np.ones(4)}})
    fast = SceneBatch(scene, attitude, np.full((4, 3), 2000.0))
    with pytest.raises(InputError, match="above RK4's limit"):
        fast.advance_to(0.01)
