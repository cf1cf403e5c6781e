"""The scene's ``sensors:`` section as a whole (core/sensors/suite.py) and what the sensor
sections share (core/sensors/section.py)."""

from pathlib import Path
import re

import numpy as np
import pytest
import yaml

from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.sensors import sensors_section
from rigid_body_attitude.core.sensors.section import NormalRows

MAGNETOMETER = {'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5, 'inclination': 1.2}


def test_a_scene_carries_all_three_sensors_and_a_sun():
    scene = scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001,
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'sun': {'direction': [1, 0, 0]},
        'sensors': {'imu': {'rate': 200.0}, 'magnetometer': MAGNETOMETER,
                    'star_tracker': {'rate': 5.0, 'sun_exclusion_angle': 0.5}}})
    assert [key for key, _ in scene.sensors.items()] == ['imu', 'magnetometer', 'star_tracker']
    rates = scene.imu.rate, scene.magnetometer.rate, scene.star_tracker.rate
    assert rates == (200.0, 100.0, 5.0)
    assert scene.with_overrides(step=0.0005).star_tracker.rate == 5.0


def test_two_sensors_on_one_topic_are_refused():
    with pytest.raises(SceneError, match="sensors.star_tracker.topic to differ from "
                                         "sensors.magnetometer.topic, got 'att' for both"):
        sensors_section({'magnetometer': {**MAGNETOMETER, 'topic': 'att'},
                         'star_tracker': {'rate': 5.0, 'topic': 'att'}})


def test_one_frame_has_one_mount():
    """A magnetometer inside the IMU (imu_tools reads both in one frame) shares its frame and
    mount; the same frame with another mount would put two transforms on /tf_static."""
    shared = sensors_section({'imu': {'rate': 200.0, 'mount_rpy': [0, 0, 1.0]},
                              'magnetometer': {**MAGNETOMETER, 'frame_id': 'imu_link',
                                               'mount_rpy': [0, 0, 1.0]}})
    assert shared.magnetometer.frame_id == shared.imu.frame_id
    with pytest.raises(SceneError, match="sensors.star_tracker and sensors.imu name the same "
                                         "frame_id 'imu_link' with different mounts"):
        sensors_section({'imu': {'rate': 200.0},
                         'star_tracker': {'rate': 5.0, 'frame_id': 'imu_link',
                                          'boresight': [1, 0, 0]}})
    same = sensors_section({'imu': {'rate': 200.0, 'mount_rpy': [0, 1.5707963267948966, 0]},
                            'star_tracker': {'rate': 5.0, 'frame_id': 'imu_link',
                                             'boresight': [1, 0, 0]}})
    assert same.star_tracker.frame_id == 'imu_link'


@pytest.mark.parametrize('block', [1, 3, 1024])
def test_normal_rows_are_the_generators_normals_in_order_whatever_the_block(block):
    rows = NormalRows(np.random.default_rng(8), 4, block)
    drawn = [rows.next() for _ in range(700)]
    expected = np.random.default_rng(8).standard_normal((700, 4))
    assert np.array_equal(np.array(drawn), expected)


def documented_sections():
    """The YAML examples of docs/scenes.md that hold a ``sensors`` section."""
    text = (Path(__file__).resolve().parents[3] / 'docs' / 'scenes.md').read_text()
    blocks = [yaml.safe_load(block) for block in re.findall(r'```yaml\n(.*?)```', text, re.S)]
    return [block for block in blocks if isinstance(block, dict) and 'sensors' in block]


def test_the_documented_sections_load_as_written():
    sections = documented_sections()
    assert {key for block in sections for key in block['sensors']} == {
        'imu', 'magnetometer', 'star_tracker'}
    for block in sections:
        scene = scene_from_mapping({'rate_source': 'dynamics', 'step': 0.001,
                                    'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}}, **block})
        assert list(scene.sensors.items())
