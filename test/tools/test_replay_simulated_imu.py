"""The replay tool on a dynamics scene with simulated sensors: the samples a session ticked at
the same times gives (IMU, magnetometer, star tracker), written to the output bag with their
mounts on /tf_static; and imu_noise reads the IMU back from it (5 minutes of a static body;
the figures as in test/core/test_sensors_imu.py)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from rigid_body_attitude.bag import BagReader, write_bag
from rigid_body_attitude.core.attitude.quaternion import from_rpy
from rigid_body_attitude.msgs import (
    IMU, MAGNETIC_FIELD, POSE_WITH_COVARIANCE_STAMPED, TF_MESSAGE, decode_tf_message)
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.settings import load_node_scene
from rigid_body_attitude.tools import allan
from rigid_body_attitude.tools.replay import main

TICK_NS = 20_000_000


class Kept:
    """A sink keeping the simulated IMU's samples."""

    use_header_stamps = True

    def __init__(self):
        self.samples = []

    def sensor_wanted(self, topic):
        return True

    def simulated_sensor(self, topic, data):
        self.samples.append((topic, data))

    def __getattr__(self, name):
        return lambda *args: None


def scene_file(tmp_path, step, imu, omega, **others):
    path = tmp_path / 'sensed.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'sensed', 'rate_source': 'dynamics', 'step': step,
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': omega},
        'sensors': {'imu': {'frame_id': 'imu_link', 'topic': 'sim/imu', **imu}, **others}}))
    return str(path)


def replay(tmp_path, scene, seconds, *options):
    bag = tmp_path / 'in'
    write_bag(bag, stamps=[100.001, 100.001 + seconds],
              ground_truth=np.tile([1.0, 0.0, 0.0, 0.0], (2, 1)))
    out = tmp_path / 'out'
    assert main([str(bag), '-o', str(out), '--scene', scene, '--no-progress',
                 *options]) == 0
    return out


MAGNETOMETER = {'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5, 'inclination': 1.2,
                'frame_id': 'imu_link', 'mount_rpy': [0.0, 0.0, 1.0], 'seed': 6}
STAR_TRACKER = {'rate': 10.0, 'boresight': [0.0, 1.0, 0.0], 'seed': 7}


def test_the_replay_writes_the_samples_a_session_gives_at_the_same_ticks(tmp_path, capsys):
    scene = scene_file(tmp_path, 0.001, {'rate': 200.0, 'seed': 5, 'mount_rpy': [0, 0, 1.0]},
                       [0.3, 2.0, 0.1], magnetometer=MAGNETOMETER, star_tracker=STAR_TRACKER)
    out = replay(tmp_path, scene, 2.0)
    topics = {'sim/imu': IMU, 'imu/mag': MAGNETIC_FIELD,
              'star_tracker': POSE_WITH_COVARIANCE_STAMPED}
    with BagReader(out) as reader:
        assert {name: reader.topics[name] for name in topics} == topics
        assert 'imu' not in reader.topics
        written = [(topic, data) for topic, _, _, data in reader.messages(list(topics))]
        mounts = [(stamp, data) for _, stamp, _, data in reader.messages(['/tf_static'])]
    kept = Kept()
    session = DynamicsSession(load_node_scene(scene), defaults(), kept, lambda: 0,
                              lambda: 0.0)
    for tick_ns in range(100_020_000_000, 102_001_000_001, TICK_NS):  # the replay's ticks
        session.tick(tick_ns)
    counts = {name: sum(topic == name for topic, _ in written) for name in topics}
    assert counts == {'sim/imu': 396, 'imu/mag': 199, 'star_tracker': 20}  # to 102.000 s
    assert sorted(written) == sorted(kept.samples)
    assert [data for topic, data in written if topic == 'sim/imu'] == [
        data for topic, data in kept.samples if topic == 'sim/imu']
    # the mounts once, at the first message's time: the IMU and the magnetometer share a frame
    assert len(mounts) == 1 and mounts[0][0] == 100_001_000_000
    transforms = decode_tf_message(mounts[0][1])
    assert [(t.parent_frame, t.child_frame) for t in transforms] == [
        ('base_link', 'imu_link'), ('base_link', 'star_tracker_link')]
    assert transforms[0].rotation == pytest.approx(tuple(from_rpy([0.0, 0.0, 1.0])), abs=1e-15)
    assert transforms[1].rotation == pytest.approx((0.5 ** 0.5, -0.5 ** 0.5, 0.0, 0.0))


def test_imu_noise_reads_the_simulated_figures_back_from_the_replayed_bag(tmp_path, capsys):
    scene = scene_file(tmp_path, 0.01, {
        'rate': 100.0, 'seed': 1, 'gyroscope_noise_density': 2e-3,
        'gyroscope_random_walk': 2e-2, 'gyroscope_turn_on_bias': 0.01,
        'gyroscope_scale_stddev': 0.0, 'gyroscope_misalignment_stddev': 0.0}, [0.0, 0.0, 0.0])
    out = replay(tmp_path, scene, 300.0, '--publish-rate', '10')
    capsys.readouterr()
    recording = allan.read_recording(out, 'sim/imu')  # what imu_noise reads
    assert recording.rate == pytest.approx(100.0, rel=1e-9)
    fit = allan.fit_noise(allan.allan_curve(recording.gyro, recording.rate), 300.0)
    assert fit.white == pytest.approx(2e-3, rel=0.10)
    assert not fit.k_is_bound and fit.random_walk == pytest.approx(2e-2, rel=0.10)


def test_outputs_name_the_sensor_topics_the_scene_gives(tmp_path, capsys):
    scene = scene_file(tmp_path, 0.001, {'rate': 200.0, 'mount_rpy': [0, 0, 1.0]},
                       [0.3, 2.0, 0.1], magnetometer=MAGNETOMETER)
    out = replay(tmp_path, scene, 0.2, '--outputs', 'imu/mag,/tf_static')
    with BagReader(out) as reader:
        assert reader.topics == {'imu/mag': MAGNETIC_FIELD, '/tf_static': TF_MESSAGE}
        assert reader.message_counts == {'imu/mag': 19, '/tf_static': 1}
    bag = tmp_path / 'in'
    assert main([str(bag), '-o', str(tmp_path / 'out2'), '--scene', scene, '--no-progress',
                 '--outputs', 'imu/maggie']) == 1
    assert ("error: Unknown output topic 'imu/maggie'; valid choices: orientation, "
            in capsys.readouterr().err)
