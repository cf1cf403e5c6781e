"""A filter's attitude measurements in stamp order, its start from the first one, its ``odom``.

The ``star_tracker_filter`` scene (gyro strapdown corrected by a star tracker, started from
the first star tracker sample) on a body turning at a constant rate: the gyro reads the true
rate (its samples at 100 Hz), the star tracker the true attitude at every tenth instant with a
small error. A measurement stamped at a gyro sample's instant changes the same outputs,
bit for bit, whether it arrives before or after that sample; none before its own stamp.
"""

import math

import numpy as np
import pytest
from conftest import MS

from rigid_body_attitude.core.attitude.float_quaternion import q_exp, q_multiply, q_normalize
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.msgs.cdr import encode_pose_with_covariance_stamped
from rigid_body_attitude.session.attitude_input import ATTITUDE_START_STATUS, MEASUREMENT_QUEUE
from rigid_body_attitude.session.decoding import input_handler

START_NS = 1000 * 10**9
PERIOD_NS = 10 * MS
OMEGA = (0.02, -0.01, 0.03)
STDDEV = 1e-4
GYRO = dict(gyroscope_noise_density=1e-5, gyroscope_random_walk=1e-7,
            gyroscope_turn_on_bias=1e-4)


def truth(k):
    """The true attitude (w, x, y, z) at instant ``k`` (constant body rate from the identity)."""
    q = (1.0, 0.0, 0.0, 0.0)
    step = q_exp(*(value * PERIOD_NS * 1e-9 for value in OMEGA))
    for _ in range(k):
        q = q_normalize(q_multiply(q, step))
    return q


def measurement(k, offset=(0.0, 0.0, 0.0), frame='world'):
    """The star tracker's message at instant ``k``: the truth turned by ``offset`` [rad]."""
    q = q_multiply(q_exp(*(0.5 * value for value in offset)), truth(k))
    cov = [0.0] * 36
    for index in range(6):
        cov[7 * index] = 1e9 if index < 3 else STDDEV * STDDEV
    return encode_pose_with_covariance_stamped(START_NS + k * PERIOD_NS, frame,
                                               (0.0, 0.0, 0.0), q, cov)


def feed(session, ticks, star_first, offsets=None):
    """Gyro samples 1..ticks and a measurement every tenth instant from 0, the measurement of
    an instant before (``star_first``) or after its gyro sample."""
    star = input_handler(session, 'attitude_measurement')
    offsets = offsets or {}
    star(measurement(0))
    for k in range(1, ticks + 1):
        sec, nanosec = divmod(START_NS + k * PERIOD_NS, 10**9)
        due = k % 10 == 0
        if due and star_first:
            star(measurement(k, offsets.get(k, (0.0, 0.0, 0.0))))
        session.gyro(sec, nanosec, OMEGA)
        if due and not star_first:
            star(measurement(k, offsets.get(k, (0.0, 0.0, 0.0))))


def test_a_measurement_changes_the_same_outputs_whichever_comes_first(open_scene):
    offsets = {k: (2e-4 * math.sin(k), -1e-4, 3e-4 * math.cos(k)) for k in range(10, 301, 10)}
    runs = []
    for star_first in (True, False):
        session, sink = open_scene('star_tracker_filter', **GYRO)
        feed(session, 300, star_first, offsets)
        runs.append(sink.odometries)
        assert session.rejection_counts()['attitude_measurement_stale_stamp'] == 0
        assert session.estimation.counts['attitude_late'] == 0
    assert runs[0] == runs[1]
    stamps = [sec * 10**9 + nanosec for sec, nanosec, *_ in runs[0]]
    assert stamps == [START_NS + k * PERIOD_NS for k in range(301)]
    # the measurement of instant 10 first reaches the output of instant 11
    unchanged, sink = open_scene('star_tracker_filter', **GYRO)
    feed(unchanged, 10, True)
    assert sink.odometries[10] == runs[0][10]
    assert runs[0][11][2] != sink.odometries[10][2]


def test_the_filter_starts_at_the_first_measurement(open_scene):
    session, sink = open_scene('star_tracker_filter', **GYRO)
    sec, nanosec = divmod(START_NS - PERIOD_NS, 10**9)
    session.gyro(sec, nanosec, OMEGA)  # before any measurement: not integrated
    assert session.rejection_counts()['awaiting_attitude'] == 1
    assert sink.attitudes == [] and sink.odometries == []
    input_handler(session, 'attitude_measurement')(measurement(0, (3e-4, 0.0, 0.0)))
    assert session.alignment is not None and session.alignment.status == ATTITUDE_START_STATUS
    start = q_multiply(q_exp(1.5e-4, 0.0, 0.0), truth(0))
    assert sink.attitudes[-1] == (START_NS // 10**9, START_NS % 10**9, start)
    stamp_sec, stamp_nanosec, attitude, rate, _ = sink.odometries[-1]
    assert (stamp_sec * 10**9 + stamp_nanosec, attitude, rate) == (START_NS, start,
                                                                   (0.0, 0.0, 0.0))
    assert np.reshape(sink.covariances[-1], (3, 3)) == pytest.approx(
        STDDEV ** 2 * np.eye(3), rel=1e-9)
    sec, nanosec = divmod(START_NS + PERIOD_NS, 10**9)
    session.gyro(sec, nanosec, OMEGA)  # integrated from the measurement's stamp
    expected = q_normalize(q_multiply(start, q_exp(*(value * 0.01 for value in OMEGA))))
    assert sink.attitudes[-1][2] == pytest.approx(expected, abs=1e-12)
    assert sink.odometries[-1][3] == pytest.approx(OMEGA, abs=1e-12)
    assert np.all(np.linalg.eigvalsh(np.reshape(sink.odometries[-1][4], (3, 3))) > 0.0)


def test_repeated_late_and_far_measurements(open_scene):
    session, _ = open_scene('star_tracker_filter', **GYRO)
    star = input_handler(session, 'attitude_measurement')
    feed(session, 20, True)
    star(measurement(20))  # a lockstep plant repeating a tick resends its samples
    star(measurement(15))  # not newer than the last either
    counts = session.rejection_counts()
    assert counts['attitude_measurement_stale_stamp'] == 2
    star(measurement(21 + 10**4))  # 100 s ahead of the gyro: beyond max_dt
    assert session.rejection_counts()['attitude_measurement_stale_measurement'] == 1
    for k in range(21, 25):
        sec, nanosec = divmod(START_NS + k * PERIOD_NS, 10**9)
        session.gyro(sec, nanosec, OMEGA)
    star(measurement(24))  # at the latest sample's stamp: fused at once
    assert session.estimation.counts['attitude_late'] == 0
    star(measurement(25))  # ahead: held for the next sample
    assert len(session.measurements.held) == 1
    sec, nanosec = divmod(START_NS + 27 * PERIOD_NS, 10**9)
    session.gyro(sec, nanosec, OMEGA)
    assert len(session.measurements.held) == 0


def test_measurements_ahead_of_a_stalled_gyro_are_bounded(open_scene):
    session, _ = open_scene('star_tracker_filter', **GYRO, max_dt=10.0)
    star = input_handler(session, 'attitude_measurement')
    feed(session, 1, True)
    for k in range(2, MEASUREMENT_QUEUE + 4):
        star(measurement(k))
    assert len(session.measurements.held) == MEASUREMENT_QUEUE
    assert session.rejection_counts()['attitude_measurement_queue_full'] == 2


def test_a_reset_waits_for_the_next_measurement(open_scene):
    session, sink = open_scene('star_tracker_filter', **GYRO)
    feed(session, 15, True)
    session.reset()
    published = len(sink.attitudes)
    sec, nanosec = divmod(START_NS + 16 * PERIOD_NS, 10**9)
    session.gyro(sec, nanosec, OMEGA)
    assert len(sink.attitudes) == published
    input_handler(session, 'attitude_measurement')(measurement(20))
    assert len(sink.attitudes) == published + 1


@pytest.mark.parametrize('section, match', [
    ({'start': 'attitude_measurement'}, 'estimation.attitude true'),
    ({'attitude': True, 'start': 'star'}, 'estimation.start'),
])
def test_a_bad_start_is_one_scene_error(section, match):
    with pytest.raises(SceneError, match=match):
        scene_from_mapping({'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
                            'estimation': section})


def test_the_start_is_published_again_while_its_measurement_comes_again(open_scene):
    session, sink = open_scene('star_tracker_filter', **GYRO)
    star = input_handler(session, 'attitude_measurement')
    for _ in range(3):  # a lockstep plant repeating its first tick
        star(measurement(0))
    assert [entry[:4] for entry in sink.odometries] == [
        (START_NS // 10**9, START_NS % 10**9, truth(0), (0.0, 0.0, 0.0))] * 3
    assert session.estimation.counts['attitude_start_repeated'] == 2
    assert session.rejection_counts()['attitude_measurement_stale_stamp'] == 0
    sec, nanosec = divmod(START_NS + PERIOD_NS, 10**9)
    session.gyro(sec, nanosec, OMEGA)
    star(measurement(0))  # after a gyro sample: stale
    assert session.rejection_counts()['attitude_measurement_stale_stamp'] == 1
    assert len(sink.odometries) == 4


def test_with_the_period_a_gyro_sample_waits_for_its_late_measurement(open_scene):
    """The measurement of instant k arrives after the gyro sample of k + 1 (a slow link): the
    sample of k + 1 waits for it, and the outputs are those of a measurement on time."""
    offsets = {k: (2e-4, -1e-4 * math.sin(k), 3e-4) for k in range(10, 101, 10)}
    on_time, sink = open_scene('star_tracker_filter', **GYRO, attitude_measurement_period=0.1)
    feed(on_time, 100, True, offsets)
    late, late_sink = open_scene('star_tracker_filter', **GYRO, attitude_measurement_period=0.1)
    star = input_handler(late, 'attitude_measurement')
    star(measurement(0))
    for k in range(1, 101):
        sec, nanosec = divmod(START_NS + k * PERIOD_NS, 10**9)
        published = len(late_sink.odometries)
        late.gyro(sec, nanosec, OMEGA)
        if k % 10 == 1 and k > 1:
            assert len(late_sink.odometries) == published  # held
            star(measurement(k - 1, offsets[k - 1]))
            assert len(late_sink.odometries) == published + 1  # released
    assert late_sink.odometries == sink.odometries
    assert late.estimation.counts['attitude_late'] == 0


def test_a_missing_measurement_is_given_up_at_the_next_gyro_sample(open_scene):
    session, sink = open_scene('star_tracker_filter', **GYRO, attitude_measurement_period=0.1)
    input_handler(session, 'attitude_measurement')(measurement(0))
    for k in range(1, 13):
        sec, nanosec = divmod(START_NS + k * PERIOD_NS, 10**9)
        session.gyro(sec, nanosec, OMEGA)
    stamps = [sec * 10**9 + nanosec for sec, nanosec, *_ in sink.odometries]
    assert stamps == [START_NS + k * PERIOD_NS for k in range(13)]  # 11 went on at 12
    assert session.estimation.counts['attitude_missing'] == 1
    assert len(session.measurements.samples) == 0  # 12 waits for none: 10 was given up
