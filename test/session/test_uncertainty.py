"""The gyro session's attitude covariance: what goes to the sink, when, and what moves it.

The covariance's consistency (NEES, BROAD) is tested in test/core and test/tools; here: the
session feeds it every integrated step, hands it to the sink at each fold, starts it again on
reset, sets it from set_pose (with or without a covariance), refuses a bad one, reports the
1-sigma tilt and yaw and warns past ``tilt_stddev_warn``.
"""

import math

import numpy as np
import pytest
from conftest import BASE_NS, MS

from rigid_body_attitude.core.estimation.attitude_covariance import AttitudeCovariance
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel, initial_covariance
from rigid_body_attitude.core.attitude.quaternion import scalar_exp_step, scalar_step_rate
from rigid_body_attitude.session.levelling import FROM_GRAVITY, FROM_TIMEOUT, AlignmentResult
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.reports import LEVEL_WARN
from rigid_body_attitude.session.uncertainty import (
    BATCH_SIZE, FOLD_SECONDS, UNKNOWN_POSITION_VARIANCE, error_model_from, orientation_block,
    pose_covariance)

OMEGA = (0.3, -0.2, 1.0)


def feed(session, count, start_ns=BASE_NS, rate=OMEGA):
    for k in range(count):
        session.gyro(*divmod(start_ns + k * MS, 10**9), rate)


def pose_cov(block):
    full = np.zeros((6, 6))
    full[:3, :3] = np.eye(3)
    full[3:, 3:] = np.reshape(block, (3, 3))
    return tuple(full.reshape(36).tolist())


def is_spd(values, size):
    matrix = np.reshape(values, (size, size))
    return (np.all(np.isfinite(matrix)) and np.array_equal(matrix, matrix.T)
            and np.linalg.eigvalsh(matrix)[0] > 0.0)


def test_the_sink_gets_the_unlevelled_prior_then_one_covariance_per_fold(open_scene):
    session, sink = open_scene('strapdown')
    model = GyroErrorModel()
    prior = initial_covariance(model, None)[:3, :3]
    assert sink.covariances == [tuple(prior.reshape(9).tolist())]
    per_fold = round(FOLD_SECONDS / 1e-3)  # at 1 kHz the time bound comes first
    assert per_fold < BATCH_SIZE
    feed(session, 1 + 3 * per_fold)  # a baseline, then 3 folds of steps
    assert len(sink.covariances) == 4
    state = session.propagator.state
    grown = np.reshape(sink.covariances[-1], (3, 3))
    assert np.all(np.diag(grown) > np.diag(prior)) and is_spd(sink.covariances[-1], 3)
    assert state.time == pytest.approx(3 * per_fold * 1e-3)


def published_ages(session, sink, period_ns, count):
    """Feed ``count`` samples ``period_ns`` apart; after each, the stamp time [s] since the
    step the published covariance was folded at; and the number of folds."""
    state = session.propagator.state
    session.gyro(*divmod(BASE_NS, 10**9), OMEGA)  # the baseline: the prior is of its time
    folded_at, seen, ages = state.time, len(sink.covariances), []
    for k in range(1, count):
        session.gyro(*divmod(BASE_NS + k * period_ns, 10**9), OMEGA)
        if len(sink.covariances) != seen:
            folded_at, seen = state.time, len(sink.covariances)
        ages.append(state.time - folded_at)
    return ages, seen


@pytest.mark.parametrize('rate_hz, steps_per_fold', [
    (100, 5), (1000, 50), (20000, BATCH_SIZE)])
def test_the_published_covariance_is_never_older_than_the_fold_period(
        open_scene, rate_hz, steps_per_fold):
    session, sink = open_scene('strapdown', max_dt=1.0)
    before = len(sink.covariances)
    ages, folds = published_ages(session, sink, 10**9 // rate_hz, 1 + 4 * steps_per_fold)
    assert max(ages) < FOLD_SECONDS
    assert max(ages) == pytest.approx((steps_per_fold - 1) / rate_hz)
    assert folds - before == 4


def moving_rates(count):
    t = np.arange(count) * 1e-3
    return [tuple(row) for row in np.stack(
        [2.0 * np.sin(3.0 * t), 1.5 * np.cos(2.0 * t), 3.0 * np.sin(1.3 * t + 1.0)],
        axis=1).tolist()]


@pytest.mark.parametrize('integrator', ['exp_map', 'delta_single', 'rk4_quaternion'])
def test_the_session_feeds_the_core_exactly_the_steps_its_method_made(open_scene, integrator):
    """exp_map holds the previous sample's rate, delta_single the current one; any other
    method: the rate that makes the rotation it made (``log(q_before* ⊗ q_after)/dt``)."""
    session, sink = open_scene('strapdown', integrator=integrator)
    reference = AttitudeCovariance(GyroErrorModel(), window_seconds=None,
                                   batch_size=BATCH_SIZE)
    state = session.propagator.state
    rates = moving_rates(4 * BATCH_SIZE + 1)
    session.gyro(*divmod(BASE_NS, 10**9), rates[0])
    seen, folded = len(sink.covariances), []
    for k in range(1, len(rates)):
        q_before, time_before = state.attitude_tuple(), state.time
        session.gyro(*divmod(BASE_NS + k * MS, 10**9), rates[k])
        dt = state.time - time_before
        held = {'exp_map': rates[k - 1], 'delta_single': rates[k]}.get(
            integrator, scalar_step_rate(q_before, state.attitude_tuple(), dt))
        if integrator != 'rk4_quaternion':
            made = scalar_step_rate(q_before, state.attitude_tuple(), dt)
            assert np.allclose(made, held, rtol=1e-9, atol=1e-9)
        reference.add_sample(q_before, held, dt)
        if len(sink.covariances) != seen:
            seen = len(sink.covariances)
            folded.append(tuple(reference.attitude_covariance.reshape(9).tolist()))
    assert len(folded) > 4 and sink.covariances[-len(folded):] == folded


def test_the_step_rate_inverts_the_exp_step():
    q = (0.6, -0.3, 0.5, 0.548)
    for omega in [(0.3, -2.0, 1.0), (1e-9, 0.0, -2e-9), (0.0, 0.0, 0.0), (300.0, 10.0, 5.0)]:
        after = scalar_exp_step(q, omega, 1e-3)
        assert np.allclose(scalar_step_rate(q, after, 1e-3), omega, rtol=1e-9, atol=1e-12)
        flipped = tuple(-c for c in after)  # the same rotation: the shorter way round
        assert np.allclose(scalar_step_rate(q, flipped, 1e-3), omega, rtol=1e-9, atol=1e-12)


def test_reset_and_a_backward_jump_start_the_covariance_again(open_scene):
    session, sink = open_scene('strapdown')
    feed(session, 2 * BATCH_SIZE + 1)
    start = sink.covariances[0]
    assert sink.covariances[-1] != start
    session.reset()
    assert sink.covariances[-1] == start
    feed(session, 2 * BATCH_SIZE + 1)
    feed(session, 5, start_ns=BASE_NS - 10**10)  # back 10 s, confirmed: reset
    assert sink.covariances[-1] == start


def test_set_pose_resets_to_set_pose_stddev_or_takes_the_message_covariance(open_scene):
    session, sink = open_scene('strapdown', set_pose_stddev=0.02)
    feed(session, 10)
    session.set_pose('world', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert sink.covariances[-1] == tuple((np.eye(3) * 0.02 ** 2).reshape(9).tolist())
    block = (4e-4, 1e-5, 0.0, 1e-5, 9e-4, 0.0, 0.0, 0.0, 0.25)
    session.set_pose('world', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), pose_cov(block))
    assert sink.covariances[-1] == block
    assert session.poses_accepted == 2


@pytest.mark.parametrize('block, why', [
    ((1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), 'symmetric'),
    ((1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0), 'positive semi-definite'),
    ((math.nan,) + (0.0,) * 8, 'finite'),
    ((math.inf,) + (0.0,) * 8, 'finite'),
])
def test_a_bad_covariance_refuses_the_pose_and_is_counted(open_scene, block, why):
    session, sink = open_scene('strapdown')
    feed(session, 10)
    before = (session.propagator.state.attitude_tuple(), len(sink.covariances))
    session.set_pose('world', (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 0.0), pose_cov(block))
    assert (session.propagator.state.attitude_tuple(), len(sink.covariances)) == before
    assert session.rejection_counts()['invalid_covariance'] == 1
    assert why in sink.logs[-1][1]
    with pytest.raises(InputError):
        orientation_block((0.0,) * 35)


def aligned(window_seconds, at_rest, source):
    return AlignmentResult(attitude=(1.0, 0.0, 0.0, 0.0), gyro_bias=(0.0, 0.0, 0.0),
                           window_seconds=window_seconds, at_rest=at_rest, source=source,
                           status=source)


def test_levelling_starts_the_levelled_covariance(open_scene):
    session, sink = open_scene('strapdown')
    session.on_aligned(aligned(1.0, True, FROM_GRAVITY))
    expected = initial_covariance(GyroErrorModel(), 1.0)[:3, :3]
    assert sink.covariances[-1] == tuple(expected.reshape(9).tolist())
    session.on_aligned(aligned(1.0, False, FROM_TIMEOUT))
    assert sink.covariances[-1] == sink.covariances[0]


def test_diagnostics_show_tilt_and_yaw_and_warn_past_the_bound(open_scene, clocks):
    session, sink = open_scene('strapdown', set_pose_stddev=0.01, tilt_stddev_warn=0.02)
    feed(session, 10)
    clocks.monotonic = 1.0
    unlevelled = session.report()
    assert unlevelled.level == LEVEL_WARN and 'tilt_stddev_warn' in unlevelled.message
    assert dict(unlevelled.values)['tilt_stddev [deg]'] == '180.000'
    session.set_pose('world', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    clocks.monotonic = 2.0
    report = session.report()
    values = dict(report.values)
    assert report.level == 0 and report.message == 'propagating'
    assert values['tilt_stddev [deg]'] == values['yaw_stddev [deg]'] == \
        f'{math.degrees(0.01):.3f}'


def test_covariance_off_gives_no_uncertainty_and_no_covariance(open_scene):
    session, sink = open_scene('strapdown', covariance=False)
    feed(session, 200)
    assert session.uncertainty is None and sink.covariances == []
    assert 'tilt_stddev [deg]' not in dict(session.report().values)


def test_calibration_noise_overrides_the_parameters_and_bad_values_name_the_key():
    values = defaults() | {'gyroscope_noise_density': 1e-3}
    assert error_model_from(values).gyroscope_noise_density == 1e-3
    calibrated = error_model_from(values, {'gyroscope_noise_density': 2e-4,
                                           'gyroscope_random_walk': 3e-5, 'update_rate': 200})
    assert (calibrated.gyroscope_noise_density, calibrated.gyroscope_random_walk) == (2e-4, 3e-5)
    for bad in (-1.0, math.nan, 'x', True):
        with pytest.raises(InputError, match='gyroscope_random_walk'):
            error_model_from(values, {'gyroscope_random_walk': bad})


def test_the_pose_covariance_is_spd_with_the_position_unknown():
    block = (4e-4, 1e-5, 0.0, 1e-5, 9e-4, 0.0, 0.0, 0.0, 0.25)
    full = pose_covariance(block)
    assert is_spd(full, 6) and np.reshape(full, (6, 6))[3:, 3:].reshape(9).tolist() == list(block)
    assert np.diag(np.reshape(full, (6, 6)))[:3].tolist() == [UNKNOWN_POSITION_VARIANCE] * 3


def test_a_kalibr_imu_yaml_gives_the_session_its_gyro_noise(open_scene, tmp_path):
    path = tmp_path / 'imu.yaml'
    path.write_text('rostopic: /imu\nupdate_rate: 200.0\ngyroscope_noise_density: 2.0e-4\n'
                    'gyroscope_random_walk: 3.0e-5\naccelerometer_noise_density: 1.0e-3\n'
                    'accelerometer_random_walk: 1.0e-4\n')
    session, _ = open_scene('strapdown', calibration_file=str(path),
                            gyroscope_noise_density=1e-3, gyroscope_random_walk=1e-4)
    model = session.uncertainty.model
    assert (model.gyroscope_noise_density, model.gyroscope_random_walk) == (2e-4, 3e-5)
    plain = tmp_path / 'plain.yaml'
    plain.write_text('bias: [0.0, 0.0, 0.0]\n')
    session, _ = open_scene('strapdown', calibration_file=str(plain),
                            gyroscope_noise_density=1e-3)
    assert session.uncertainty.model.gyroscope_noise_density == 1e-3


def test_levelling_at_rest_starts_the_covariance_from_its_window(open_scene):
    session, sink = open_scene('strapdown', align_seconds=0.5)
    unlevelled = sink.covariances[-1]
    rng = np.random.default_rng(1)
    for k in range(2000):
        rate = tuple(rng.normal(0.0, 0.003, 3).tolist())
        accel = tuple((np.array([0.0, 0.0, 9.81]) + rng.normal(0.0, 0.03, 3)).tolist())
        session.gyro(*divmod(BASE_NS + k * MS, 10**9), rate, None, accel)
    assert session.alignment is not None and session.alignment.at_rest, session.alignment_text()
    expected = AttitudeCovariance(GyroErrorModel(),
                                  window_seconds=session.alignment.window_seconds,
                                  batch_size=BATCH_SIZE).folded_attitude_covariance
    levelled = np.reshape(sink.covariances[-1], (3, 3))
    assert sink.covariances[-1] != unlevelled
    assert levelled[0, 0] < 1e-3 and levelled[0, 0] == pytest.approx(expected[0, 0], rel=1e-3)


def test_a_pose_set_before_the_first_sample_keeps_its_covariance(open_scene):
    session, sink = open_scene('strapdown')
    block = (4e-4, 0.0, 0.0, 0.0, 9e-4, 0.0, 0.0, 0.0, 0.25)
    session.set_pose('world', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), pose_cov(block))
    feed(session, 2)  # no accelerometer: the integration starts from the pose at once
    assert session.alignment_done and sink.covariances[-1] == block


def level_at_rest(session, count, start=0, seed=1):
    rng = np.random.default_rng(seed)
    for k in range(start, start + count):
        rate = tuple(rng.normal(0.0, 0.003, 3).tolist())
        accel = tuple((np.array([0.0, 0.0, 9.81]) + rng.normal(0.0, 0.03, 3)).tolist())
        session.gyro(*divmod(BASE_NS + k * MS, 10**9), rate, None, accel)


@pytest.mark.parametrize('with_covariance', [True, False])
def test_a_pose_set_while_levelling_keeps_its_yaw_variance_when_levelling_completes(
        open_scene, with_covariance):
    session, sink = open_scene('strapdown', align_seconds=0.5, set_pose_stddev=0.03)
    level_at_rest(session, 100)
    assert not session.alignment_done
    block = (4e-4, 1e-5, 2e-5, 1e-5, 9e-4, 3e-5, 2e-5, 3e-5, 0.0025)
    session.set_pose('world', (0.9, 0.0, 0.0, 0.4359), (0.0, 0.0, 0.0),
                     pose_cov(block) if with_covariance else None)
    level_at_rest(session, 1900, start=100)
    assert session.alignment is not None and session.alignment.at_rest, session.alignment_text()
    window = session.alignment.window_seconds
    yaw_variance = block[8] if with_covariance else 0.03 ** 2
    model = GyroErrorModel()
    expected = initial_covariance(model, window, math.sqrt(yaw_variance))
    levelled = AttitudeCovariance(model, covariance=expected, batch_size=BATCH_SIZE)
    published = np.reshape(sink.covariances[-1], (3, 3))
    # folded since levelling: the yaw grew by the gyro noise only, the tilt is the levelling's
    assert published[2, 2] == pytest.approx(yaw_variance, rel=1e-3)
    assert published[0, 0] == pytest.approx(levelled.folded_attitude_covariance[0, 0], rel=1e-3)
    assert published[0, 0] < 1e-3 and published[0, 1] == pytest.approx(0.0, abs=1e-9)
    session.reset()  # forgets the pose: the heading and its variance are the defaults again
    level_at_rest(session, 2000, start=3000, seed=2)
    assert session.alignment is not None and session.alignment.at_rest
    assert np.reshape(sink.covariances[-1], (3, 3))[2, 2] == pytest.approx(
        model.initial_yaw_stddev ** 2, rel=1e-6)


#: Orientation blocks a hostile or careless peer sends on ``set_pose_with_covariance``: finite
#: but huge (symmetrising, an eigen-decomposition or the first fold would overflow), or above
#: the physical bound of pi^2 rad^2.
HOSTILE_BLOCKS = {
    'huge diagonal': (1e308, 0.0, 0.0, 0.0, 1e308, 0.0, 0.0, 0.0, 1e308),
    'huge rank one': (1e308,) * 9,
    'huge with opposite signs': (1e308, -1e308, 0.0, -1e308, 1e308, 0.0, 0.0, 0.0, 1.0),
    'huge yaw only': (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e300),
    'variance above pi^2': (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 10.0),
    'huge asymmetric': (1.0, 1e308, 0.0, -1e308, 1.0, 0.0, 0.0, 0.0, 1.0),
}


@pytest.mark.parametrize('name', sorted(HOSTILE_BLOCKS))
def test_a_huge_or_unphysical_covariance_is_refused_before_anything_changes(
        open_scene, clocks, name):
    """Refused as ``invalid_covariance`` (three times, one warning), the attitude and the
    covariance as they were, every covariance handed to the sink finite, no internal error;
    a valid pose afterwards is taken."""
    session, sink = open_scene('strapdown')
    feed(session, 10)
    before = (session.propagator.state.attitude_tuple(), len(sink.covariances))
    for _ in range(3):
        session.set_pose('world', (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                         pose_cov(HOSTILE_BLOCKS[name]))
        clocks.monotonic += 1.0
    assert (session.propagator.state.attitude_tuple(), len(sink.covariances)) == before
    counts = session.rejection_counts()
    assert (counts['invalid_covariance'], counts['internal_error'], session.poses_accepted) == (
        3, 0, 0)
    warnings = [text for level, text in sink.logs if 'invalid_covariance' in text]
    assert len(warnings) == 1 and warnings[0].startswith('set_pose rejected')
    feed(session, 3 * BATCH_SIZE, start_ns=BASE_NS + 10 * MS)
    session.set_pose('world', (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                     pose_cov((math.pi ** 2, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4)))
    feed(session, 3 * BATCH_SIZE, start_ns=BASE_NS + 10 * MS + 3 * BATCH_SIZE * MS)
    assert session.poses_accepted == 1 and session.rejection_counts()['internal_error'] == 0
    assert all(is_spd(values, 3) for values in sink.covariances)
    report = session.report()
    assert dict(report.values)['rejected invalid_covariance'] == '3'


def test_the_covariance_check_scales_before_symmetrising():
    """A symmetric block of the largest floats is checked without overflow; one barely
    asymmetric is symmetrised without overflow (and then refused by the bound)."""
    largest = np.finfo(np.float64).max
    for block in [(largest, 0.0, 0.0, 0.0, largest, 0.0, 0.0, 0.0, largest),
                  (largest, largest, 0.0, largest * (1 - 1e-12), largest, 0.0, 0.0, 0.0, 1.0)]:
        with pytest.raises(InputError, match=r'at most pi\^2'):
            orientation_block(pose_cov(block))
    tiny = (5e-324, 0.0, 0.0, 0.0, 5e-324, 0.0, 0.0, 0.0, 5e-324)  # subnormal: floored
    assert orientation_block(pose_cov(tiny)) == (1e-24, 0.0, 0.0, 0.0, 1e-24, 0.0, 0.0, 0.0,
                                                 1e-24)
