"""The replay tool on a dynamics scene with a simulated IMU: the samples a session ticked at
the same times gives, written to the output bag; and imu_noise reads them back from it (5
minutes of a static body; the figures as in test/core/test_sensors_imu.py)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from rigid_body_attitude.bag import BagReader, write_bag
from rigid_body_attitude.msgs import IMU
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


def scene_file(tmp_path, step, imu, omega):
    path = tmp_path / 'sensed.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'sensed', 'rate_source': 'dynamics', 'step': step,
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': omega},
        'sensors': {'imu': {'frame_id': 'imu_link', 'topic': 'sim/imu', **imu}}}))
    return str(path)


def replay(tmp_path, scene, seconds, *options):
    bag = tmp_path / 'in'
    write_bag(bag, stamps=[100.001, 100.001 + seconds],
              ground_truth=np.tile([1.0, 0.0, 0.0, 0.0], (2, 1)))
    out = tmp_path / 'out'
    assert main([str(bag), '-o', str(out), '--scene', scene, '--no-progress',
                 *options]) == 0
    return out


def test_the_replay_writes_the_samples_a_session_gives_at_the_same_ticks(tmp_path, capsys):
    scene = scene_file(tmp_path, 0.001, {'rate': 200.0, 'seed': 5}, [0.3, 2.0, 0.1])
    out = replay(tmp_path, scene, 2.0)
    with BagReader(out) as reader:
        assert reader.topics['sim/imu'] == IMU
        written = [data for _, _, _, data in reader.messages(['sim/imu'])]
    kept = Kept()
    session = DynamicsSession(load_node_scene(scene), defaults(), kept, lambda: 0,
                              lambda: 0.0)
    for tick_ns in range(100_020_000_000, 102_001_000_001, TICK_NS):  # the replay's ticks
        session.tick(tick_ns)
    assert len(written) == len(kept.samples) == 396  # 100.025 s to 102.000 s
    assert written == [data for _, data in kept.samples]


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
