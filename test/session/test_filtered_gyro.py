"""The attitude filter in a gyro session: the ``imu_filter`` scene on simulated IMU samples.

A body rests, then turns about a changing axis; the gyro reads the true rate plus a bias and
white noise (and, where a test says, scale-factor and misalignment errors), the accelerometer
gravity, the magnetometer the local field (dip 60°), each with noise. The truth is integrated
with the strapdown rule the scene uses (``delta_single``), so the attitude error is the
filter's alone. The session levels, turns to magnetic north, tracks the attitude, the gyro
bias and the gyro's scale-factor and misalignment errors (taken off the samples), publishes a
covariance that bounds its error, refuses hostile
magnetometer samples and attitude measurements by reason, never tilts for a magnet, and keeps
``set_pose`` a reset.
"""

import math

import numpy as np
import pytest
from conftest import BASE_NS, MS
from scipy.stats import chi2

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.attitude.float_quaternion import q_exp, q_multiply, q_normalize
from rigid_body_attitude.core.errors import CalibrationError, SceneError
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.estimation.magnetometer_file import load_magnetometer_calibration
from rigid_body_attitude.msgs.cdr import encode_magnetic_field, encode_pose_with_covariance_stamped
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.session.filtered_gyro import FilteredGyroSession
from rigid_body_attitude.session.gyro import GyroSession

G = 9.80665
RATE = 200.0
PERIOD_NS = 5 * MS
GYRO_NOISE, ACCEL_NOISE, FIELD_NOISE = 0.003, 0.03, 2e-8  # per sample
DIP = math.radians(60.0)
FIELD = 50e-6 * np.array([0.0, math.cos(DIP), -math.sin(DIP)])  # ENU: north and down
PARAMETERS = dict(gyroscope_noise_density=GYRO_NOISE / math.sqrt(RATE),
                  accelerometer_noise_density=ACCEL_NOISE / math.sqrt(RATE),
                  magnetometer_noise_density=FIELD_NOISE / math.sqrt(RATE),
                  align_seconds=1.0)


def body_rate(t):
    """The true body rate [rad/s] at ``t`` seconds after the rest (0 during it)."""
    if t < 0.0:
        return np.zeros(3)
    return np.array([0.6 * math.sin(0.7 * t), 0.5 * math.cos(0.45 * t),
                     0.4 + 0.3 * math.sin(0.2 * t)])


def simulate(seconds, rest=2.0, yaw=1.0, bias=(0.01, -0.02, 0.015), seed=1, magnet=None,
             intrinsic=np.zeros((3, 3))):
    """Samples ``(stamp_ns, gyro, accel, field, q_true)``; ``magnet``: (start, end, field [T]
    world) added to the field between those times after the rest; ``intrinsic``: the gyro's
    scale-factor and misalignment errors ``E`` (``ω_m = (I + E) ω + b + n``)."""
    rng = np.random.default_rng(seed)
    count = int((rest + seconds) * RATE)
    times = np.arange(count) / RATE - rest
    omega = np.array([body_rate(t) for t in times])
    q = tuple(quaternion.from_rpy([0.2, -0.1, yaw]).tolist())
    attitudes = [q]
    for k in range(1, count):
        q = q_normalize(q_multiply(q, q_exp(*(omega[k] / RATE).tolist())))
        attitudes.append(q)
    q_true = np.array(attitudes)
    field = np.tile(FIELD, (count, 1))
    if magnet is not None:
        field[(times >= magnet[0]) & (times < magnet[1])] += np.array(magnet[2])
    gyro = omega @ (np.eye(3) + intrinsic).T + np.array(bias) + rng.normal(
        0.0, GYRO_NOISE, (count, 3))
    accel = quaternion.rotate_inverse(q_true, np.array([0.0, 0.0, G])) + rng.normal(
        0.0, ACCEL_NOISE, (count, 3))
    mag = quaternion.rotate_inverse(q_true, field) + rng.normal(0.0, FIELD_NOISE, (count, 3))
    return [(BASE_NS + (k + 1) * PERIOD_NS, tuple(gyro[k].tolist()), tuple(accel[k].tolist()),
             tuple(mag[k].tolist()), q_true[k]) for k in range(count)]


def run(session, samples, magnetometer=True):
    """Feed ``samples``; the attitude error [rad] (world frame) at each published sample."""
    estimates, truths = [], []
    for stamp, gyro, accel, field, q_true in samples:
        sec, nanosec = divmod(stamp, 10**9)
        if magnetometer:
            session.magnetic_field(sec, nanosec, 'base_link', field)
        if session.gyro(sec, nanosec, gyro, None, accel):
            estimates.append(session.propagator.state.attitude_tuple())
            truths.append(q_true)
    return quaternion.log(quaternion.multiply(np.array(truths),
                                              quaternion.conjugate(np.array(estimates))))


def covariance(session):
    return np.array(session.estimation.published).reshape(3, 3)


def test_the_filter_levels_turns_to_magnetic_north_and_tracks_the_attitude(open_scene):
    session, sink = open_scene('imu_filter', **PARAMETERS)
    assert isinstance(session, FilteredGyroSession)
    errors = run(session, simulate(30.0))
    assert np.degrees(np.linalg.norm(errors[:20], axis=1)).max() < 1.0  # heading from the field
    assert np.degrees(np.linalg.norm(errors, axis=1)).max() < 1.0
    p = covariance(session)
    nees = errors[-1] @ np.linalg.solve(p, errors[-1])
    assert nees < 11.345  # chi-square 99 %, 3 dof
    assert math.degrees(math.sqrt(p[2, 2])) < 5.0  # the heading observable
    assert sink.accelerations and sink.covariances[-1] == session.estimation.published
    values = dict(sink.reports[-1].values) if sink.reports else {}
    assert not values or 'heading_observable' in values


def test_the_gyro_bias_is_estimated_and_reported(open_scene):
    bias = (0.01, -0.02, 0.015)
    session, _ = open_scene('imu_filter', **PARAMETERS)
    run(session, simulate(40.0, bias=bias))
    estimate = np.array(session.estimation.estimator.gyro_bias)
    assert np.abs(estimate - bias).max() < 2e-3
    values = dict(session.report().values)
    assert values['gyro_bias_estimate [rad/s]'].split() == [f'{v:.6g}' for v in estimate]
    assert 'magnetometer' in values['updates and rejections']
    assert session.bias_text().endswith('(filter)')


def test_the_gyros_scale_and_misalignment_errors_are_learned_and_taken_off_the_samples(
        open_scene):
    intrinsic = np.array([[0.02, -0.015, 0.0], [0.01, -0.01, 0.02], [0.0, 0.015, 0.01]])
    session, _ = open_scene('imu_filter', **PARAMETERS)
    samples = simulate(60.0, intrinsic=intrinsic)
    estimates, truths, covariances = [], [], []
    for stamp, gyro, accel, field, q_true in samples:
        sec, nanosec = divmod(stamp, 10**9)
        session.magnetic_field(sec, nanosec, 'base_link', field)
        if session.gyro(sec, nanosec, gyro, None, accel):
            estimates.append(session.propagator.state.attitude_tuple())
            truths.append(q_true)
            covariances.append(covariance(session))
    estimator = session.estimation.estimator
    estimate = estimator.intrinsic.reshape(3, 3)
    assert np.abs(estimate - intrinsic).max() < 0.005  # 2 % errors learned within 0.5 %
    probe = np.array([0.7, -0.4, 1.1])  # the map the samples take: (I + Ê)⁻¹ (ω − b̂)
    a = np.reshape(session.sample_map.affine[:9], (3, 3))
    expected = np.linalg.solve(np.eye(3) + estimate, probe - np.array(estimator.gyro_bias))
    assert a @ probe + session.sample_map.affine[9:] == pytest.approx(expected, abs=1e-12)
    assert session.sample_map.bias_removed(probe) == pytest.approx(expected, abs=1e-12)
    errors = quaternion.log(quaternion.multiply(np.array(truths),
                                                quaternion.conjugate(np.array(estimates))))
    assert np.degrees(np.linalg.norm(errors, axis=1)).max() < 3.0
    nees = np.einsum('ni,ni->n', errors, np.linalg.solve(np.array(covariances),
                                                         errors[:, :, None])[:, :, 0])
    assert np.mean(nees <= chi2.ppf(0.99, 3)) >= 0.99
    session.reset()  # a new start: no estimate left on the samples
    assert session.sample_map.affine == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                                         0.0, 0.0)


def test_without_magnetometer_the_heading_is_propagated_and_says_so(open_scene, tmp_path):
    path = tmp_path / 'tilt_only.yaml'
    path.write_text('rate_source: gyro\nbody: {inertia: {moments: [1, 1, 1]}}\n'
                    'estimation: {gravity: true}\n')
    session, _ = open_scene(str(path), **PARAMETERS)
    errors = run(session, simulate(20.0), magnetometer=False)
    tilt = np.degrees(np.linalg.norm(errors[:, :2], axis=1))
    assert tilt.max() < 1.0
    p = covariance(session)
    assert math.degrees(math.sqrt(p[2, 2])) > 90.0  # yaw unobservable: the covariance says so
    values = dict(session.report().values)
    assert values['heading_observable'] == 'no'


def test_a_magnet_is_rejected_and_never_tilts_the_estimate(open_scene):
    session, _ = open_scene('imu_filter', **PARAMETERS)
    magnet = (8.0, 14.0, (30e-6, 20e-6, 40e-6))
    errors = run(session, simulate(20.0, magnet=magnet))
    tilt = np.degrees(np.linalg.norm(errors[:, :2], axis=1))
    heading = np.degrees(np.abs(errors[:, 2]))
    assert tilt.max() < 1.0 and heading.max() < 3.0
    counts = session.estimation.estimator.counts
    assert sum(count for name, count in counts.items()
               if name.startswith('magnetometer_field')) > 50


@pytest.mark.parametrize('field, frame, reason', [
    ((math.nan, 0.0, 0.0), 'base_link', 'magnetometer_non_finite'),
    ((0.0, 0.0, 0.0), 'base_link', 'magnetometer_out_of_range'),
    ((1.0, 0.0, 0.0), 'base_link', 'magnetometer_out_of_range'),
    ((2e-5, 0.0, 0.0), 'elsewhere', 'magnetometer_no_mount'),
])
def test_a_hostile_field_is_refused_by_reason_and_changes_nothing(open_scene, field, frame,
                                                                  reason):
    session, _ = open_scene('imu_filter', **PARAMETERS)
    samples = simulate(2.0)
    run(session, samples)
    before = session.propagator.state.attitude_tuple(), session.estimation.published
    handle = input_handler(session, 'imu/mag')
    handle(encode_magnetic_field(samples[-1][0] + MS, frame, field))
    handle(b'\x00\x01\x00\x00garbage')
    assert session.rejection_counts()[reason] == 1
    assert session.malformed_by_topic['imu/mag'] == 1
    assert (session.propagator.state.attitude_tuple(), session.estimation.published) == before


def test_a_stale_or_unstamped_field_is_refused(open_scene):
    session, _ = open_scene('imu_filter', **PARAMETERS)
    session.magnetic_field(5, 0, 'base_link', (2e-5, 0.0, -3e-5))
    session.magnetic_field(5, 0, 'base_link', (2e-5, 0.0, -3e-5))
    session.magnetic_field(0, 0, 'base_link', (2e-5, 0.0, -3e-5))
    counts = session.rejection_counts()
    assert counts['magnetometer_stale_stamp'] == 1
    assert counts['magnetometer_invalid_stamp'] == 1


def measurement(stamp_ns, q, stddev, frame='world'):
    variance = stddev * stddev
    cov = [0.0] * 36
    for index in range(6):
        cov[7 * index] = 1e9 if index < 3 else variance
    return encode_pose_with_covariance_stamped(stamp_ns, frame, (0.0, 0.0, 0.0), q, cov)


def test_an_attitude_measurement_corrects_the_heading_and_hostile_ones_are_refused(
        open_scene, tmp_path):
    path = tmp_path / 'tracker.yaml'
    path.write_text('rate_source: gyro\nbody: {inertia: {moments: [1, 1, 1]}}\n'
                    'estimation: {attitude: true}\n')
    session, _ = open_scene(str(path), **PARAMETERS)
    handle = input_handler(session, 'attitude_measurement')
    samples = simulate(4.0, yaw=1.0)
    handle(measurement(samples[0][0], tuple(samples[0][4].tolist()), 0.01))  # levelling
    errors = run(session, samples[:700], magnetometer=False)
    assert abs(errors[-1][2]) > 0.5  # the heading is the levelling's initial_yaw: 1 rad off
    stamp, q_true = samples[699][0], samples[699][4]
    handle(measurement(stamp, tuple(q_true.tolist()), 0.01, frame='map'))
    bad = [0.0] * 36
    bad[21] = -1.0
    handle(encode_pose_with_covariance_stamped(stamp, 'world', (0.0, 0.0, 0.0),
                                               tuple(q_true.tolist()), bad))
    handle(measurement(stamp + 10**9, tuple(q_true.tolist()), 0.01))
    handle(measurement(stamp, (0.0, 0.0, 0.0, 0.0), 0.01))
    counts = session.rejection_counts()
    assert counts['attitude_measurement_not_started'] == 1
    assert counts['attitude_measurement_wrong_frame'] == 1
    assert counts['attitude_measurement_invalid_covariance'] == 1
    assert counts['attitude_measurement_stale_measurement'] == 1
    assert counts['attitude_measurement_invalid_pose'] == 1
    handle(measurement(stamp, tuple(q_true.tolist()), 0.01))
    errors = run(session, samples[700:], magnetometer=False)
    assert np.degrees(np.linalg.norm(errors, axis=1)).max() < 2.0
    assert math.degrees(math.sqrt(covariance(session)[2, 2])) < 3.0


def test_set_pose_is_a_reset_of_the_attitude(open_scene):
    session, sink = open_scene('imu_filter', **PARAMETERS)
    samples = simulate(3.0)
    run(session, samples)
    target = tuple(quaternion.from_rpy([0.0, 0.0, 2.0]).tolist())
    session.set_pose('world', target, (0.0, 0.0, 0.0))
    assert session.propagator.state.attitude_tuple() == pytest.approx(target, abs=1e-12)
    assert covariance(session)[2, 2] == pytest.approx(0.01 ** 2)


def test_gravity_free_acceleration_of_a_turning_body_is_near_zero(open_scene):
    session, sink = open_scene('imu_filter', **PARAMETERS)
    run(session, simulate(10.0))
    linear = np.array([row[2] for row in sink.accelerations[-200:]])
    assert np.abs(linear.mean(axis=0)).max() < 0.05
    cov = np.array(sink.accelerations[-1][3]).reshape(3, 3)
    assert np.all(np.linalg.eigvalsh(cov) > 0.0)


def test_strapdown_stays_pure_propagation(open_scene):
    session, _ = open_scene('strapdown')
    assert type(session) is GyroSession


@pytest.mark.parametrize('section, match', [
    ({'gravity': 'yes'}, 'estimation.gravity'),
    ({'wind': True}, 'Unknown key'),
    ({'settings': {'declination': 0.1}}, 'Unknown key'),
    ({'settings': {'gravity_gate': -1.0}}, 'estimation.settings.gravity_gate'),
    ([1, 2], 'estimation'),
])
def test_a_bad_estimation_section_is_one_scene_error_naming_the_key(section, match):
    data = {'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
            'estimation': section}
    with pytest.raises(SceneError, match=match):
        scene_from_mapping(data)


def test_the_estimation_section_needs_a_gyro_scene():
    data = {'rate_source': 'dynamics', 'body': {'inertia': {'moments': [1, 1, 1]}},
            'estimation': {}}
    with pytest.raises(SceneError, match='gyro scene'):
        scene_from_mapping(data)


def test_the_magnetometer_calibration_file_inverts_the_distortion(tmp_path):
    path = tmp_path / 'mag.yaml'
    path.write_text('hard_iron: [1.0e-6, -2.0e-6, 0.5e-6]\n'
                    'soft_iron: [[1.1, 0.02, 0.0], [0.02, 0.9, 0.0], [0.0, 0.0, 1.0]]\n'
                    'noise_density: 8.0e-8\ndelay: 0.012\n')
    loaded = load_magnetometer_calibration(path)
    assert loaded.settings == {'magnetometer_noise_density': 8.0e-8,
                               'magnetometer_delay': 0.012}
    calibration = loaded.calibration
    true = np.array([20e-6, -5e-6, -40e-6])
    soft = np.array([[1.1, 0.02, 0.0], [0.02, 0.9, 0.0], [0.0, 0.0, 1.0]])
    measured = soft @ true + np.array([1.0e-6, -2.0e-6, 0.5e-6])
    assert calibration.corrected(tuple(measured.tolist())) == pytest.approx(true, abs=1e-15)


@pytest.mark.parametrize('text, match', [
    ('hard_iron: [1, 2, 3]\n', 'hard_iron'),
    ('soft_iron: [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]\n', 'handedness'),
    ('soft_iron: [[1, 0, 0], [0, 1, 0]]\n', 'soft_iron'),
    ('scale: 2\n', 'Unknown key'),
    ('{}\n', 'empty'),
    ('delay: 0.5\n', 'delay'),
    ('noise_density: -1.0e-8\n', 'noise_density'),
    ('hard_iron: [.nan, 0, 0]\n', 'hard_iron'),
    ('- [unclosed\n', 'Magnetometer calibration file'),
])
def test_a_bad_magnetometer_calibration_file_is_one_error_line(tmp_path, text, match):
    path = tmp_path / 'mag.yaml'
    path.write_text(text)
    with pytest.raises(CalibrationError, match=match) as info:
        load_magnetometer_calibration(path)
    assert '\n' not in str(info.value) and str(info.value).startswith('Magnetometer')


def test_a_missing_magnetometer_calibration_file_is_one_error_line(tmp_path):
    with pytest.raises(CalibrationError, match='does not exist'):
        load_magnetometer_calibration(tmp_path / 'none.yaml')


def test_the_magnetometer_files_figures_reach_the_filter(open_scene, tmp_path):
    path = tmp_path / 'mag.yaml'
    path.write_text('noise_density: 8.0e-8\ndelay: 0.012\ntiming: 0.0014\n')
    session, _ = open_scene('imu_filter', magnetometer_calibration_file=str(path),
                            magnetometer_noise_density=1.0e-6)
    settings = session.estimation.estimator.settings
    assert (settings.magnetometer_noise_density, settings.magnetometer_delay,
            settings.magnetometer_timing) == (8.0e-8, 0.012, 0.0014)


def test_reset_levels_again_and_restarts_the_filter(open_scene):
    session, _ = open_scene('imu_filter', **PARAMETERS)
    samples = simulate(3.0)
    run(session, samples)
    assert session.estimation.started
    session.reset()
    assert not session.estimation.started
    later = [(stamp + 10 * 10**9, *rest) for stamp, *rest in simulate(3.0, seed=2)]
    errors = run(session, later)
    assert session.estimation.started and session.alignment.at_rest
    assert np.degrees(np.linalg.norm(errors, axis=1)).max() < 1.0
