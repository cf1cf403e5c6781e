"""The attitude filter on simulated IMU data with a known truth (closed-form motions)."""

import dataclasses
import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.estimator import AttitudeEstimator
from rigid_body_attitude.core.estimation.estimator_settings import EstimatorSettings
from rigid_body_attitude.core.estimation.estimator_start import start_estimator
from rigid_body_attitude.core.estimation.gravity_free import gravity_free_acceleration
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel
from rigid_body_attitude.core.estimation.magnetometer import MagnetometerCalibration

RATE = 100.0
DT = 1.0 / RATE
GRAVITY = 9.81
FIELD_WORLD = np.array([0.0, 18e-6, -45e-6])  # ENU: north and down, dip 68 deg
MODEL = GyroErrorModel(gyroscope_noise_density=2e-4, accelerometer_noise_density=2e-3,
                       accelerometer_bias_stddev=0.02, gyroscope_scale_stddev=0.002,
                       gyroscope_misalignment_stddev=0.002, gyroscope_random_walk=1e-5)
SETTINGS = EstimatorSettings(magnetometer_noise_density=5e-8)


def rates(t):
    """A generic body rate [rad/s]: several axes, a few tenths of rad/s."""
    return np.array([0.4 * math.sin(0.7 * t), 0.3 * math.cos(0.5 * t),
                     0.5 * math.sin(0.3 * t + 1.0)])


def simulate(seconds, rate_of, acceleration_of=None, bias=(0.0, 0.0, 0.0), seed=1,
             field_of=None, accel_bias=(0.0, 0.0, 0.0)):
    """Truth attitudes (n, 4) and noisy gyro (n, 3), specific force (n, 3) with
    ``accel_bias``, field (n, 3)."""
    rng = np.random.default_rng(seed)
    count = int(seconds * RATE)
    q = (1.0, 0.0, 0.0, 0.0)
    truth, gyro, accel, field = [], [], [], []
    sigma_g = MODEL.gyroscope_noise_density * math.sqrt(RATE)
    sigma_a = MODEL.accelerometer_noise_density * math.sqrt(RATE)
    sigma_m = SETTINGS.magnetometer_noise_density * math.sqrt(RATE)
    for k in range(count):
        t = k * DT
        omega = rate_of(t)
        q = quaternion.scalar_exp_step(q, omega, DT)
        truth.append(q)
        gyro.append(omega + np.array(bias) + rng.normal(0.0, sigma_g, 3))
        world_force = np.array([0.0, 0.0, GRAVITY])
        if acceleration_of is not None:
            world_force = world_force + acceleration_of(t)
        accel.append(quaternion.rotate_inverse(q, world_force) + np.array(accel_bias)
                     + rng.normal(0.0, sigma_a, 3))
        world_field = FIELD_WORLD if field_of is None else field_of(t)
        field.append(quaternion.rotate_inverse(q, world_field) + rng.normal(0.0, sigma_m, 3))
    return np.array(truth), np.array(gyro), np.array(accel), np.array(field)


def started(q_start, settings=SETTINGS, magnetometer=True, field_body=None):
    """An estimator started at ``q_start`` (levelled over 1 s, as a session does)."""
    estimator = AttitudeEstimator(MODEL, settings, 'enu', sample_rate=RATE)
    if field_body is None:
        field_body = quaternion.rotate_inverse(np.array(q_start), FIELD_WORLD)
    q = start_estimator(estimator, tuple(q_start), (0.0, 0.0, 0.0), 1.0, GRAVITY,
                        field_body if magnetometer else None, 100)
    return estimator, q


def run(estimator, q, gyro, accel, field=None):
    """The session's per-sample calls; the estimates (n, 4) and covariances (n, 3, 3)."""
    estimates, covariances = [], []
    for k in range(gyro.shape[0]):
        b = estimator.gyro_bias
        rate = (gyro[k, 0] - b[0], gyro[k, 1] - b[1], gyro[k, 2] - b[2])
        q_after = quaternion.scalar_exp_step(q, rate, DT)
        due = estimator.sample(q, rate, DT, q_after, tuple(accel[k]))
        if field is not None:
            estimator.magnetic_field(q_after, tuple(field[k]))
        q = estimator.update(q_after) if due else q_after
        estimates.append(q)
        covariances.append(estimator.covariance.attitude)
    return np.array(estimates), np.array(covariances)


def world_errors(truth, estimates):
    """``δθ`` (n, 3) with ``q_true = exp(δθ) ⊗ q_est`` [rad]."""
    return quaternion.log(quaternion.multiply(truth, quaternion.conjugate(estimates)))


def test_tilt_converges_from_a_wrong_start():
    truth, gyro, accel, field = simulate(20.0, lambda t: np.zeros(3))
    wrong = quaternion.exp(np.radians([4.0, -3.0, 0.0]))
    estimator, q = started(wrong, magnetometer=False)
    estimator.covariance.p[:2, :2] = np.eye(2) * math.radians(10.0) ** 2
    estimates, _ = run(estimator, q, gyro, accel)
    tilt = np.degrees(np.linalg.norm(world_errors(truth, estimates)[:, :2], axis=1))
    assert tilt[0] > 4.0
    assert tilt[-1] < 0.1


def test_magnetic_disturbance_never_tilts():
    def disturbed(t):  # a magnet passing: 40 µT along a tilted direction for 10 s
        return FIELD_WORLD + (np.array([30e-6, 0.0, 25e-6]) if 10.0 < t < 20.0 else 0.0)
    truth, gyro, accel, field = simulate(30.0, rates, seed=3, field_of=disturbed)
    _, _, _, clean = simulate(30.0, rates, seed=3)
    tilts = []
    for magnetic in (field, clean):
        estimator, q = started(truth[0])
        estimates, _ = run(estimator, q, gyro, accel, magnetic)
        tilts.append(np.linalg.norm(world_errors(truth, estimates)[:, :2], axis=1))
    assert np.degrees(np.abs(tilts[0] - tilts[1]).max()) < 0.05
    assert np.degrees(tilts[0].max()) < 0.5


def test_accepted_disturbance_turns_heading_only():
    """A field turned by 5° about a horizontal axis (dip changed within the tolerance) is
    accepted, and the tilt stays where gravity puts it."""
    turned = quaternion.rotate(quaternion.exp(np.radians([5.0, 0.0, 0.0])), FIELD_WORLD)
    truth, gyro, accel, field = simulate(20.0, rates, seed=4, field_of=lambda t: turned)
    estimator, q = started(truth[0])
    estimates, _ = run(estimator, q, gyro, accel, field)
    assert estimator.counts['magnetometer'] > 100
    tilt = np.linalg.norm(world_errors(truth, estimates)[:, :2], axis=1)
    assert np.degrees(tilt.max()) < 0.5


def test_translation_does_not_tilt():
    def shaking(t):  # 3 m/s² back and forth along east at 0.5 Hz, 2 m/s² along north: the
        # velocity (3/π sin πt, 2.5 sin 0.8t) swings about zero, the body stays within 1-3 m
        return np.array([3.0 * math.cos(math.pi * t), 2.0 * math.cos(0.8 * t), 0.0])
    truth, gyro, accel, field = simulate(60.0, lambda t: 0.2 * rates(t), shaking, seed=5)
    estimator, q = started(truth[0], magnetometer=False)
    estimates, _ = run(estimator, q, gyro, accel)
    tilt = np.degrees(np.linalg.norm(world_errors(truth, estimates)[:, :2], axis=1))
    assert tilt.max() < 1.5  # the specific force alone would tilt by up to 17 deg


def test_gyro_bias_converges_at_rest():
    bias = (0.01, -0.02, 0.015)
    truth, gyro, accel, field = simulate(10.0, lambda t: np.zeros(3), bias=bias, seed=6)
    estimator, q = started(truth[0])
    estimator.covariance.p[3:6, 3:6] = np.eye(3) * 0.03 ** 2
    run(estimator, q, gyro, accel, field)
    assert estimator.counts['zero_rate'] > 100
    assert np.abs(np.array(estimator.gyro_bias) - bias).max() < 2e-4


def test_gyro_bias_converges_in_motion():
    bias = (0.004, -0.003, 0.005)
    truth, gyro, accel, field = simulate(60.0, rates, bias=bias, seed=7)
    estimator, q = started(truth[0])
    estimator.covariance.p[3:6, 3:6] = np.eye(3) * 0.01 ** 2
    run(estimator, q, gyro, accel, field)
    assert estimator.counts['zero_rate'] == 0
    assert np.abs(np.array(estimator.gyro_bias) - bias).max() < 1e-3


def disturbance_process(seconds, seed):
    """The heading disturbance the filter models: a first-order Markov angle [rad] of 1σ
    ``magnetic_disturbance_stddev`` and time ``magnetic_disturbance_time``, as a field."""
    rng = np.random.default_rng(seed)
    decay = math.exp(-DT / SETTINGS.magnetic_disturbance_time)
    sigma = SETTINGS.magnetic_disturbance_stddev
    angles = [rng.normal(0.0, sigma)]
    for _ in range(int(seconds * RATE)):
        angles.append(decay * angles[-1] + rng.normal(0.0, sigma * math.sqrt(1 - decay ** 2)))
    return lambda t: quaternion.rotate(quaternion.exp([0.0, 0.0, angles[int(t * RATE)]]),
                                       FIELD_WORLD)


def test_nees_in_band_over_a_long_run():
    """The errors the model describes (white noise, a bias, an accelerometer bias drawn
    from its prior, a heading disturbance drawn from its process) stay inside the bounds."""
    accel_bias = np.random.default_rng(11).normal(0.0, MODEL.accelerometer_bias_stddev, 3)
    truth, gyro, accel, field = simulate(120.0, rates, bias=(0.002, -0.001, 0.0015), seed=8,
                                         field_of=disturbance_process(120.0, 12),
                                         accel_bias=accel_bias)
    estimator, q = started(truth[0])
    estimator.covariance.p[3:6, 3:6] = np.eye(3) * 0.005 ** 2
    estimates, covariances = run(estimator, q, gyro, accel, field)
    errors = world_errors(truth, estimates)[500:]
    nees = np.einsum('ni,nij,nj->n', errors, np.linalg.inv(covariances[500:]), errors)
    assert np.mean(nees <= 11.345) >= 0.93
    assert 0.3 < np.mean(nees) / 3.0 < 3.0


def test_without_magnetometer_the_heading_stays_unknown():
    truth, gyro, accel, _ = simulate(10.0, rates, seed=9)
    estimator, q = started(truth[0], magnetometer=False)
    run(estimator, q, gyro, accel)
    assert math.sqrt(estimator.covariance.attitude[2, 2]) > 3.0


def test_magnetic_start_finds_north():
    levelled = quaternion.exp(np.radians([3.0, -2.0, 0.0]))
    q_true = quaternion.multiply(quaternion.exp(np.radians([0.0, 0.0, 70.0])), levelled)
    field_body = quaternion.rotate_inverse(q_true, FIELD_WORLD)
    estimator, q = started(levelled, field_body=field_body)
    assert math.degrees(quaternion.attitude_error(q, q_true)) < 1e-6
    assert math.degrees(math.sqrt(estimator.covariance.attitude[2, 2])) < 3.0


def test_attitude_measurement_corrects_the_attitude():
    truth, gyro, accel, _ = simulate(2.0, rates, seed=10)
    estimator, q = started(truth[0], magnetometer=False)
    estimates, _ = run(estimator, q, gyro, accel)
    off = quaternion.multiply(quaternion.exp(np.radians([0.0, 0.0, 20.0])), estimates[-1])
    corrected = estimator.attitude_measurement(tuple(off), truth[-1], np.eye(3) * 1e-6)
    assert math.degrees(quaternion.attitude_error(corrected, truth[-1])) < 0.2
    assert math.sqrt(estimator.covariance.attitude[2, 2]) < 2e-3


def test_gravity_free_acceleration_at_rest_is_zero():
    q = quaternion.exp(np.radians([10.0, 20.0, 30.0]))
    force = quaternion.rotate_inverse(q, [0.0, 0.0, GRAVITY])
    estimator, _ = started(q)
    acceleration, covariance = gravity_free_acceleration(
        q, force, np.zeros(3), GRAVITY, np.array([0.0, 0.0, 1.0]), estimator.covariance.p,
        1e-4)
    assert np.abs(acceleration).max() < 1e-12
    assert np.all(np.linalg.eigvalsh(covariance) > 0.0)


@pytest.mark.parametrize('force', [(math.nan, 0.0, 9.8), (math.inf, 0.0, 0.0),
                                   (0.0, 0.0, 1e5), (0.0, 0.0, 0.0)])
def test_sample_refuses_hostile_specific_force(force):
    estimator, q = started((1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='specific force'):
        estimator.sample(q, (0.0, 0.0, 0.0), DT, q, force)


@pytest.mark.parametrize('field', [(math.nan, 0.0, 1e-5), (-math.inf, 0.0, 0.0),
                                   (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)])
def test_magnetic_field_refuses_hostile_values(field):
    estimator, q = started((1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='magnetic field'):
        estimator.magnetic_field(q, field)


@pytest.mark.parametrize('name, value', [('gravity_gate', 0.0), ('acceleration_time', -1.0),
                                         ('magnetometer_noise_density', math.nan),
                                         ('declination', 4.0), ('estimate_intrinsic', 1)])
def test_settings_refuse_bad_values(name, value):
    with pytest.raises(InputError, match=name):
        EstimatorSettings(**{name: value})


def test_magnetometer_calibration_refuses_bad_values():
    with pytest.raises(InputError, match='hard_iron'):
        MagnetometerCalibration(hard_iron=(math.nan, 0.0, 0.0))
    with pytest.raises(InputError, match='soft_iron'):
        MagnetometerCalibration(soft_iron=(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))


def test_attitude_measurement_refuses_a_zero_quaternion():
    estimator, q = started((1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='q_measured'):
        estimator.attitude_measurement(q, (0.0, 0.0, 0.0, 0.0), np.eye(3) * 1e-4)


def test_magnetometer_delay_is_taken_off():
    """A magnetometer 20 ms late on a body turning at up to 3 rad/s: paired with the attitude
    at its own instant, the heading holds; paired with the gyro's, it errs with the turn."""
    truth, gyro, accel, field = simulate(30.0, lambda t: 6.0 * rates(t), seed=12)
    late = np.concatenate([field[:2], field[:-2]])  # 2 samples at 100 Hz
    errors = {}
    for delay in (0.0, 0.02):
        settings = dataclasses.replace(SETTINGS, magnetometer_delay=delay,
                                       magnetometer_timing=0.001)
        estimator, q = started(truth[0], settings=settings)
        estimates, _ = run(estimator, q, gyro, accel, late)
        heading = world_errors(truth, estimates)[:, 2]
        errors[delay] = math.degrees(math.sqrt(np.mean(heading[500:] ** 2)))
    assert errors[0.02] < 0.5
    assert errors[0.0] > 2 * errors[0.02]


def test_magnetic_field_refuses_an_age_out_of_range():
    estimator, _ = started((1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='age'):
        estimator.magnetic_field((1.0, 0.0, 0.0, 0.0), (0.0, 18e-6, -45e-6), age=1.0)
    with pytest.raises(InputError, match='age'):
        estimator.magnetic_field((1.0, 0.0, 0.0, 0.0), (0.0, 18e-6, -45e-6), age=math.nan)


def test_attached_magnet_is_learned_and_heading_holds():
    """A magnet fixed to the body from the start of the motion (a 27 µT offset in the
    sensor frame): the filter learns it as hard iron and the heading holds; without
    learning, the field is refused and the heading is the gyro's alone."""
    truth, gyro, accel, field = simulate(90.0, lambda t: 4.0 * rates(t), seed=13)
    magnet = field + np.array([-3.5e-6, 0.2e-6, 27e-6])
    errors = {}
    for learn in (True, False):
        settings = dataclasses.replace(SETTINGS, learn_hard_iron=learn)
        estimator, q = started(truth[0], settings=settings, field_body=field[0])
        estimates, _ = run(estimator, q, gyro + np.array([0.0, 0.0, 2e-3]), accel, magnet)
        heading = np.degrees(world_errors(truth, estimates)[-1000:, 2])
        errors[learn] = (math.sqrt(np.mean(heading ** 2)), estimator.counts)
    assert errors[True][1]['hard_iron_learned'] >= 1
    assert errors[True][0] < 1.0
    assert errors[False][1]['hard_iron_learned'] == 0
    assert errors[False][0] > 2.0 * errors[True][0]


def test_a_clipped_interval_measures_no_velocity_change():
    """A blow beyond the accelerometer's full scale (20 m/s² here): the clipped samples read
    the full scale, so those intervals measure no velocity change (counted), and the tilt
    holds."""
    full_scale = 20.0

    def blows(t):  # 40 m/s² along east for 30 ms every 2 s (then as much back: at rest again)
        phase = t % 2.0
        return np.array([40.0 if 1.0 <= phase < 1.03 else -40.0 if 1.5 <= phase < 1.53
                         else 0.0, 0.0, 0.0])
    truth, gyro, accel, _ = simulate(20.0, lambda t: 0.2 * rates(t), blows, seed=7)
    accel = np.clip(accel, -full_scale, full_scale)
    settings = dataclasses.replace(SETTINGS, accelerometer_range=full_scale,
                                   motion_model='velocity')
    estimator, q = started(truth[0], settings, magnetometer=False)
    estimates, _ = run(estimator, q, gyro, accel)
    assert estimator.counts['velocity_clipped'] == 20  # one interval per blow
    tilt = np.degrees(np.linalg.norm(world_errors(truth, estimates)[:, :2], axis=1))
    assert tilt.max() < 0.08  # 0.05 deg; the clipped blows taken as measured: 0.11 deg
