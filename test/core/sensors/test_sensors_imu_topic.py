"""A simulated IMU's ``topic`` may not be one of the node's own topics (core/sensors/imu.py)."""

from __future__ import annotations

import pytest

from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.sensors import imu_spec
from rigid_body_attitude.core.sensors.imu import NODE_TOPICS
from rigid_body_attitude.session.settings import input_topics, output_topics


def dynamics_scene(sensors=None):
    return scene_from_mapping({'rate_source': 'dynamics', 'step': 0.001,
                               'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
                               'effects': ['commanded_torque'], 'sensors': sensors})


def test_the_refused_names_are_every_topic_the_node_has_in_a_dynamics_scene():
    scene = dynamics_scene()
    names = {*output_topics(scene), *input_topics(scene, frozenset({'torque', 'rotor_torque'})),
             '/clock', '/tf_static'}
    assert {name.lstrip('/') for name in names} <= set(NODE_TOPICS)


@pytest.mark.parametrize('topic', ['orientation', 'pose', 'twist', 'energy', 'angular_momentum',
                                   'diagnostics', 'clock', 'tf_static', 'torque', 'set_pose'])
def test_a_topic_of_the_node_is_one_error_naming_the_key(topic):
    with pytest.raises(SceneError) as raised:
        imu_spec({'rate': 200.0, 'topic': topic})
    message = str(raised.value)
    assert 'sensors.imu.topic' in message and repr(topic) in message and '\n' not in message
    with pytest.raises(SceneError, match='sensors.imu.topic'):
        dynamics_scene({'imu': {'rate': 200.0, 'topic': topic}})


@pytest.mark.parametrize('topic', ['imu', 'sim/imu', 'imu/data', 'twist_imu', 'sensors/twist'])
def test_other_names_are_taken(topic):
    assert imu_spec({'rate': 200.0, 'topic': topic}).topic == topic
    assert dynamics_scene({'imu': {'rate': 200.0, 'topic': topic}}).imu.topic == topic
