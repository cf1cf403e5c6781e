"""The nodes' interface table (session/interface.py): which endpoints a scene has, every input's
decoder found by its type, the README's and docs/closed-loop.md's topic tables equal to the
table's rendering, and a simulated sensor's topic never one of the node's own."""

from __future__ import annotations

from pathlib import Path

import pytest

from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.msgs.types import (
    IMU, MAGNETIC_FIELD, POSE_WITH_COVARIANCE_STAMPED, TWIST_STAMPED, VECTOR3_STAMPED)
from rigid_body_attitude.session.decoding import decoder
from rigid_body_attitude.session.interface import (
    CONTROLLER_INTERFACE, NODE_INTERFACE, QOS_PROFILES, Situation, check_scene_topics,
    markdown_table, qos_markdown_table)
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.settings import load_node_scene

REPO_ROOT = Path(__file__).resolve().parents[2]


def dynamics_scene(sensors=None):
    return scene_from_mapping({'rate_source': 'dynamics', 'step': 0.001,
                               'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
                               'effects': ['commanded_torque'], 'sensors': sensors})


def gyro_scene():
    return scene_from_mapping({'rate_source': 'gyro',
                               'body': {'inertia': {'moments': [1.0, 1.0, 1.0]}}})


def names(endpoints):
    return [endpoint.name for endpoint in endpoints]


def table_in(path: Path, header: str) -> str:
    """The Markdown table of ``path`` that starts with the line ``header``."""
    lines = path.read_text().splitlines()
    start = lines.index(header)
    end = next((k for k in range(start, len(lines)) if not lines[k].startswith('|')),
               len(lines))
    return '\n'.join(lines[start:end])


def test_the_readme_topic_table_is_the_interface_rendered():
    rendered = markdown_table(NODE_INTERFACE)
    assert table_in(REPO_ROOT / 'README.md', rendered.splitlines()[0]) == rendered


def test_the_controller_topic_table_is_the_interface_rendered():
    rendered = markdown_table(CONTROLLER_INTERFACE)
    assert table_in(REPO_ROOT / 'docs' / 'closed-loop.md', rendered.splitlines()[0]) == (
        rendered)


def test_the_qos_table_of_the_node_page_is_the_profiles_rendered():
    rendered = qos_markdown_table()
    assert table_in(REPO_ROOT / 'docs' / 'node.md', rendered.splitlines()[0]) == rendered


def test_a_gyro_scene_has_the_gyro_inputs_the_mount_and_the_covariance_output():
    values = defaults()
    situation = Situation(gyro_scene(), values)
    assert names(NODE_INTERFACE.inputs(situation)) == [
        'imu', 'angular_velocity', 'set_pose', 'set_pose_with_covariance']
    assert names(NODE_INTERFACE.inputs(situation, ('transforms',))) == ['/tf_static']
    assert names(NODE_INTERFACE.outputs(situation)) == [
        'orientation', 'pose', 'pose_with_covariance', 'imu/data', '/diagnostics']
    values['covariance'] = False
    assert 'pose_with_covariance' not in names(NODE_INTERFACE.outputs(Situation(
        gyro_scene(), values)))
    assert 'imu/data' not in names(NODE_INTERFACE.outputs(Situation(
        gyro_scene(), defaults(), imu_input=False)))


def test_a_dynamics_scene_has_the_commands_its_propagator_takes_and_the_body_outputs():
    values = defaults() | {'publish_clock': True, 'publish_tf': True}
    scene = dynamics_scene({'imu': {'rate': 200.0, 'topic': 'sim/imu'}})
    situation = Situation(scene, values, frozenset({'torque'}))
    assert names(NODE_INTERFACE.inputs(situation)) == [
        'torque', 'set_pose', 'set_pose_with_covariance']
    assert names(NODE_INTERFACE.inputs(Situation(scene, values, frozenset({'rotor_torque'})),
                                       ('command',))) == ['rotor_torque']
    present = [(endpoint.direction, endpoint.topic(scene))
               for endpoint in NODE_INTERFACE.present(situation)]
    assert [name for direction, name in present if direction == 'out'] == [
        'orientation', 'pose', 'twist', 'odom', 'energy', 'angular_momentum', 'sim/imu',
        '/diagnostics', '/clock', '/tf', '/tf_static']
    assert ('service', '~/reset') in present
    quiet = Situation(dynamics_scene(), defaults(), frozenset({'torque'}))
    assert names(NODE_INTERFACE.outputs(quiet, ('clock', 'tf', 'tf_static',
                                                'simulated_sensor'))) == []


def test_every_input_type_leads_to_its_decoder_and_every_qos_name_exists():
    for endpoint in (*NODE_INTERFACE, *CONTROLLER_INTERFACE):
        assert endpoint.qos in QOS_PROFILES, endpoint.name
        assert endpoint.direction in ('in', 'out', 'service'), endpoint.name
    for endpoint in NODE_INTERFACE:
        if endpoint.direction == 'in' and endpoint.role != 'transforms':
            assert callable(decoder(endpoint.name)), endpoint.name
    for msgtype in (IMU, VECTOR3_STAMPED, TWIST_STAMPED):  # the replay's gyro topic
        assert callable(decoder('angular_velocity', msgtype))


def test_the_refused_names_are_every_topic_the_node_has_in_a_dynamics_scene():
    scene = dynamics_scene()
    situation = Situation(scene, defaults() | {'publish_clock': True, 'publish_tf': True},
                          frozenset({'torque', 'rotor_torque'}))
    own = {endpoint.name.lstrip('/') for endpoint in NODE_INTERFACE.present(situation)
           if endpoint.direction != 'service' and not endpoint.named_by}
    for name in sorted(own) + ['tf_static']:
        with pytest.raises(SceneError, match='sensors.imu.topic'):
            check_scene_topics(dynamics_scene({'imu': {'rate': 200.0, 'topic': name}}))


@pytest.mark.parametrize('topic', ['orientation', 'pose', 'twist', 'energy', 'angular_momentum',
                                   'diagnostics', 'clock', 'tf_static', 'torque', 'set_pose'])
def test_a_topic_of_the_node_is_one_error_naming_the_key(topic, tmp_path):
    with pytest.raises(SceneError) as raised:
        check_scene_topics(dynamics_scene({'imu': {'rate': 200.0, 'topic': topic}}))
    message = str(raised.value)
    assert 'sensors.imu.topic' in message and repr(topic) in message and '\n' not in message
    path = tmp_path / 'scene.yaml'
    path.write_text(f'rate_source: dynamics\nstep: 0.001\nbody: {{inertia: {{moments: '
                    f'[1.0, 2.0, 3.0]}}}}\nsensors: {{imu: {{rate: 200.0, topic: {topic}}}}}\n')
    with pytest.raises(SceneError, match='sensors.imu.topic'):
        load_node_scene(str(path))


@pytest.mark.parametrize('topic', ['imu', 'sim/imu', 'imu/data', 'twist_imu', 'sensors/twist'])
def test_other_names_are_taken(topic):
    scene = dynamics_scene({'imu': {'rate': 200.0, 'topic': topic}})
    check_scene_topics(scene)
    assert scene.imu.topic == topic


MAGNETOMETER = {'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5}


def test_each_simulated_sensor_is_an_output_on_the_topic_its_section_names():
    scene = dynamics_scene({'imu': {'rate': 200.0, 'frame_id': 'base_link'},
                            'magnetometer': {**MAGNETOMETER, 'topic': 'sim/mag',
                                             'frame_id': 'base_link'},
                            'star_tracker': {'rate': 5.0, 'frame_id': 'base_link'}})
    situation = Situation(scene, defaults(), frozenset({'torque'}))
    sensors = NODE_INTERFACE.outputs(situation, ('simulated_sensor',))
    assert [(e.topic(scene), e.type) for e in sensors] == [
        ('imu', IMU), ('sim/mag', MAGNETIC_FIELD), ('star_tracker', POSE_WITH_COVARIANCE_STAMPED)]
    # every frame is the body's: no mount to publish; one frame off the body: /tf_static
    assert names(NODE_INTERFACE.outputs(situation, ('tf_static',))) == []
    moved = dynamics_scene({'star_tracker': {'rate': 5.0, 'frame_id': 'st'}})
    assert names(NODE_INTERFACE.outputs(Situation(moved, defaults()), ('tf_static',))) == [
        '/tf_static']


@pytest.mark.parametrize('sensor, section', [('magnetometer', MAGNETOMETER),
                                             ('star_tracker', {'rate': 5.0})])
def test_a_magnetometer_or_star_tracker_on_a_topic_of_the_node_is_refused(sensor, section):
    with pytest.raises(SceneError, match=f"sensors.{sensor}.topic to be none of the node's own "
                                         f"topics .*, got 'twist'"):
        check_scene_topics(dynamics_scene({sensor: {**section, 'topic': 'twist'}}))
