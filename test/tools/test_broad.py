"""Tests of rigid_body_attitude.tools.broad on the shipped BROAD trials (CC BY 4.0, docs/data.md).
"""

import math

import numpy as np
import pytest

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.tools import broad
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.attitude.quaternion import attitude_error, scalar_exp_step

TRIAL_07 = '07_undisturbed_fast_rotation_B'
TRIAL_15 = '15_undisturbed_fast_translation_A'


@pytest.fixture(scope='module')
def trials(data_dir):
    return {name: broad.load_trial(data_dir / f'{name}.npz') for name in (TRIAL_07, TRIAL_15)}


def test_load_trial_arrays_stamps_and_phases(trials, data_dir):
    trial = trials[TRIAL_07]
    raw = np.load(data_dir / f'{TRIAL_07}.npz')
    assert trial.name == TRIAL_07
    assert trial.sampling_rate == pytest.approx(2000.0 / 7.0, rel=1e-15)
    assert trial.sample_count == 52518
    assert np.array_equal(trial.gyro, raw['imu_gyr'])
    assert np.array_equal(trial.acc, raw['imu_acc'])
    assert np.array_equal(trial.ground_truth, raw['opt_quat_wxyz'], equal_nan=True)
    assert trial.stamps[0] == 0.0 and trial.stamps[7] == 7 / trial.sampling_rate
    assert np.allclose(np.diff(trial.stamps), 0.0035, rtol=0.0, atol=1e-12)
    # The motion mask switches on once (rest, motion, rest): index of its first True.
    assert trial.first_motion_index == 7573
    assert not trial.movement[7572] and trial.movement[7573]
    assert int(trial.ground_truth_lost.sum()) == 1594
    assert int(trials[TRIAL_15].ground_truth_lost.sum()) == 86
    assert 'BROAD' in trial.info
    with pytest.raises(ValueError, match='read-only'):
        trial.gyro[0, 0] = 1.0


@pytest.mark.parametrize('name', [TRIAL_07, TRIAL_15])
def test_rest_gyro_bias_agrees_with_final_rest_phase(trials, name):
    trial = trials[name]
    bias = trial.rest_gyro_bias()
    assert np.array_equal(bias, trial.gyro[:trial.first_motion_index].mean(axis=0))
    last_motion = trial.sample_count - int(np.argmax(trial.movement[::-1]))
    final_rest = trial.gyro[last_motion:].mean(axis=0)
    # The two rest phases (≥ 7500 and ≥ 10700 samples, σ ≈ 2e-3 rad/s, standard error 2e-5)
    # differ by ≤ 1e-4 rad/s (slow bias drift); 5e-4 allows that drift five times over.
    assert np.max(np.abs(bias - final_rest)) < 5e-4
    # Averaging over the motion too would be off by > 1.7e-2 rad/s (measured): the tolerance
    # separates a rest-only estimate from a contaminated one.
    assert np.max(np.abs(trial.gyro.mean(axis=0) - bias)) > 10 * 5e-4


@pytest.mark.parametrize('name, storage', [(TRIAL_07, 'sqlite3'), (TRIAL_15, 'mcap')])
def test_trial_to_bag_round_trip(trials, tmp_path, name, storage):
    trial = trials[name]
    path = tmp_path / name
    counts = broad.trial_to_bag(trial, path, storage=storage)
    kept = ~trial.ground_truth_lost
    assert counts == {'imu': trial.sample_count, 'ground_truth': int(kept.sum())}
    rates = bag.read_series(path, 'imu')
    assert np.array_equal(rates.values, trial.gyro)
    assert np.allclose(rates.stamps, trial.stamps, rtol=0.0, atol=1e-9)
    acceleration = bag.read_series(path, 'imu', decoder=msgs.imu_acceleration)
    assert np.array_equal(acceleration.values, trial.acc)
    truth = bag.read_series(path, 'ground_truth')
    assert np.array_equal(truth.values, trial.ground_truth[kept])
    assert np.array_equal(truth.bag_times_ns, rates.bag_times_ns[kept])
    with bag.BagReader(path) as reader:
        metadata = reader.custom_data
        assert reader.topics == {'ground_truth': msgs.QUATERNION_STAMPED, 'imu': msgs.IMU}
    assert metadata['citation'] == broad.CITATION and 'doi:10.3390/data6070072' in broad.CITATION
    assert metadata['license'].startswith('CC BY 4.0')
    assert metadata['broad_trial'] == name
    stored_bias = [float(value) for value in metadata['rest_gyro_bias_rad_s'].split()]
    assert stored_bias == trial.rest_gyro_bias().tolist()


def test_main_converts_a_trial_and_reports_errors(data_dir, tmp_path, capsys):
    out = tmp_path / 'converted'
    assert broad.main([str(data_dir / f'{TRIAL_15}.npz'), str(out), '--imu-topic', 'gyro']) == 0
    assert '86 lost samples skipped' in capsys.readouterr().out
    with bag.BagReader(out) as reader:
        assert reader.message_counts == {'gyro': 52556, 'ground_truth': 52470}
    assert broad.main([str(tmp_path / 'missing.npz'), str(tmp_path / 'x')]) == 1
    assert 'error: Expected a BROAD trial archive (.npz)' in capsys.readouterr().err
    assert broad.main([str(data_dir / f'{TRIAL_15}.npz'), str(out)]) == 1
    assert 'exists already' in capsys.readouterr().err


def _write_archive(path, **changes):
    count = 20
    arrays = dict(sampling_rate=np.float64(100.0), imu_gyr=np.zeros((count, 3)),
                  imu_acc=np.zeros((count, 3)), opt_quat_wxyz=np.tile([1.0, 0, 0, 0], (count, 1)),
                  movement=np.arange(count) >= 5, info=np.str_('synthetic'))
    arrays.update(changes)
    np.savez(path, **{key: value for key, value in arrays.items() if value is not None})
    return path


@pytest.mark.parametrize('changes, message', [
    (dict(movement=None), r"Expected key 'movement' in BROAD archive .*got keys"),
    (dict(imu_acc=np.zeros((19, 3))), r"'imu_acc' .* to have shape \(20, 3\), got \(19, 3\)"),
    (dict(imu_gyr=np.zeros((20, 4))), r"'imu_gyr' .* to have shape \(N, 3\), got \(20, 4\)"),
    (dict(sampling_rate=np.float64(0.0)), '`sampling_rate` .* to be positive'),
    (dict(imu_gyr=np.full((20, 3), np.nan)), "'imu_gyr' .* to be finite"),
    (dict(movement=np.ones(20)), '`movement` .* to be bool'),
    (dict(movement=np.ones(20, dtype=bool)), 'to start with a rest phase and contain motion'),
    (dict(movement=np.zeros(20, dtype=bool)), 'to start with a rest phase and contain motion'),
    (dict(opt_quat_wxyz=np.tile([2.0, 0, 0, 0], (20, 1))), 'to be unit quaternions'),
    (dict(opt_quat_wxyz=np.tile([1.0, 0, 0, np.nan], (20, 1))), 'finite or all NaN'),
])
def test_load_trial_rejects_malformed_archives(tmp_path, changes, message):
    path = _write_archive(tmp_path / 'trial.npz', **changes)
    with pytest.raises(InputError, match=message):
        broad.load_trial(path)


def test_load_trial_rejects_missing_and_non_archive_files(tmp_path):
    with pytest.raises(InputError, match='no such file'):
        broad.load_trial(tmp_path / 'absent.npz')
    (tmp_path / 'text.npz').write_text('not a zip archive')
    with pytest.raises(InputError, match='to be a NumPy .npz archive'):
        broad.load_trial(tmp_path / 'text.npz')


def _strapdown_max_error_deg(trial, rate_sample, coning=False, window_s=10.0):
    """Largest error of q_{k+1} = q_k ⊗ exp(v_k) over window_s after the first motion sample.

    v_k = h ω_k (rate_sample 'start') or h ω_{k+1} ('end'); with ``coning`` the trapezoid
    v_k = ½h(ω_k + ω_{k+1}) + (h²/12) ω_k × ω_{k+1}. Bias: the rest-phase estimate.
    """
    start = trial.first_motion_index
    steps = math.floor(window_s * trial.sampling_rate)
    h = 1.0 / trial.sampling_rate
    rates = trial.gyro - trial.rest_gyro_bias()
    if coning:
        increments = (0.5 * h * (rates[:-1] + rates[1:])
                      + h * h / 12.0 * np.cross(rates[:-1], rates[1:]))
    else:
        increments = h * (rates[:-1] if rate_sample == 'start' else rates[1:])
    attitude = tuple(trial.ground_truth[start])
    path = np.empty((steps, 4))
    for step, increment in enumerate(increments[start:start + steps].tolist()):
        attitude = scalar_exp_step(attitude, increment, 1.0)
        path[step] = attitude
    errors = attitude_error(path, trial.ground_truth[start + 1:start + steps + 1])
    return float(np.degrees(np.max(errors)))


def test_strapdown_errors_reproduce_the_issue_with_rate_at_interval_start(trials):
    first_order = {name: _strapdown_max_error_deg(trials[name], 'start') for name in trials}
    at_end = {name: _strapdown_max_error_deg(trials[name], 'end') for name in trials}
    trapezoid = {name: _strapdown_max_error_deg(trials[name], 'start', coning=True)
                 for name in trials}
    # Our figures (deterministic to round-off, pinned to the printed 1e-3 deg): see
    # studies/broad_strapdown.py.
    assert first_order[TRIAL_07] == pytest.approx(8.875, abs=1e-3)
    assert first_order[TRIAL_15] == pytest.approx(1.329, abs=1e-3)
    assert trapezoid[TRIAL_07] == pytest.approx(6.520, abs=1e-3)
    assert trapezoid[TRIAL_15] == pytest.approx(1.031, abs=1e-3)
    # The issue quotes about 9.2 / 1.3 deg (first order) and 6.9 / 1.0 deg (trapezoid). Trial
    # 07's figure depends on details of the set-up: starting 1-2 samples earlier or later moves
    # it by up to 0.25 deg, a median instead of a mean bias by 0.1 deg. 10 % covers that and
    # still separates the two sample conventions: ω_{k+1} gives 4.2 / 0.83 deg (> 35 % off).
    issue = {TRIAL_07: (9.2, 6.9), TRIAL_15: (1.3, 1.0)}
    for name, (issue_first_order, issue_trapezoid) in issue.items():
        assert first_order[name] == pytest.approx(issue_first_order, rel=0.10)
        assert trapezoid[name] == pytest.approx(issue_trapezoid, rel=0.10)
        assert at_end[name] != pytest.approx(issue_first_order, rel=0.35)
        assert trapezoid[name] < first_order[name]
