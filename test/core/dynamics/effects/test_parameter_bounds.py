"""Effect parameters whose physics cannot stay finite are refused when the scene loads."""

import pytest

from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping


def dynamics_scene(effect):
    return {'rate_source': 'dynamics', 'step': 0.001,
            'body': {'mass': 1.0, 'inertia': {'moments': [1, 2, 3]}},
            'effects': [effect, *([{'translation': {}}] if 'uniform_gravity' in effect else [])]}


@pytest.mark.parametrize('effect, parameter', [
    ({'rotor': {'momentum': [1e308, 1e308, 1e308]}}, 'momentum'),
    ({'gravity_about_pivot': {'centre_of_mass': [1e308, 0, 0]}}, 'centre_of_mass'),
    ({'viscous_damping': {'coefficient': 1e308}}, 'coefficient'),
    ({'translation': {'initial_position': [1e308, 0, 0]}}, 'initial_position'),
    ({'translation': {'initial_velocity': [0, 1e308, 0]}}, 'initial_velocity'),
    ({'gravity_gradient': {'orbit_radius': 1e308}}, 'orbit_radius'),
    ({'gravity_gradient': {'orbit_radius': 7e6, 'mu': 10**400}}, 'mu'),
    ({'constant_torque': {'torque': [0, 0, 1e80]}}, 'torque'),
    ({'uniform_gravity': {'gravity': [0, 0, -1e200]}}, 'gravity'),  # with translation
])
def test_absurd_effect_parameters_are_one_scene_error(effect, parameter):
    with pytest.raises(SceneError) as raised:
        scene_from_mapping(dynamics_scene(effect)).build_effects()
    message = str(raised.value)
    assert f'parameter {parameter!r} must be a number of magnitude at most 1e75' in message
    assert len(message) < 400 and '\n' not in message


@pytest.mark.parametrize('effect', [
    {'gyro_bias': {'bias': [1e300, 0, 0]}},
    {'earth_rate': {'latitude': 45.0, 'rate': 1e300}},
])
def test_absurd_gyro_effect_parameters_are_one_scene_error(effect):
    with pytest.raises(SceneError, match='magnitude at most 1e75'):
        scene_from_mapping({'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
                            'effects': [effect]}).build_effects()
