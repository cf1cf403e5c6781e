"""A real IMU through the gyro session: Imu bytes with accelerometer and gyro, sensor frame.

Synthetic samples: a noisy rest at a known tilt, then a known rotation. The session levels from
gravity before it integrates (nothing published meanwhile), rotates samples from the sensor
frame into the body frame (``mount_rpy``), applies a calibration file, starts from the scene
without accelerometer data, levels again after ``reset`` and after ``align_timeout`` without
rest; hostile parameters and calibration files give one error naming the key.
"""

import math
import random
from pathlib import Path

import numpy as np
import pytest
from conftest import BASE_NS, MS

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.alignment import tilt_angle, world_up
from rigid_body_attitude.core.errors import CalibrationError
from rigid_body_attitude.msgs import encode_imu, encode_vector3_stamped
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.session.parameters import check_values, defaults
from rigid_body_attitude.session.reports import LEVEL_OK, LEVEL_WARN
from rigid_body_attitude.tools.broad import load_trial
from rigid_body_attitude.core.attitude.quaternion import from_rpy


def rpy(*angles):
    """``from_rpy`` of roll, pitch, yaw as a (w, x, y, z) tuple."""
    return tuple(from_rpy(angles).tolist())


G = 9.80665
PERIOD_NS = 5 * MS  # 200 Hz
BROAD = Path('/work/shared/data/broad')


def specific_force(attitude, world_axes='enu'):
    """What an accelerometer at rest measures in the body frame: R(q)ᵀ up g."""
    up = np.array(world_up(world_axes)) * G
    return tuple(quaternion.rotate_inverse(attitude, up).tolist())


def rest_samples(count, accel, rng, bias=(0.002, -0.001, 0.0005), start=0):
    """``count`` noisy rest samples: (stamp, rate, accel)."""
    for k in range(start, start + count):
        rate = tuple(b + rng.gauss(0.0, 0.003) for b in bias)
        acc = tuple(a + rng.gauss(0.0, 0.03) for a in accel)
        yield BASE_NS + k * PERIOD_NS, rate, acc


def feed(handle, samples, frame='imu_link'):
    for stamp, rate, acc in samples:
        handle(encode_imu(stamp, frame, rate, acc))


def test_levels_to_the_tilt_of_the_gravity_it_measures(open_scene):
    """ENU, NED and NWU: the levelled roll and pitch are those of the attitude at rest."""
    for world_axes in ('enu', 'ned', 'nwu'):
        truth = rpy(0.3, -0.2, 0.0)
        session, sink = open_scene('strapdown', world_axes=world_axes)
        handle = input_handler(session, 'imu')
        feed(handle, rest_samples(400, specific_force(truth, world_axes), random.Random(1)))
        assert session.alignment_done and session.alignment.at_rest
        levelled = session.alignment.attitude
        assert math.degrees(tilt_angle(levelled, truth, world_axes)) < 0.05, world_axes
        # The first output is the levelled attitude; the window's mean rate is the bias.
        assert np.allclose(sink.attitudes[0][2], levelled, atol=1e-6)
        # σ/√n = 0.003/√200 = 2e-4 rad/s per axis; 1e-3 is 5 σ.
        assert np.allclose(session.alignment.gyro_bias, (0.002, -0.001, 0.0005), atol=1e-3)


def test_nothing_is_published_while_levelling_and_the_diagnostics_say_so(open_scene, clocks):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    accel = specific_force((1.0, 0.0, 0.0, 0.0))
    feed(handle, rest_samples(100, accel, random.Random(2)))
    assert not sink.attitudes and not session.alignment_done
    clocks.monotonic = 1.0
    report = session.report()
    values = dict(report.values)
    # Nothing integrated yet: never OK.
    assert report.level == LEVEL_WARN and report.message.startswith('aligning: ')
    assert values['alignment'].startswith('aligning: ')
    assert values['accepted'] == '100'  # taken by the levelling, not rejected
    feed(handle, rest_samples(300, accel, random.Random(3), start=100))
    assert session.alignment_done and sink.attitudes
    clocks.monotonic = 2.0
    report = session.report()
    assert (report.level, report.message) == (LEVEL_OK, 'propagating')
    assert dict(report.values)['alignment'].startswith('aligned at rest over 1 s')
    assert '(levelling)' in dict(report.values)['gyro_bias [rad/s]']


def test_a_rotation_after_levelling_is_integrated_less_the_levelled_bias(open_scene):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    bias = (0.01, -0.02, 0.005)
    accel = specific_force((1.0, 0.0, 0.0, 0.0))
    rng = random.Random(4)
    feed(handle, rest_samples(400, accel, rng, bias=bias))
    start = session.alignment.attitude
    # 1 s at 0.5 rad/s about the body z axis (the gyro adds its bias), noise-free; each sample
    # is integrated over the interval before it.
    for k in range(400, 600):
        rate = (bias[0], bias[1], 0.5 + bias[2])
        handle(encode_imu(BASE_NS + k * PERIOD_NS, 'imu_link', rate, accel))
    last = sink.attitudes[-1][2]
    turned = quaternion.multiply(quaternion.conjugate(start), last)
    expected = rpy(0.0, 0.0, 0.5)
    # The bias estimate's error (noise 0.003 rad/s over 1 s: ~2e-4 rad/s) stays within 1e-3 rad.
    assert float(quaternion.attitude_error(turned, expected)) < 1e-3


def test_mount_rpy_turns_sensor_rates_into_body_rates(open_scene):
    """The sensor's x axis is the body's y axis (yaw 90°): a turn about sensor x is one about
    body y; the accelerometer is rotated the same way, so the body is level."""
    session, sink = open_scene('strapdown', mount_rpy=(0.0, 0.0, math.pi / 2))
    handle = input_handler(session, 'imu')
    # Level body, sensor yawed 90°: gravity along z in both frames; tilt the body by 0.2 rad
    # about its y axis = the sensor's x axis.
    body_truth = rpy(0.0, 0.2, 0.0)
    accel_body = specific_force(body_truth)
    mount = rpy(0.0, 0.0, math.pi / 2)
    accel_sensor = tuple(quaternion.rotate_inverse(mount, accel_body).tolist())
    feed(handle, rest_samples(400, accel_sensor, random.Random(5), bias=(0.0, 0.0, 0.0)))
    assert math.degrees(tilt_angle(session.alignment.attitude, body_truth)) < 0.05
    start = session.alignment.attitude
    for k in range(400, 500):  # 0.5 s at 1 rad/s about the sensor x axis
        handle(encode_imu(BASE_NS + k * PERIOD_NS, 'imu_link', (1.0, 0.0, 0.0), accel_sensor))
    turned = quaternion.multiply(quaternion.conjugate(start), sink.attitudes[-1][2])
    assert float(quaternion.attitude_error(turned, rpy(0.0, 0.5, 0.0))) < 2e-3


def test_set_mount_and_mount_needed(open_scene):
    session, sink = open_scene('strapdown', align_seconds=0.0)
    assert session.mount_needed('imu_link') and not session.mount_needed('base_link')
    session.set_mount(rpy(math.pi / 2, 0.0, 0.0))  # sensor y = body z
    handle = input_handler(session, 'angular_velocity')
    for k in range(101):  # 0.5 s at 1 rad/s about the sensor y axis
        handle(encode_vector3_stamped(BASE_NS + k * PERIOD_NS, 'imu_link', (0.0, 1.0, 0.0)))
    assert float(quaternion.attitude_error(sink.attitudes[-1][2],
                                           rpy(0.0, 0.0, 0.5))) < 1e-9
    given, _ = open_scene('strapdown', mount_rpy=(0.0, 0.0, 0.0))
    assert not given.mount_needed('imu_link')


def test_a_calibration_file_corrects_every_sample(open_scene, tmp_path):
    """Worked by hand: scale 2 on x, bias 0.1 rad/s on x: a measured 0.35 rad/s about x is
    2 (0.35 − 0.1) = 0.5 rad/s; 1 s of it turns the body by 0.5 rad about x."""
    path = tmp_path / 'imu_calibration.yaml'
    path.write_text('bias: [0.1, 0.0, 0.0]\nscale: [2.0, 1.0, 1.0]\n')
    session, sink = open_scene('strapdown', calibration_file=str(path), align_seconds=0.0)
    handle = input_handler(session, 'angular_velocity')
    for k in range(201):
        handle(encode_vector3_stamped(BASE_NS + k * PERIOD_NS, 'imu_link', (0.35, 0.0, 0.0)))
    assert float(quaternion.attitude_error(sink.attitudes[-1][2],
                                           rpy(0.5, 0.0, 0.0))) < 1e-9


def test_a_kalibr_file_with_g_sensitivity_takes_the_accelerometer(open_scene, tmp_path):
    """kalibr's A matrix: ω_i = ω − A a_i. With A = 1e-3 on (x, z) and a = 9.81 along z, the
    sample (0.00981, 0, 0) measured at rest is no rotation at all."""
    path = tmp_path / 'camchain-imucam.yaml'
    path.write_text('imu0:\n  update_rate: 200.0\n  gyroscopes:\n    A: [[0.0, 0.0, 1.0e-3], '
                    '[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]\n')
    session, sink = open_scene('strapdown', calibration_file=str(path), align_seconds=0.0)
    handle = input_handler(session, 'imu')
    for k in range(201):
        handle(encode_imu(BASE_NS + k * PERIOD_NS, 'imu_link', (0.00981, 0.0, 0.0),
                          (0.0, 0.0, 9.81)))
    assert float(quaternion.attitude_error(sink.attitudes[-1][2], (1, 0, 0, 0))) < 1e-12


@pytest.mark.parametrize('source', ['angular_velocity', 'imu_zeros', 'imu_not_provided'])
def test_without_accelerometer_data_it_starts_from_the_scene_and_says_so_once(
        open_scene, source):
    session, sink = open_scene('strapdown')
    topic = 'angular_velocity' if source == 'angular_velocity' else 'imu'
    handle = input_handler(session, topic)
    for k in range(5):
        stamp = BASE_NS + k * PERIOD_NS
        if source == 'angular_velocity':
            handle(encode_vector3_stamped(stamp, 'imu_link', (0.0, 0.0, 0.1)))
        else:
            accel = (0.0, 0.0, 0.0) if source == 'imu_zeros' else None
            handle(encode_imu(stamp, 'imu_link', (0.0, 0.0, 0.1), accel))
    assert len(sink.attitudes) == 5  # from the first sample on
    assert sink.attitudes[0][2] == (1.0, 0.0, 0.0, 0.0)  # the scene's
    notes = [text for level, text in sink.logs if 'no accelerometer data' in text]
    assert len(notes) == 1 and sink.logs[0][0] == LEVEL_INFO
    assert session.alignment.source == 'scene'
    assert 'not levelled' in dict(session.report().values)['alignment']


def test_reset_levels_again(open_scene):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    first = rpy(0.1, 0.0, 0.0)
    feed(handle, rest_samples(400, specific_force(first), random.Random(6)))
    assert math.degrees(tilt_angle(session.alignment.attitude, first)) < 0.05
    published = len(sink.attitudes)
    session.reset()
    assert not session.alignment_done
    second = rpy(-0.2, 0.1, 0.0)
    feed(handle, rest_samples(100, specific_force(second), random.Random(7), start=400))
    assert len(sink.attitudes) == published  # levelling again: nothing published
    feed(handle, rest_samples(400, specific_force(second), random.Random(8), start=500))
    assert math.degrees(tilt_angle(session.alignment.attitude, second)) < 0.05
    assert math.degrees(tilt_angle(sink.attitudes[-1][2], second)) < 0.1


def test_a_body_that_never_rests_is_levelled_after_the_timeout(open_scene):
    """A node restarted in flight: after align_timeout it starts from the quietest window,
    warns, and says so in the diagnostics."""
    session, sink = open_scene('strapdown', align_timeout=2.0)
    handle = input_handler(session, 'imu')
    truth = rpy(0.2, 0.0, 0.0)
    accel = specific_force(truth)
    rng = random.Random(9)
    for k in range(600):  # 3 s of shaking: rates of ±1 rad/s
        rate = tuple(math.sin(0.05 * k + phase) for phase in (0.0, 1.0, 2.0))
        acc = tuple(a + rng.gauss(0.0, 0.03) for a in accel)
        handle(encode_imu(BASE_NS + k * PERIOD_NS, 'imu_link', rate, acc))
        if k == 350:
            assert not session.alignment_done  # 1.75 s: still waiting
    assert session.alignment_done and not session.alignment.at_rest
    assert session.alignment.source == 'timeout'
    assert math.degrees(tilt_angle(session.alignment.attitude, truth)) < 0.5
    assert any(level == LEVEL_WARN and 'without rest' in text for level, text in sink.logs)
    assert 'without rest' in dict(session.report().values)['alignment']
    # Waiting, the diagnostics said why: the gyro spread.
    fresh, _ = open_scene('strapdown', align_timeout=2.0)
    shaking = input_handler(fresh, 'imu')
    for k in range(100):
        rate = tuple(math.sin(0.05 * k + phase) for phase in (0.0, 1.0, 2.0))
        shaking(encode_imu(BASE_NS + k * PERIOD_NS, 'imu_link', rate, accel))
    assert 'waiting for rest' in fresh.alignment_text()


def test_set_pose_while_levelling_gives_the_yaw(open_scene):
    session, sink = open_scene('strapdown', initial_yaw=0.3)
    handle = input_handler(session, 'imu')
    truth = rpy(0.1, 0.05, 1.2)
    accel = specific_force(truth)
    feed(handle, rest_samples(100, accel, random.Random(10)))
    session.set_pose('world', rpy(0.0, 0.0, 1.2), (0.0, 0.0, 0.0))
    feed(handle, rest_samples(300, accel, random.Random(11), start=100))
    assert float(quaternion.attitude_error(session.alignment.attitude, truth)) < 1e-3
    other, _ = open_scene('strapdown', initial_yaw=0.3)
    feed(input_handler(other, 'imu'), rest_samples(400, accel, random.Random(12)))
    assert float(quaternion.attitude_error(other.alignment.attitude,
                                           rpy(0.1, 0.05, 0.3))) < 1e-3


def test_bad_samples_while_levelling_are_counted(open_scene):
    session, _ = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    accel = specific_force((1.0, 0.0, 0.0, 0.0))
    handle(encode_imu(BASE_NS, 'imu_link', (0.0, 0.0, 0.0), accel))
    handle(encode_imu(BASE_NS + PERIOD_NS, 'imu_link', (0.0, 0.0, 0.0), (math.nan, 0.0, 9.8)))
    handle(encode_imu(BASE_NS + 2 * PERIOD_NS, 'imu_link', (2e3, 0.0, 0.0), accel))
    handle(encode_imu(BASE_NS, 'imu_link', (0.0, 0.0, 0.0), accel))  # stale
    counts = session.rejection_counts()
    assert (counts['non_finite'], counts['out_of_range'], counts['stale_stamp']) == (1, 1, 1)
    assert session.received_count() == 4


def test_on_aligned_is_called_each_time_the_start_is_settled(open_scene):
    session, _ = open_scene('strapdown')
    results = []
    session.on_aligned = results.append
    handle = input_handler(session, 'imu')
    feed(handle, rest_samples(400, specific_force((1.0, 0.0, 0.0, 0.0)), random.Random(13)))
    session.reset()
    feed(handle, rest_samples(400, specific_force((1.0, 0.0, 0.0, 0.0)), random.Random(14),
                              start=400))
    assert [result.source for result in results] == ['gravity', 'gravity']
    assert results[0].window_seconds == 1.0 and results[0].at_rest


def test_refining_the_bias_at_rest_follows_a_changed_bias(open_scene):
    session, _ = open_scene('strapdown', refine_bias_at_rest=True)
    handle = input_handler(session, 'imu')
    accel = specific_force((1.0, 0.0, 0.0, 0.0))
    feed(handle, rest_samples(400, accel, random.Random(15), bias=(0.0, 0.0, 0.0)))
    assert np.allclose(session.sample_map.gyro_bias, 0.0, atol=5e-4)
    # 20 s more rest with a bias of 0.01 rad/s about z: the estimate moves towards it.
    feed(handle, rest_samples(4000, accel, random.Random(16), bias=(0.0, 0.0, 0.01), start=400))
    assert 0.004 < session.sample_map.gyro_bias[2] < 0.011
    assert 'refined at rest' in session.bias_text()


@pytest.mark.parametrize('name, value, match', [
    ('mount_rpy', (1.0, 2.0), 'Expected parameter `mount_rpy` to be a double array of 3'),
    ('mount_rpy', (0, 0, 1), 'Expected parameter `mount_rpy` to be a double array of 3'),
    ('mount_rpy', (math.nan, 0.0, 0.0), '`mount_rpy` to hold finite numbers'),
    ('mount_rpy', [0.0, 0.0, 0.0], 'Expected parameter `mount_rpy` to be a double array'),
    ('world_axes', 'xyz', "`world_axes` to be one of 'enu', 'ned', 'nwu'"),
    ('align_seconds', -1.0, '`align_seconds` to be a finite number in \\[0, 60\\]'),
    ('align_timeout', 0.0, '`align_timeout` to be a finite number in \\(0, 3600\\]'),
    ('initial_yaw', math.inf, '`initial_yaw` to be a finite number'),
    ('refine_bias_at_rest', 1, '`refine_bias_at_rest` to be a boolean'),
])
def test_hostile_parameters_are_refused_naming_the_parameter(name, value, match):
    values = defaults()
    values[name] = value
    with pytest.raises(AssertionError, match=match):
        problem = check_values(values)
        assert not problem, problem


@pytest.mark.parametrize('text, match', [
    ('bias: [0.1, 0.0]\n', 'Expected bias to be 3 numbers'),
    ('scale: [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]\n',
     r'scale factors \(diagonal\) of scale to be in \[0.5, 2\]'),
    ('imu0:\n  gyroscopes:\n    C_gyro_i: [[2.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]\n',
     'imu0.gyroscopes.C_gyro_i to be a rotation matrix'),
    ('no_such_key: 1\n', 'Expected kalibr keys'),
    ('bias: [.nan, 0.0, 0.0]\n', 'bias'),
    ('- a\n- b\n', 'Expected a mapping'),
])
def test_hostile_calibration_files_give_one_error_naming_the_key(open_scene, tmp_path, text,
                                                                 match):
    path = tmp_path / 'calibration.yaml'
    path.write_text(text)
    with pytest.raises(CalibrationError, match=match) as raised:
        open_scene('strapdown', calibration_file=str(path))
    assert str(raised.value).startswith(f"Calibration file '{path}'")
    assert '\n' not in str(raised.value)
    with pytest.raises(CalibrationError, match='does not exist'):
        open_scene('strapdown', calibration_file=str(tmp_path / 'missing.yaml'))


BROAD_TRIALS = sorted(BROAD.glob('*.npz'))


@pytest.mark.parametrize('path', BROAD_TRIALS, ids=[p.stem for p in BROAD_TRIALS])
def test_broad_trials_level_within_half_a_degree_of_the_optical_truth(open_scene, path):
    """Real samples (BROAD, CC BY 4.0, docs/data.md) through the session: the levelled tilt
    against the optical attitude at the stamp where the levelling ended."""
    trial = load_trial(path)
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    period_ns = round(1e9 / trial.sampling_rate)
    count = int(4 * trial.sampling_rate)
    for k in range(count):
        handle(encode_imu(BASE_NS + k * period_ns, 'imu', tuple(trial.gyro[k].tolist()),
                          tuple(trial.acc[k].tolist())))
        if session.alignment_done:
            break
    assert session.alignment.at_rest, session.alignment_text()
    # The first optical attitude from there on, still in the initial rest (the cameras find
    # the body a few seconds into some trials).
    seen = np.flatnonzero(~trial.ground_truth_lost[k:trial.first_motion_index])
    truth = trial.ground_truth[k + seen[0]]
    assert math.degrees(tilt_angle(session.alignment.attitude, tuple(truth.tolist()))) < 0.5
    assert sink.attitudes and sink.attitudes[0][0] * 10**9 + sink.attitudes[0][1] == (
        BASE_NS + k * period_ns)


def test_the_calibration_applied_is_said_at_start_and_in_diagnostics(open_scene, tmp_path):
    """One INFO line at start naming the file, its kind, the IMU key and every term with its
    values; the same in the diagnostics' values; ``calibration none`` without a file."""
    path = tmp_path / 'camchain-imucam.yaml'
    path.write_text('imu0:\n  gyroscopes:\n    M: [[1.02, 0, 0], [0.01, 0.98, 0], [0, 0, 1]]\n'
                    '  gyroscope_noise_density: 1.6968e-04\n  gyroscope_random_walk: 1.9393e-05\n'
                    '  update_rate: 200.0\n')
    session, sink = open_scene('strapdown', calibration_file=str(path))
    lines = [text for level, text in sink.logs if text.startswith('calibration:')]
    assert len(lines) == 1 and sink.logs[0][0] == LEVEL_INFO
    assert lines[0].startswith(f"calibration: file '{path}' (kalibr imu-camera result, IMU key "
                               f"imu0): gyro_matrix K [[0.980392, 0, 0], [-0.010004, 1.02041, 0], "
                               "[0, 0, 1]]; gyroscope_noise_density")
    assert ('gyroscope_noise_density [rad/s/sqrt(Hz)] 0.00016968; gyroscope_random_walk '
            '[rad/s^2/sqrt(Hz)] 1.9393e-05; update_rate [Hz] 200') in lines[0]
    values = dict(session.report().values)
    assert (values['calibration'], values['calibration_kind'], values['calibration_imu_key']) == (
        str(path), 'kalibr imu-camera result', 'imu0')
    assert values['calibration gyroscope_noise_density [rad/s/sqrt(Hz)]'] == '0.00016968'
    plain, _ = open_scene('strapdown')
    assert dict(plain.report().values)['calibration'] == 'none'
