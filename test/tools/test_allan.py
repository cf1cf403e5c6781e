"""imu_noise (tools/allan.py): Allan fits recovering known noise, real bags, hostile inputs."""

from __future__ import annotations

import re

import numpy as np
import pytest
import yaml

from rigid_body_attitude.bag import write_bag
from rigid_body_attitude.core.estimation.calibration import load_calibration
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.tools import allan

import broad_coverage

RATE = 50.0
WHITE = 2e-3      # rad/s/√Hz
WALK = 2e-4       # rad/s²/√Hz


def synthetic(seconds: float, seed: int = 1, walk: float = WALK) -> np.ndarray:
    """White noise of density WHITE plus a random walk of density ``walk`` (n, 3)."""
    rng = np.random.default_rng(seed)
    count = int(seconds * RATE)
    white = rng.normal(size=(count, 3)) * WHITE * np.sqrt(RATE)
    return white + np.cumsum(rng.normal(size=(count, 3)) * walk / np.sqrt(RATE), axis=0)


def test_known_white_noise_and_random_walk_are_recovered():
    """N within 5 % (thousands of averages at its τ); K within 25 % (its +½ point lies near
    τ = 100-200 s, where 40 minutes hold only a dozen or two independent averages)."""
    duration = 2400.0
    fit = allan.fit_noise(allan.allan_curve(synthetic(duration), RATE), duration)
    assert fit.white == pytest.approx(WHITE, rel=0.05)
    assert not fit.k_is_bound
    assert fit.random_walk == pytest.approx(WALK, rel=0.25)


def test_a_short_recording_gives_a_random_walk_bound_not_a_value():
    duration = 60.0
    fit = allan.fit_noise(allan.allan_curve(synthetic(duration, walk=0.0), RATE), duration)
    assert fit.white == pytest.approx(WHITE, rel=0.1)
    assert fit.k_is_bound and fit.random_walk > 0.0


def test_a_bag_with_an_imu_topic_gives_imu_yaml_and_plot(tmp_path):
    samples = synthetic(120.0, seed=4, walk=0.0)
    stamps = 1.7e9 + np.arange(samples.shape[0]) / RATE
    gravity = np.tile([0.0, 0.0, 9.81], (samples.shape[0], 1)) + samples * 10.0
    write_bag(tmp_path / 'static', stamps=stamps, rates=samples, accelerations=gravity,
              imu_topic='imu/data_raw', ground_truth_topic=None, torque_topic=None)
    output, plot = tmp_path / 'imu.yaml', tmp_path / 'allan.png'
    assert allan.main([str(tmp_path / 'static'), '--output', str(output),
                       '--plot', str(plot)]) == 0
    written = yaml.safe_load(output.read_text())
    assert written['rostopic'] == '/imu/data_raw'
    assert written['update_rate'] == pytest.approx(RATE, rel=1e-6)
    assert written['gyroscope_noise_density'] == pytest.approx(WHITE, rel=0.1)
    assert written['accelerometer_noise_density'] == pytest.approx(10.0 * WHITE, rel=0.1)
    assert written['gyroscope_random_walk'] > 0.0
    assert plot.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_a_broad_trial_uses_its_rest_phase(tmp_path):
    path = next(p for p in broad_coverage.trial_paths() if p.stem.startswith('07'))
    output = tmp_path / 'imu.yaml'
    assert allan.main([str(path), '--output', str(output), '--plot',
                       str(tmp_path / 'allan.png')]) == 0
    written = yaml.safe_load(output.read_text())
    assert 5e-5 < written['gyroscope_noise_density'] < 5e-4
    assert written['update_rate'] == pytest.approx(285.714, rel=1e-4)


def run_error(argv: list[str], capsys) -> str:
    """Run main, expect exit code 2 and one ``error:`` line; return it."""
    assert allan.main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('error: '), lines
    return lines[0]


def test_a_missing_file_is_one_error_line(tmp_path, capsys):
    assert 'does not exist' in run_error([str(tmp_path / 'missing')], capsys)


def test_a_bag_without_imu_topic_is_one_error_line(tmp_path, capsys):
    stamps = np.arange(1000) / RATE
    write_bag(tmp_path / 'torques', stamps=stamps, torques=np.zeros((1000, 3)),
              ground_truth_topic=None, imu_topic=None)
    assert 'sensor_msgs/msg/Imu' in run_error([str(tmp_path / 'torques')], capsys)
    assert 'imu' in run_error([str(tmp_path / 'torques'), '--topic', 'imu'], capsys)


def test_a_too_short_recording_is_one_error_line(tmp_path, capsys):
    stamps = np.arange(100) / RATE
    write_bag(tmp_path / 'short', stamps=stamps, rates=np.zeros((100, 3)),
              ground_truth_topic=None, torque_topic=None)
    assert 'at least 10 s' in run_error([str(tmp_path / 'short')], capsys)


def test_a_file_that_is_not_a_recording_and_bad_options_are_one_error_line(tmp_path, capsys):
    junk = tmp_path / 'junk.npz'
    junk.write_bytes(b'not an archive')
    assert 'npz' in run_error([str(junk)], capsys)
    run_error(['--no-such-option'], capsys)
    trial = str(next(p for p in broad_coverage.trial_paths() if p.stem.startswith('07')))
    assert 'no' in run_error([trial, '--output', str(tmp_path / 'no' / 'dir.yaml')], capsys)


def static_bag(path, samples, rate=RATE):
    stamps = 1.7e9 + np.arange(samples.shape[0]) / rate
    write_bag(path, stamps=stamps, rates=samples, ground_truth_topic=None, torque_topic=None)
    return str(path)


def _with(samples, change):
    samples = samples.copy()
    change(samples)
    return samples


@pytest.mark.parametrize('name, change, why', [
    ('constant', lambda s: s.__setitem__(slice(None), 0.01), r'to vary: 100 % of its samples'),
    ('one axis stuck', lambda s: s.__setitem__((slice(None), 1), 0.0), r'y axis .* to vary'),
    ('one huge sample', lambda s: s.__setitem__((500, 2), 1e300), r'robust standard deviations'),
    ('one glitch of 35 rad/s', lambda s: s.__setitem__((500, 0), 35.0),
     r'x sample lies .* robust standard deviations'),
    ('saturated 5 %', lambda s: s.__setitem__((slice(0, None, 20), 0), 0.5),
     r'unsaturated gyroscope.*5 % of the x samples sit at 0\.5'),
])
def test_a_recording_no_estimate_can_come_from_is_refused_and_nothing_written(
        tmp_path, capsys, name, change, why):
    """One ``error:`` line saying why; neither imu.yaml nor the plot is written."""
    bag = static_bag(tmp_path / 'bag', _with(synthetic(60.0, walk=0.0), change))
    output, plot = tmp_path / 'imu.yaml', tmp_path / 'allan.png'
    line = run_error([bag, '--output', str(output), '--plot', str(plot)], capsys)
    assert re.search(why, line), line
    assert not output.exists() and not plot.exists()


def test_non_finite_samples_are_refused():
    """(The bag writer refuses them, so the check is called as ``read_recording`` calls it.)"""
    for bad in (np.nan, np.inf, -np.inf):
        samples = synthetic(20.0, walk=0.0)
        samples[7, 0] = bad
        with pytest.raises(InputError, match=r'finite gyroscope samples in here; 1 are NaN'):
            allan.check_static(samples, 'gyroscope', 'here')


def test_the_output_is_checked_by_the_nodes_calibration_checker():
    """A text the node would refuse (noise density 0, inf) is refused before writing; a
    written one loads as the node loads it."""
    good = ('rostopic: /imu\nupdate_rate: 50\ngyroscope_noise_density: 2.0e-03\n'
            'gyroscope_random_walk: 1.0e-04\n')
    allan.checked_yaml(good)
    for bad in (good.replace('2.0e-03', '0.0'), good.replace('1.0e-04', '.inf'),
                good.replace('gyroscope_random_walk: 1.0e-04\n', '')):
        with pytest.raises(InputError, match='the node would refuse'):
            allan.checked_yaml(bad)


def test_every_file_imu_noise_writes_is_one_the_node_loads(tmp_path):
    bag = static_bag(tmp_path / 'bag', synthetic(60.0, seed=3))
    output = tmp_path / 'imu.yaml'
    assert allan.main([bag, '--output', str(output), '--plot', str(tmp_path / 'a.png')]) == 0
    calibration = load_calibration(output)
    assert calibration.kind == 'kalibr_noise'
    assert calibration.noise.gyroscope_noise_density == pytest.approx(WHITE, rel=0.1)
