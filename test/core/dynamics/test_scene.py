"""Tests of scene loading and validation (scene.py) and of the shipped scenes.

Every shipped scene loads and runs one second; only the effects a scene names are built (a
probe effect registered here counts its constructions and calls); each kind of bad scene gives
an error naming the bad value and the valid choices.
"""

import re
import textwrap

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import EFFECTS, RateCorrection, TorqueEffect
from rigid_body_attitude.core.dynamics.effects.base import Parameter, register
from rigid_body_attitude.core.yaml_files import real
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.propagator import (
    build_propagator, DynamicsPropagator, GyroPropagator)
from rigid_body_attitude.core.dynamics.scene import (
    builtin_scenes, load_scene, scene_from_mapping, scene_path)
from rigid_body_attitude.session.stream import GyroStream

SHIPPED = {'commanded_torque', 'dzhanibekov', 'free_flyer', 'gravity_gradient_satellite',
           'gyrostat', 'heavy_top', 'slew', 'slew_commanded', 'strapdown', 'torque_free_box'}
BODY = '{inertia: {moments: [1.0, 2.0, 3.0]}}'


def run_one_second(scene):
    """Run ``scene`` for 1 s of simulated time; commanded inputs get a small command."""
    propagator = build_propagator(scene)
    if isinstance(propagator, GyroPropagator):
        stream = GyroStream(propagator, max_dt=0.1, time_jump_threshold=1.0)
        for k in range(201):   # 200 Hz for 1 s
            t = 0.005 * k
            outcome = stream.add(round(t * 1e9), [0.1 * np.sin(t), 0.2, -0.3 * np.cos(2 * t)])
            assert outcome.accepted
        assert propagator.state.time == pytest.approx(1.0, abs=1e-12)
    else:
        for input_name in sorted(propagator.input_names):
            size = propagator.input_routes[input_name][0].input_size(input_name)
            propagator.command(input_name, 0.0, np.resize([0.01, -0.02, 0.03], size))
        propagator.advance_to(1.0)
        assert propagator.state.time == pytest.approx(1.0, abs=1e-12)
    return propagator


@pytest.fixture
def probe(request):
    """Register the effect ``probe_effect`` for one test; count constructions and calls."""
    calls = {'init': 0, 'torque_body': 0, 'corrected_rate': 0}

    class ProbeEffect(TorqueEffect, RateCorrection):
        name = 'probe_effect'
        description = 'counts its constructions and calls (test only)'
        parameters = {'gain': Parameter(real, 0.0, 'damping gain [N m s]')}
        rate_sources = frozenset({'dynamics', 'gyro'})

        def __init__(self, params, body):
            super().__init__(params, body)
            calls['init'] += 1

        def torque(self, t, q, omega):
            calls['torque_body'] += 1
            gain = self.params['gain']
            return -gain * omega[0], -gain * omega[1], -gain * omega[2]

        def add_batch_torque(self, t, q, omega, chunk, out):
            out -= self.params['gain'] * omega

        def corrected_rate(self, t, attitude, omega_measured):
            calls['corrected_rate'] += 1
            return omega_measured

    register(ProbeEffect)
    request.addfinalizer(lambda: EFFECTS.pop('probe_effect', None))
    return calls


# --- shipped scenes ---------------------------------------------------------------------------

def test_builtin_scenes_are_the_shipped_files():
    scenes = builtin_scenes()
    assert SHIPPED <= set(scenes)
    for name, path in scenes.items():
        assert path.is_file() and path.stem == name
        assert scene_path(name) == path


@pytest.mark.parametrize('name', sorted(builtin_scenes()))
def test_builtin_scene_runs_one_second(name):
    scene = load_scene(name)
    assert scene.name == name and scene.description
    assert scene.source == str(builtin_scenes()[name])
    propagator = run_one_second(scene)
    state = propagator.state
    assert np.all(np.isfinite(state.attitude)) and np.all(np.isfinite(state.omega_body))
    assert np.all(np.isfinite(state.position))
    assert quat.norm_error(state.attitude) <= 1e-12
    diagnostics = propagator.diagnostics()
    assert np.isfinite(diagnostics.kinetic_energy)
    assert np.all(np.isfinite(diagnostics.world_angular_momentum))


def test_unnamed_effect_is_never_built_or_called(probe):
    for name in sorted(builtin_scenes()):
        run_one_second(load_scene(name))
    assert probe == {'init': 0, 'torque_body': 0, 'corrected_rate': 0}


def test_named_probe_built_once_per_build_and_called(probe):
    scene = scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.01, 'body': {'inertia': {'moments': [1, 1, 1]}},
        'initial_state': {'omega_body': [0.0, 0.0, 1.0]},
        'effects': [{'probe_effect': {'gain': 0.5}}]})
    assert probe['init'] == 1            # validation builds the effects once
    assert len(scene.build_effects()) == 1
    assert probe['init'] == 2
    propagator = DynamicsPropagator(scene)
    assert probe['init'] == 3
    propagator.reset()
    assert probe['init'] == 3            # reset reuses the effects
    propagator.advance_to(0.1)
    assert probe['torque_body'] >= 4 * 10   # RK4: at least 4 torque evaluations per step
    # the torque it returned acted: ω₃ = exp(−0.5 t) for J = 1 (RK4 at h = 0.01: 1e−10)
    assert propagator.state.omega_body[2] == pytest.approx(np.exp(-0.05), abs=1e-10)
    assert probe['corrected_rate'] == 0


def test_named_probe_corrects_gyro_rates(probe):
    scene = scene_from_mapping({'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
                                'effects': ['probe_effect']})
    propagator = GyroPropagator(scene)
    assert probe['init'] == 2
    stream = GyroStream(propagator, max_dt=0.1, time_jump_threshold=1.0)
    for k in range(5):
        stream.add(10_000_000 * k, [0.0, 0.0, 1.0])
    assert probe['corrected_rate'] == 5
    assert probe['torque_body'] == 0


# --- a valid scene ------------------------------------------------------------------------------

def test_scene_defaults_and_normalised_attitude():
    scene = scene_from_mapping({'rate_source': 'dynamics',
                                'body': {'inertia': {'moments': [1, 2, 3]}},
                                'initial_state': {'attitude': [2.0, 0.0, 0.0, 0.0]}},
                               default_name='mine')
    assert (scene.name, scene.integrator, scene.step, scene.mass) == ('mine', 'rk4', 0.001, 1.0)
    np.testing.assert_array_equal(scene.initial_attitude, [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(scene.initial_omega_body, [0.0, 0.0, 0.0])
    assert scene.effects == ()
    gyro = scene_from_mapping({'rate_source': 'gyro',
                               'body': {'inertia': {'sphere': {'radius': 1}}}, 'effects': None})
    assert gyro.integrator == 'delta_single'
    np.testing.assert_allclose(gyro.inertia.tensor, 0.4 * np.eye(3), rtol=1e-15)


def test_scene_inertia_shapes():
    box = scene_from_mapping({'rate_source': 'dynamics', 'body': {
        'mass': 2.0, 'inertia': {'box': {'edges': [0.1, 0.2, 0.3], 'about': 'corner'}}}})
    assert box.inertia.tensor[0, 1] == pytest.approx(-2.0 * 0.02 / 4.0, rel=1e-15)
    cylinder = scene_from_mapping({'rate_source': 'dynamics', 'body': {
        'mass': 4.0, 'inertia': {'cylinder': {'radius': 0.5, 'height': 1.0}}}})
    assert cylinder.inertia.tensor[2, 2] == pytest.approx(0.5, rel=1e-15)


def test_with_overrides_revalidates():
    scene = load_scene('commanded_torque')
    changed = scene.with_overrides(step=0.01, effect_parameters={'commanded_torque': {
        'timeout': 2.0}, 'rotor': {'momentum': [1, 0, 0]}})
    assert changed.step == 0.01 and changed.integrator == scene.integrator
    assert changed.effects == (('commanded_torque', {'timeout': 2.0}),)
    assert scene.effects == (('commanded_torque', {'timeout': 0.5}),)
    with pytest.raises(SceneError, match=r"Effect 'commanded_torque': parameter 'timeout' must "
                                         r"be a number > 0, got -1"):
        scene.with_overrides(effect_parameters={'commanded_torque': {'timeout': -1}})
    with pytest.raises(SceneError, match='Expected step to be a positive number of seconds'):
        scene.with_overrides(step=-0.5)


def test_load_scene_from_path(tmp_path):
    path = tmp_path / 'spinner.yaml'
    path.write_text(f'rate_source: dynamics\nbody: {BODY}\n'
                    'initial_state: {omega_body: [0.0, 0.0, 1.0e-3]}\n')
    scene = load_scene(str(path))
    assert scene.name == 'spinner' and scene.source == str(path)
    # YAML 1.1 reads 1.0e-3 (dot and signed exponent) as a number
    assert scene.initial_omega_body[2] == 1e-3


# --- bad scenes ---------------------------------------------------------------------------------

def effects_list():
    return re.escape(', '.join(sorted(EFFECTS)))


BAD_SCENES = [
    ('unknown top-level key', f'rate_source: dynamics\nbody: {BODY}\nintegrater: rk4',
     r"Unknown key 'integrater' in scene; valid keys: body, description, effects, "
     r'estimation, initial_state, integrator, magnetic_field, name, orbit, rate_source, '
     r'sensors, step, sun'),
    ('missing rate_source', f'body: {BODY}', r"Missing key 'rate_source' in scene; valid keys"),
    ('missing body', 'rate_source: dynamics', r"Missing key 'body' in scene; valid keys"),
    ('bad rate_source', f'rate_source: imu\nbody: {BODY}',
     r"Unknown rate_source 'imu'; valid choices: dynamics, gyro"),
    ('unknown effect parameter',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [viscous_damping: {{coeff: 1.0}}]',
     r"Effect 'viscous_damping': unknown parameter 'coeff'; valid parameters: coefficient"),
    ('unknown parameter lists all',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [gravity_gradient: {{radius: 7.0e+6}}]',
     r"Effect 'gravity_gradient': unknown parameter 'radius'; valid parameters: "
     r'initial_anomaly, mu, orbit_normal, orbit_radius'),
    ('wrong parameter type',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [viscous_damping: {{coefficient: fast}}]',
     r"Effect 'viscous_damping': parameter 'coefficient' must be a number, got 'fast'"),
    ('wrong vector parameter',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [constant_torque: {{torque: [1, 2]}}]',
     r"Effect 'constant_torque': parameter 'torque' must be a list of 3 numbers, got \[1, 2\]"),
    ('wrong choice parameter', f'rate_source: dynamics\nbody: {BODY}\n'
     'effects: [constant_torque: {torque: [1, 2, 3], frame: inertial}]',
     r"Effect 'constant_torque': parameter 'frame' must be 'body' or 'world', got 'inertial'"),
    ('missing required parameter',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [gravity_gradient]',
     r"Effect 'gravity_gradient': missing parameter 'orbit_radius' \(orbit radius \[m\]\) "
     r"or the scene's orbit: section"),
    ('gyro effect in a dynamics scene',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [gyro_bias]',
     r"Effect 'gyro_bias' applies to gyro scenes, not to rate_source 'dynamics'"),
    ('dynamics effect in a gyro scene',
     f'rate_source: gyro\nbody: {BODY}\neffects: [viscous_damping: {{coefficient: 1.0}}]',
     r"Effect 'viscous_damping' applies to dynamics scenes, not to rate_source 'gyro'"),
    ('missing companion', f'rate_source: dynamics\nbody: {BODY}\neffects: [commanded_force]',
     r"Effect 'commanded_force' needs effect 'translation' in the same scene"),
    ('missing companion of gravity',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [uniform_gravity]',
     r"Effect 'uniform_gravity' needs effect 'translation' in the same scene"),
    ('effect twice', f'rate_source: dynamics\nbody: {BODY}\n'
     'effects: [commanded_torque, commanded_torque]',
     r"Effect 'commanded_torque' is named more than once in scene"),
    ('asymmetric inertia', 'rate_source: dynamics\n'
     'body: {inertia: {tensor: [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}}',
     r'Bad body\.inertia\.tensor: Expected `inertia` to be symmetric, got '
     r'\[\[1\.0, 0\.1, 0\.0\], \[0\.0, 1\.0, 0\.0\], \[0\.0, 0\.0, 1\.0\]\]'),
    ('not positive definite', 'rate_source: dynamics\n'
     'body: {inertia: {tensor: [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}}',
     r'Bad body\.inertia\.tensor: Expected `inertia` to be positive definite, got .* '
     r'principal moments \[-1\.0'),
    ('triangle inequality', 'rate_source: dynamics\nbody: {inertia: {moments: [1.0, 2.0, 3.5]}}',
     r'Bad body\.inertia\.moments: Expected principal moments with J1 \+ J2 >= J3 \(a real '
     r'mass distribution\), got \[1\.0, 2\.0, 3\.5\]'),
    ('unknown inertia shape', 'rate_source: dynamics\nbody: {inertia: {ellipsoid: [1, 2, 3]}}',
     r'Expected body\.inertia to be one of \{tensor, moments, box, cylinder, sphere: \.\.\.\}, '
     r"got \{'ellipsoid'"),
    ('bad box parameter', 'rate_source: dynamics\n'
     'body: {inertia: {box: {edges: [1, 2, 3], about: middle}}}',
     r"Bad body\.inertia\.box: Expected `about` to be 'centre' or 'corner', got 'middle'"),
    ('unknown box parameter', 'rate_source: dynamics\n'
     'body: {inertia: {box: {edges: [1, 2, 3], density: 2}}}',
     r"Bad body\.inertia\.box parameters \{.*\}: .*unexpected keyword argument 'density'"),
    ('unknown body key',
     'rate_source: dynamics\nbody: {colour: red, inertia: {moments: [1, 1, 1]}}',
     r"Unknown key 'colour' in body; valid keys: inertia, mass"),
    ('bad mass', 'rate_source: dynamics\nbody: {mass: -2.0, inertia: {moments: [1, 1, 1]}}',
     r'Expected body\.mass to be a positive number \[kg\], got -2\.0'),
    ('zero step', f'rate_source: dynamics\nstep: 0\nbody: {BODY}',
     r'Expected step to be a positive number of seconds, got 0'),
    ('negative step', f'rate_source: dynamics\nstep: -1.0e-3\nbody: {BODY}',
     r'Expected step to be a positive number of seconds, got -0\.001'),
    ('infinite step', f'rate_source: dynamics\nstep: .inf\nbody: {BODY}',
     r'Expected step to be a positive number of seconds, got inf'),
    ('YAML 1.1 exponent in an effect', f'rate_source: dynamics\nbody: {BODY}\n'
     'effects: [gravity_gradient: {orbit_radius: 7.0e6}]',
     r"Effect 'gravity_gradient': parameter 'orbit_radius' must be a number \(YAML 1\.1 reads "
     r'7\.0e6 as text: write it with a sign in the exponent and a dot, e\.g\. 7\.0e\+6\), '
     r"got '7\.0e6'"),
    ('YAML 1.1 exponent in the step', f'rate_source: dynamics\nstep: 1e-3\nbody: {BODY}',
     r"Expected 'step' to be a number \(YAML 1\.1 reads 1e-3 as text: .*\), got '1e-3'"),
    ('unknown initial_state key', f'rate_source: dynamics\nbody: {BODY}\n'
     'initial_state: {omega: [0, 0, 1]}',
     r"Unknown key 'omega' in initial_state; valid keys: attitude, omega_body"),
    ('short omega', f'rate_source: dynamics\nbody: {BODY}\ninitial_state: {{omega_body: [1, 2]}}',
     r'Expected `initial_state\.omega_body` to have shape \(\.\.\., 3\), got \(2,\)'),
    ('non-finite attitude', f'rate_source: dynamics\nbody: {BODY}\n'
     'initial_state: {attitude: [.nan, 0, 0, 1]}',
     r'Expected `initial_state\.attitude` to be finite, got \[nan, 0\.0, 0\.0, 1\.0\]'),
    ('effects not a list', f'rate_source: dynamics\nbody: {BODY}\neffects: commanded_torque',
     r"Expected effects to be a list, got 'commanded_torque'"),
    ('effect parameters not a mapping',
     f'rate_source: dynamics\nbody: {BODY}\neffects: [viscous_damping: 0.1]',
     r"Expected the parameters of effect 'viscous_damping' to be a mapping, got 0\.1"),
    ('integrator not text', f'rate_source: dynamics\nintegrator: 4\nbody: {BODY}',
     r"Expected 'integrator' to be a string, got 4"),
    ('not a mapping', '- rate_source: dynamics', r'Expected a scene to be a mapping with keys'),
    ('not YAML', 'rate_source: [dynamics',
     r"Scene file '.*bad\.yaml', line 2, column 1: not valid YAML: expected ',' or ']'"),
]


@pytest.mark.parametrize('text, message', [case[1:] for case in BAD_SCENES],
                         ids=[case[0] for case in BAD_SCENES])
def test_bad_scene_file_rejected(tmp_path, text, message):
    path = tmp_path / 'bad.yaml'
    path.write_text(textwrap.dedent(text) + '\n')
    with pytest.raises(SceneError, match=message):
        load_scene(str(path))


def test_unknown_effect_lists_valid_effects():
    with pytest.raises(SceneError, match=r"Unknown effect 'wind'; valid effects: "
                                         + effects_list()):
        scene_from_mapping({'rate_source': 'dynamics', 'body': {'inertia': {'moments': [1, 1, 1]}},
                            'effects': ['wind']})
    assert {'commanded_torque', 'gravity_gradient', 'rotor', 'translation'} <= set(EFFECTS)


def test_scene_file_not_found(tmp_path):
    missing = str(tmp_path / 'nowhere.yaml')
    with pytest.raises(SceneError, match=re.escape(f'Scene file {missing!r} does not exist')):
        load_scene(missing)


def test_unknown_builtin_lists_builtins():
    listed = re.escape(', '.join(sorted(builtin_scenes())))
    with pytest.raises(SceneError, match=r"Unknown scene 'tumbling_box'; built-in scenes: "
                                         + listed + r', or give a path to a \.yaml file'):
        load_scene('tumbling_box')


def test_scene_errors_are_value_errors():
    with pytest.raises(ValueError, match="Missing key 'body' in scene"):
        scene_from_mapping({'rate_source': 'dynamics'})
