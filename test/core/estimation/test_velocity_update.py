"""The bounded-velocity channel of the attitude filter: its measured power and its model."""

import math

import numpy as np

from rigid_body_attitude.core.estimation.filter_covariance import (
    FILTER_STATE_SIZE, VELOCITY, VELOCITY_START)
from rigid_body_attitude.core.estimation.velocity_update import (
    BoundedVelocity, VelocityPower, velocity_change_measurement)

INTERVAL = 0.05
NOISE = 3e-3


def test_velocity_power_at_rest_is_the_noise_floor():
    power = VelocityPower(0.5, 1.0, NOISE)
    for _ in range(200):
        decay, variance = power.step(np.zeros(3), INTERVAL)
    assert power.power == NOISE ** 2 * 0.5
    assert decay == math.exp(-INTERVAL / 0.5)
    assert variance < 1e-6


def test_velocity_power_measures_a_swing():
    """A hand swinging at 1 Hz with 0.5 m/s amplitude: the Gauss-Markov σ_v² it is given
    covers the swing's variance (0.125 m²/s² per axis) within a factor of four."""
    power = VelocityPower(0.5, 1.0, NOISE)
    times = np.arange(0.0, 20.0, INTERVAL)
    velocity = 0.5 * np.sin(2.0 * math.pi * times)
    for change in np.diff(velocity):
        power.step(np.full(3, change), INTERVAL)
    sigma2 = power.power / (2.0 * (1.0 - math.exp(-1.0)))
    assert 0.125 <= sigma2 <= 4 * 0.125


def test_velocity_power_rises_at_once_with_a_blow():
    power = VelocityPower(0.5, 1.0, NOISE)
    for _ in range(40):
        _, quiet = power.step(np.zeros(3), INTERVAL)
    _, variance = power.step(np.array([1.0, 0.0, 0.0]), INTERVAL)
    assert variance > 1e4 * quiet
    assert math.sqrt(variance) > 0.2  # the blow's 1 m/s is 5 sigma of one axis's step


def test_velocity_change_has_no_heading_column():
    h, y, r = velocity_change_measurement(np.array([0.3, -0.2, 0.49]), np.eye(3), INTERVAL,
                                          9.81, np.array([0.0, 0.0, 1.0]), np.zeros(3), NOISE)
    assert h.shape == (3, FILTER_STATE_SIZE)
    assert np.all(h[:, 2] == 0.0)
    assert np.array_equal(h[:, VELOCITY], np.eye(3))
    assert np.array_equal(h[:, VELOCITY_START], -np.eye(3))
    np.testing.assert_allclose(y, [0.3, -0.2, 0.49 - 9.81 * INTERVAL])
    np.testing.assert_allclose(r, np.eye(3) * NOISE ** 2 * INTERVAL)


def test_velocity_turns_with_a_heading_correction():
    channel = BoundedVelocity(0.5, 1.0, NOISE, 0.01)
    channel.velocity = np.array([1.0, 0.0, 0.2])
    dx = np.zeros(FILTER_STATE_SIZE)
    dx[2] = math.pi / 2
    channel.inject(dx)
    np.testing.assert_allclose(channel.velocity, [0.0, 1.0, 0.2], atol=1e-15)
