"""Rest detection (thresholds from the measured noise, taps refused) and bias at rest."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.rest import RestBiasEstimator, RestDetector
from rigid_body_attitude.tools.broad import load_trial

RATE_HZ = 200.0
DT = 1.0 / RATE_HZ
G = 9.80665
TAPPING = '24_disturbed_tapping_A'


def _rest_samples(count: int, rng: np.random.Generator, gyro_sigma: float = 2e-3,
                  acc_sigma: float = 0.03, bias=(0.004, -0.002, 0.001),
                  up=(0.0, 0.0, G)) -> tuple[np.ndarray, np.ndarray]:
    gyro = np.asarray(bias) + gyro_sigma * rng.standard_normal((count, 3))
    acc = np.asarray(up) + acc_sigma * rng.standard_normal((count, 3))
    return gyro, acc


def _feed(detector: RestDetector, gyro: np.ndarray, acc: np.ndarray) -> np.ndarray:
    flags = np.zeros(len(gyro), dtype=bool)
    for k, (w, a) in enumerate(zip(gyro.tolist(), acc.tolist())):
        flags[k] = detector.update(*w, *a, DT)
    return flags


def test_update_reports_rest_once_the_window_is_full():
    detector = RestDetector(window_seconds=0.25)
    flags = _feed(detector, *_rest_samples(400, np.random.default_rng(1)))
    full = int(math.ceil(0.25 * RATE_HZ))
    assert not flags[:full - 1].any()
    assert flags[full + 5:].mean() > 0.95
    assert detector.at_rest and detector.reason() == ''


@pytest.mark.parametrize('sigma', [5e-4, 5e-3])
def test_gyro_threshold_follows_the_measured_noise(sigma):
    detector = RestDetector()
    _feed(detector, *_rest_samples(1000, np.random.default_rng(2), gyro_sigma=sigma))
    # Total spread of white noise σ per axis is √3 σ; the threshold is twice the quietest
    # window's, which is within a few tens of per cent of √3 σ.
    assert 2.0 * math.sqrt(3.0) * sigma * 0.7 < detector.gyro_threshold
    assert detector.gyro_threshold < 2.0 * math.sqrt(3.0) * sigma * 1.05


def test_update_refuses_motion_and_a_slow_steady_turn():
    rng = np.random.default_rng(4)
    detector = RestDetector()
    _feed(detector, *_rest_samples(400, rng))
    assert detector.at_rest
    gyro, acc = _rest_samples(200, rng)
    gyro[:, 2] += 0.08 * np.sin(np.linspace(0.0, 6.0, 200))  # a wobble of 0.08 rad/s
    flags = _feed(detector, gyro, acc)
    assert not flags[20:].any()
    gyro, acc = _rest_samples(400, rng)
    gyro[:, 2] += 0.1  # a steady turn: quiet gyro, non-zero mean
    flags = _feed(detector, gyro, acc)
    assert not flags[60:].any()
    assert 'gyro' in detector.reason() and 'threshold 0.05' in detector.reason()


def test_update_refuses_a_tap_and_the_window_after_it():
    rng = np.random.default_rng(5)
    detector = RestDetector(window_seconds=0.25)
    gyro, acc = _rest_samples(600, rng)
    acc[300:303] += [5.0, -20.0, 40.0]  # a tap: three samples of a large specific force
    flags = _feed(detector, gyro, acc)
    assert flags[250:300].all()
    assert not flags[300:300 + int(0.25 * RATE_HZ)].any()
    assert flags[300 + int(0.25 * RATE_HZ) + 2:].all()


def test_update_refuses_a_free_fall_or_missing_accelerometer():
    detector = RestDetector()
    gyro, acc = _rest_samples(300, np.random.default_rng(6), up=(0.0, 0.0, 0.0))
    assert not _feed(detector, gyro, acc).any()
    assert 'is not gravity' in detector.reason()


def test_rest_detector_refuses_bad_arguments():
    with pytest.raises(InputError, match='window_seconds'):
        RestDetector(window_seconds=0.0)
    with pytest.raises(InputError, match='noise_factor'):
        RestDetector(noise_factor=math.nan)


def _taps(trial) -> np.ndarray:
    """Samples whose specific force is more than 3 m/s² away from gravity during motion."""
    magnitude = np.linalg.norm(trial.acc, axis=1)
    return np.flatnonzero(trial.movement & (np.abs(magnitude - 9.81) > 3.0))


def test_update_never_takes_the_taps_of_trial_24_for_rest(data_dir):
    trial = load_trial(data_dir / f'{TAPPING}.npz')
    detector = RestDetector()
    dt = 1.0 / trial.sampling_rate
    flags = np.zeros(trial.sample_count, dtype=bool)
    for k, (w, a) in enumerate(zip(trial.gyro.tolist(), trial.acc.tolist())):
        flags[k] = detector.update(*w, *a, dt)
    taps = _taps(trial)
    assert taps.size > 100
    window = int(detector.window_seconds * trial.sampling_rate)
    after_taps = np.unique(np.concatenate([taps + lag for lag in range(window)]))
    assert not flags[after_taps[after_taps < trial.sample_count]].any()
    assert flags[trial.movement].mean() < 1e-3
    assert flags[:trial.first_motion_index].mean() > 0.95


def _tap_events(trial, taps: np.ndarray) -> list[np.ndarray]:
    """The tap samples grouped into events (gaps over 0.2 s), each ±3 samples around its peak."""
    gap = int(0.2 * trial.sampling_rate)
    events = np.split(taps, np.flatnonzero(np.diff(taps) > gap) + 1)
    magnitude = np.linalg.norm(trial.acc, axis=1)
    peaks = [int(event[np.argmax(magnitude[event])]) for event in events]
    return [np.arange(peak - 3, peak + 4) for peak in peaks]


def test_update_refuses_trial_24_taps_on_a_body_at_rest(data_dir):
    """The taps' specific force added to the trial's initial rest, one every 150 samples."""
    trial = load_trial(data_dir / f'{TAPPING}.npz')
    rest_count = trial.first_motion_index
    events = _tap_events(trial, _taps(trial))
    assert len(events) > 20
    gyro, acc = trial.gyro[:rest_count].copy(), trial.acc[:rest_count].copy()
    local_gravity = np.median(trial.acc[trial.movement], axis=0)
    starts = 1000 + 150 * np.arange(len(events))
    assert starts[-1] + 150 < rest_count
    for start, event in zip(starts, events):
        acc[start:start + 7] += trial.acc[event] - local_gravity
    detector = RestDetector()
    dt = 1.0 / trial.sampling_rate
    flags = np.array([detector.update(*w, *a, dt) for w, a in zip(gyro.tolist(), acc.tolist())])
    window = int(detector.window_seconds * trial.sampling_rate)
    for start in starts:
        assert not flags[start:start + 7 + window].any(), start
        assert flags[start + 7 + window + 5:start + 150].mean() > 0.9, start
    assert flags[window + 1:starts[0]].mean() > 0.95


def test_bias_estimator_converges_on_rest_and_ignores_motion():
    rng = np.random.default_rng(7)
    bias = np.array([0.01, -0.02, 0.005])
    detector = RestDetector()
    detector.set_gyro_bias((0.0, 0.0, 0.0))
    estimator = RestBiasEstimator((0.0, 0.0, 0.0), initial_seconds=0.0, time_constant=60.0)
    errors = []
    for segment in range(6):
        gyro, acc = _rest_samples(int(10 * RATE_HZ), rng, bias=tuple(bias))
        if segment % 2:  # motion: 1 rad/s oscillation about x, tilting the specific force
            t = np.arange(len(gyro)) * DT
            gyro[:, 0] += np.sin(t)
            angle = 1.0 - np.cos(t)
            acc[:, 1] = G * np.sin(angle) + 0.03 * rng.standard_normal(len(t))
            acc[:, 2] = G * np.cos(angle) + 0.03 * rng.standard_normal(len(t))
        for w, a in zip(gyro.tolist(), acc.tolist()):
            if detector.update(*w, *a, DT):
                estimator.update(True, detector.delayed_gyro, DT)
                detector.set_gyro_bias(estimator.bias)
        errors.append(float(np.linalg.norm(np.asarray(estimator.bias) - bias)))
    # 30 s of rest at σ = 2e-3 rad/s and 200 Hz: standard error 2e-3/√6000 = 2.6e-5 per axis.
    assert errors[-1] < 1.5e-4
    assert errors[-1] < errors[0]
    # Motion segments (1, 3, 5) did not move the estimate by more than the noise.
    assert abs(errors[1] - errors[0]) < 1.5e-4
    assert 29.0 < estimator.rest_seconds < 30.0


def test_bias_estimator_is_a_running_mean_then_an_exponential_one():
    estimator = RestBiasEstimator((1.0, 1.0, 1.0), initial_seconds=1.0, time_constant=4.0)
    estimator.update(True, (3.0, 3.0, 3.0), 1.0)  # two seconds of rest: mean of 1 and 3
    assert estimator.bias == pytest.approx((2.0, 2.0, 2.0))
    estimator.update(False, (100.0, 100.0, 100.0), 1.0)  # not at rest: ignored
    assert estimator.bias == pytest.approx((2.0, 2.0, 2.0))
    estimator.update(True, (5.0, 5.0, 5.0), 1.0)  # mean of 1, 3, 5
    assert estimator.bias == pytest.approx((3.0, 3.0, 3.0))
    estimator.update(True, (7.0, 7.0, 7.0), 1.0)
    estimator.update(True, (7.0, 7.0, 7.0), 1.0)  # past τ = 4 s: gain 1/4
    assert estimator.bias[0] == pytest.approx(4.0 + 0.25 * (7.0 - 4.0))
