"""AttitudeCovariance: closed forms at rest and about one axis, batching, resets, hostile input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.attitude_covariance import (
    AttitudeCovariance, transition_blocks)
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.gyro_error_model import (
    GRAVITY,
    GyroErrorModel,
    initial_covariance,
    levelled_tilt_stddev,
)

IDENTITY = (1.0, 0.0, 0.0, 0.0)


def test_at_rest_the_variance_grows_as_n2_t_plus_bias_t2_plus_k2_t3_over_3():
    model = GyroErrorModel(gyroscope_noise_density=2e-4, gyroscope_random_walk=3e-5)
    covariance = AttitudeCovariance(model, window_seconds=2.0)
    dt, steps = 0.001, 30000
    covariance.add_samples(np.tile(IDENTITY, (steps, 1)), np.zeros((steps, 3)), dt)
    t = dt * steps
    tilt0 = levelled_tilt_stddev(model, 2.0)
    bias0 = model.gyroscope_noise_density ** 2 / 2.0
    expected = (tilt0 ** 2 + model.gyroscope_noise_density ** 2 * t + bias0 * t * t
                + model.gyroscope_random_walk ** 2 * t ** 3 / 3.0)
    assert covariance.attitude_covariance[0, 0] == pytest.approx(expected, rel=1e-6)
    yaw = math.pi ** 2 + expected - tilt0 ** 2
    assert covariance.attitude_covariance[2, 2] == pytest.approx(yaw, rel=1e-9)


def test_a_scale_error_grows_with_the_angle_turned_about_a_fixed_axis():
    """Turning by θ about z with scale error σ_s gives an extra σ_s θ about world z."""
    model = GyroErrorModel(gyroscope_noise_density=0.0, gyroscope_random_walk=0.0,
                           gyroscope_scale_stddev=0.01, initial_yaw_stddev=0.0)
    covariance = AttitudeCovariance(model, window_seconds=1e6)
    dt, steps, rate = 0.01, 500, 2.0
    stamps = np.arange(steps) * dt
    q = quaternion.exp(np.outer(stamps * rate, [0.0, 0.0, 1.0]))
    covariance.add_samples(q, np.tile([0.0, 0.0, rate], (steps, 1)), dt)
    angle = rate * dt * steps
    assert math.sqrt(covariance.attitude_covariance[2, 2]) == pytest.approx(
        0.01 * angle, rel=1e-9)


def test_scale_and_misalignment_errors_cancel_when_the_body_turns_back():
    """The transition uses the signed rates: turning by θ about a tilted axis and back leaves
    no scale or misalignment error (as in the sensor: the same errors, opposite angles), while
    the same turns in one direction leave one that grows with the angle."""
    model = GyroErrorModel(gyroscope_noise_density=0.0, gyroscope_random_walk=0.0,
                           gyroscope_scale_stddev=0.01, gyroscope_misalignment_stddev=0.01,
                           initial_yaw_stddev=0.0)
    dt, steps = 0.002, 400
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    start = initial_covariance(model, 1e6)[:3, :3]

    def turned(signs: np.ndarray) -> np.ndarray:
        rates = np.outer(signs * 3.0, axis)
        angles = np.concatenate([[0.0], np.cumsum(signs * 3.0 * dt)[:-1]])
        covariance = AttitudeCovariance(model, window_seconds=1e6)
        covariance.add_samples(quaternion.exp(np.outer(angles, axis)), rates, dt)
        return covariance.attitude_covariance - start

    back = turned(np.concatenate([np.ones(steps), -np.ones(steps)]))
    on = turned(np.ones(2 * steps))
    assert np.abs(back).max() < 1e-12 * np.abs(on).max()
    assert np.trace(on) > (0.01 * 3.0 * 2 * steps * dt) ** 2


def test_batches_of_any_size_give_the_transition_of_single_steps():
    rng = np.random.default_rng(3)
    steps = 96
    q = quaternion.normalize(rng.normal(size=(steps, 4)))
    rates = rng.normal(size=(steps, 3)) * 4.0
    model = GyroErrorModel(gyroscope_random_walk=0.0)
    one = AttitudeCovariance(model, batch_size=1)
    many = AttitudeCovariance(model, batch_size=32)
    for row in range(steps):
        one.add_sample(tuple(q[row]), tuple(rates[row]), 0.002)
        many.add_sample(tuple(q[row]), tuple(rates[row]), 0.002)
    np.testing.assert_allclose(many.covariance, one.covariance, rtol=1e-10, atol=1e-18)
    whole = transition_blocks(q, rates, np.full(steps, 0.002))
    parts = sum(transition_blocks(q[i:i + 1], rates[i:i + 1], np.full(1, 0.002))
                for i in range(steps))
    np.testing.assert_allclose(whole, parts, rtol=1e-12, atol=1e-15)


def test_the_covariance_stays_symmetric_positive_definite_and_finite():
    rng = np.random.default_rng(5)
    covariance = AttitudeCovariance(batch_size=7)
    for _ in range(2000):
        covariance.add_sample(tuple(quaternion.normalize(rng.normal(size=4))),
                              tuple(rng.normal(size=3) * 10.0), 0.001)
    p = covariance.covariance
    assert np.all(np.isfinite(p))
    np.testing.assert_array_equal(p, p.T)
    assert np.linalg.eigvalsh(p)[0] > 0.0
    sigma = covariance.stddev()
    assert sigma.tilt >= max(sigma.world_x, sigma.world_y) > 0.0


def test_levelled_tilt_and_initial_bias_follow_the_window():
    model = GyroErrorModel(accelerometer_noise_density=0.002, accelerometer_bias_stddev=0.05)
    expected = math.sqrt((0.002 / GRAVITY) ** 2 / 4.0 + (0.05 / GRAVITY) ** 2)
    assert levelled_tilt_stddev(model, 4.0) == pytest.approx(expected, rel=1e-12)
    p = initial_covariance(model, 4.0, yaw_stddev=0.1)
    np.testing.assert_allclose(np.diag(p)[:6], [expected ** 2] * 2 + [0.01]
                               + [model.gyroscope_noise_density ** 2 / 4.0] * 3)
    unlevelled = initial_covariance(model, None)
    assert unlevelled[3, 3] == pytest.approx(model.gyroscope_turn_on_bias ** 2)


def test_set_pose_replaces_the_attitude_block_and_clears_its_correlations():
    covariance = AttitudeCovariance()
    covariance.add_samples(np.tile(IDENTITY, (100, 1)), np.tile([1.0, 2.0, 3.0], (100, 1)), 0.01)
    covariance.set_pose(stddev=0.02)
    p = covariance.covariance
    np.testing.assert_allclose(p[:3, :3], np.eye(3) * 4e-4)
    assert not p[:3, 3:].any()
    given = np.array([[1e-4, 2e-5, 0.0], [2e-5, 1e-4, 0.0], [0.0, 0.0, 9e-4]])
    covariance.set_pose(covariance=given)
    np.testing.assert_array_equal(covariance.attitude_covariance, given)


@pytest.mark.parametrize('bad, message', [
    (np.eye(2), 'shape'),
    (np.diag([1.0, 1.0, np.nan]), 'finite'),
    (np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), 'symmetric'),
    (np.diag([1.0, -1.0, 1.0]), 'semi-definite'),
])
def test_set_pose_rejects_a_covariance_that_is_not_one(bad, message):
    with pytest.raises(InputError, match=message):
        AttitudeCovariance().set_pose(covariance=bad)


@pytest.mark.parametrize('kwargs', [{'gyroscope_noise_density': -1.0},
                                    {'gyroscope_random_walk': float('inf')},
                                    {'initial_yaw_stddev': 'large'}])
def test_the_error_model_names_the_bad_field(kwargs):
    with pytest.raises(InputError, match=next(iter(kwargs))):
        GyroErrorModel(**kwargs)


def test_bad_steps_are_dropped_and_counted():
    covariance = AttitudeCovariance(batch_size=4)
    before = covariance.covariance
    for dt in (float('nan'), -0.01, 0.0, float('inf')):
        covariance.add_sample(IDENTITY, (0.0, 0.0, 1.0), dt)
    np.testing.assert_array_equal(covariance.covariance, before)
    assert covariance.rejected_samples == 4
    with pytest.raises(InputError, match='batch_size'):
        AttitudeCovariance(batch_size=0)
    with pytest.raises(InputError, match='per sample'):
        covariance.add_sample((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.01)  # type: ignore[arg-type]
        covariance.covariance
    np.testing.assert_array_equal(covariance.covariance, before)


def test_the_transition_block_is_the_integral_of_the_rotation_over_the_step():
    """Against ``∫ R(q) expm(τ [ω×]) dτ`` by scipy quadrature, small and large steps (series
    and closed-form branches)."""
    from scipy.integrate import quad_vec
    from scipy.linalg import expm
    rng = np.random.default_rng(1)
    q = rng.normal(size=(5, 4)) * 1.7
    rates = rng.normal(size=(5, 3)) * 3.0
    dt = np.array([0.001, 0.01, 0.1, 0.5, 1e-6])
    expected = np.zeros((3, 12))
    for k in range(5):
        rotation = quaternion.to_matrix(q[k])
        w = rates[k]
        skew = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        m = quad_vec(lambda tau: rotation @ expm(skew * tau), 0.0, dt[k], epsabs=1e-14)[0]
        expected[:, :3] -= m
        expected[:, 3:] -= (m[:, :, None] * w[None, None, :]).reshape(3, 9)
    np.testing.assert_allclose(transition_blocks(q, rates, dt), expected, rtol=0, atol=1e-13)
    per_row = sum(transition_blocks(q[i:i + 1], rates[i:i + 1], dt[i:i + 1]) for i in range(5))
    np.testing.assert_allclose(per_row, expected, rtol=0, atol=1e-13)
