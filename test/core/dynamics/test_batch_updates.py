"""SceneBatch between calls: discarded bodies and effect parameters replaced per body."""

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.batch import SceneBatch
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping

SCENE = scene_from_mapping({
    'name': 'torqued', 'rate_source': 'dynamics', 'integrator': 'rk4', 'step': 0.01,
    'body': {'mass': 1.0, 'inertia': {'moments': [1.0, 2.0, 2.5]}},
    'effects': [{'constant_torque': {'torque': [0.0, 0.0, 0.0]}}]})


def bodies(count: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    return quaternion.normalize(rng.normal(size=(count, 4))), rng.normal(size=(count, 3))


def test_discarded_bodies_become_nan_and_leave_the_others_and_the_step_check_alone():
    attitude, omega = bodies(6)
    omega[2] = [500.0, 0.0, 0.0]  # beyond RK4's limit at 0.01 s steps
    batch = SceneBatch(SCENE, attitude, omega)
    with pytest.raises(InputError, match='RK4'):
        batch.advance_to(0.1)
    mask = np.zeros(6, dtype=bool)
    mask[2] = True
    batch.discard(mask)
    batch.advance_to(0.5)
    keep = ~mask
    reference = SceneBatch(SCENE, attitude[keep], omega[keep])
    reference.advance_to(0.5)
    assert np.all(np.isnan(batch.attitude[2])) and np.all(np.isnan(batch.omega_body[2]))
    assert np.array_equal(batch.attitude[keep], reference.attitude)
    assert np.array_equal(batch.omega_body[keep], reference.omega_body)
    with pytest.raises(InputError, match='mask of 6'):
        batch.discard(np.ones(5, dtype=bool))


def test_effect_parameters_replaced_per_body_act_from_then_on():
    attitude, omega = bodies(4)
    torques = np.array([[0.0, 0.0, 1.0], [0.5, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 0.0]])
    switched = SceneBatch(SCENE, attitude, omega)
    switched.advance_to(0.3)
    switched.set_effect_parameters({'constant_torque': {'torque': torques}})
    switched.advance_to(0.6)
    first = SceneBatch(SCENE, attitude, omega)
    first.advance_to(0.3)
    second = SceneBatch(SCENE, first.attitude, first.omega_body,
                        effect_parameters={'constant_torque': {'torque': torques}})
    second.advance_to(0.3)
    # Equal up to round-off: the step times count from 0.3 in one and from 0 in the other.
    assert np.allclose(switched.attitude, second.attitude, rtol=0.0, atol=1e-12)
    assert np.allclose(switched.omega_body, second.omega_body, rtol=0.0, atol=1e-12)
    first.advance_to(0.6)  # no torque: differs where a torque was set, not where none was
    change = np.abs(switched.omega_body - first.omega_body).max(axis=1)
    assert np.all(change[:3] > 1e-2) and change[3] == 0.0
    with pytest.raises(InputError, match="no effect 'wind'"):
        switched.set_effect_parameters({'wind': {'speed': np.zeros(4)}})
    with pytest.raises(InputError, match='shape'):
        switched.set_effect_parameters({'constant_torque': {'torque': np.zeros((3, 3))}})
