"""A dynamics session with a simulated IMU: samples at the sensor instants, on the clock's
time axis, as Imu messages with REP-145 covariances; deterministic; reset and set_pose."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.attitude.integrators import strapdown_method
from rigid_body_attitude.msgs.decoders import parse_stamped
from rigid_body_attitude.msgs.decoders import IMU_COUNT
from rigid_body_attitude.msgs.types import IMU

from conftest import MS

START_NS = 1_700_000_000 * 10**9  # a whole second: sample instants are multiples of 5 ms
QUIET = dict(gyroscope_noise_density=0.0, gyroscope_random_walk=0.0,
             gyroscope_turn_on_bias=0.0, gyroscope_scale_stddev=0.0,
             gyroscope_misalignment_stddev=0.0, accelerometer_noise_density=0.0,
             accelerometer_turn_on_bias=0.0)


def scene_file(tmp_path, imu, effects=(), omega=(0.3, 2.0, 0.1)):
    path = tmp_path / 'sensed.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'sensed', 'rate_source': 'dynamics', 'step': 0.001,
        'body': {'mass': 2.0, 'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': list(omega)}, 'effects': list(effects),
        'sensors': {'imu': {'rate': 200.0, 'frame_id': 'imu_link', **imu}}}))
    return str(path)


def decoded(data):
    """(stamp_ns, frame_id, body floats) of one Imu."""
    parsed = parse_stamped(data, IMU, IMU_COUNT)
    return parsed.sec * 10**9 + parsed.nanosec, parsed.frame_id, parsed.body


def run(session, ticks_ns):
    for now in ticks_ns:
        session.tick(now)


def test_samples_come_at_every_multiple_of_the_period_whatever_the_ticks(
        open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, {'seed': 4}))
    jitter = np.random.default_rng(1).integers(0, 15 * MS, size=60)
    ticks = [START_NS + 3 * MS + k * 20 * MS + int(j) for k, j in enumerate(jitter)]
    run(session, ticks)
    stamps = [decoded(data)[0] for _, data in sink.simulated]
    assert all(topic == 'imu' for topic, _ in sink.simulated)
    assert np.all(np.diff(stamps) == 5 * MS) and stamps[0] % (5 * MS) == 0
    # the first instant after the start is the baseline; samples up to the last tick
    baseline = -(-ticks[0] // (5 * MS)) * 5 * MS
    assert stamps[0] == baseline + 5 * MS
    assert ticks[-1] - 5 * MS < stamps[-1] <= ticks[-1]


def test_the_message_is_rep_145_in_the_sensor_frame(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, {'gyroscope_noise_density': 1e-3,
                                                     'accelerometer_noise_density': 2e-3,
                                                     'gyroscope_resolution': 1e-3}))
    run(session, [START_NS, START_NS + 20 * MS])
    _, frame_id, body = decoded(sink.simulated[0][1])
    assert frame_id == 'imu_link'
    assert body[:4] == (0.0, 0.0, 0.0, 1.0) and body[4] == -1.0  # orientation not provided
    gyro_covariance, acc_covariance = np.reshape(body[16:25], (3, 3)), np.reshape(body[28:37],
                                                                                  (3, 3))
    assert gyro_covariance == pytest.approx(np.eye(3) * (1e-6 * 200.0 + 1e-6 / 12.0))
    assert acc_covariance == pytest.approx(np.eye(3) * 4e-6 * 200.0)


def test_noise_free_samples_integrate_to_the_dynamics_truth(open_scene, tmp_path):
    """Mean rates over each interval: delta_single from the truth at the baseline instant
    lands on the truth at a later tick (round-off)."""
    session, sink = open_scene(scene_file(tmp_path, QUIET))
    session.tick(START_NS)
    start = session.propagator.state.attitude_tuple()
    session.tick(START_NS + 1000 * MS)
    truth = session.propagator.state.attitude_tuple()
    method, estimate = strapdown_method('delta_single'), start
    samples = [decoded(data)[2][13:16] for _, data in sink.simulated]
    assert len(samples) == 200
    for rate in samples:
        estimate = method.propagate(estimate, rate, rate, 0.005)
    assert quaternion.attitude_error(estimate, truth) < 1e-12


def test_tick_grouping_does_not_change_a_sample(open_scene, tmp_path):
    path = scene_file(tmp_path, {'seed': 9})
    first, first_sink = open_scene(path)
    second, second_sink = open_scene(path)
    run(first, [START_NS + k * 10 * MS for k in range(101)])
    run(second, [START_NS + k * 25 * MS for k in range(41)])
    assert len(first_sink.simulated) == 200  # 5 ms to 1 s; the start is the baseline
    assert first_sink.simulated == second_sink.simulated


def test_a_reset_starts_the_sensor_again_from_its_seed(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, {'seed': 2}))
    run(session, [START_NS + k * 10 * MS for k in range(11)])
    before = [decoded(data)[2] for _, data in sink.simulated]
    session.reset()
    sink.simulated.clear()
    run(session, [START_NS + (11 + k) * 10 * MS for k in range(11)])
    after = [decoded(data)[2] for _, data in sink.simulated]
    assert len(after) == len(before) == 20
    # the same constants and noise; the motion again, on a time axis 0.1 s later (round-off)
    assert np.array(after) == pytest.approx(np.array(before), rel=1e-12, abs=1e-15)


def test_set_pose_makes_the_next_instant_a_baseline(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, QUIET, omega=(0.0, 0.0, 0.5)))
    run(session, [START_NS, START_NS + 50 * MS])
    session.set_pose('world', (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    count = len(sink.simulated)
    run(session, [START_NS + 100 * MS])
    rates = [decoded(data)[2][13:16] for _, data in sink.simulated]
    assert len(rates) == count + 10  # the pose's instant (50 ms) is a baseline
    assert all(rate == pytest.approx((0.0, 0.0, 0.5), abs=1e-12) for rate in rates)


def test_held_body_feels_the_sections_gravity_and_free_fall_feels_none(open_scene, tmp_path):
    held, held_sink = open_scene(scene_file(tmp_path, {**QUIET, 'gravity': [0, 0, -9.8]},
                                            omega=(0.0, 0.0, 0.0)))
    run(held, [START_NS, START_NS + 20 * MS])
    assert decoded(held_sink.simulated[0][1])[2][25:28] == pytest.approx((0.0, 0.0, 9.8))
    falling_scene = scene_file(tmp_path, QUIET, ['translation', 'uniform_gravity'],
                               omega=(0.0, 0.0, 0.0))
    falling, falling_sink = open_scene(falling_scene)
    run(falling, [START_NS, START_NS + 20 * MS])
    assert decoded(falling_sink.simulated[0][1])[2][25:28] == pytest.approx((0.0, 0.0, 0.0),
                                                                            abs=1e-9)
    assert math.isfinite(falling.propagator.state.position[2])
