"""Tests of gyro_bias: ω = ω_measured − b, b given or estimated over an initial rest window.

During the window the corrected rate is zero, so the strapdown attitude holds still exactly
(exp(0) = 1); afterwards b is the mean of the window's samples and the attitude follows the
exp-map closed form of the corrected rates (exact per step: a few round-offs).
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import BodyProperties, EFFECTS
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.propagator import GyroPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.session.stream import GyroStream

BODY = BodyProperties(Inertia([1.0, 1.0, 1.0]), 1.0)
BIAS = np.array([0.01, -0.02, 0.005])
DT = 1.0 / 64.0          # stamps k/64 are exact in binary, so the window edge is exact
Q0 = quat.normalize([0.9, 0.1, -0.3, 0.2])


def test_given_bias_is_subtracted():
    effect = EFFECTS['gyro_bias']({'bias': BIAS.tolist()}, BODY)
    np.testing.assert_array_equal(effect.corrected_rate(0.0, quat.identity(),
                                                        np.array([0.11, 0.08, 0.105])),
                                  np.array([0.11, 0.08, 0.105]) - BIAS)


def stream_with_estimate(seconds):
    scene = scene_from_mapping({'rate_source': 'gyro', 'integrator': 'exp_map',
                                'body': {'inertia': {'moments': [1, 1, 1]}},
                                'initial_state': {'attitude': Q0.tolist()},
                                'effects': [{'gyro_bias': {'estimate_seconds': seconds}}]})
    propagator = GyroPropagator(scene)
    return GyroStream(propagator, max_dt=0.1, time_jump_threshold=1.0)


def test_bias_estimated_at_rest_is_the_sample_mean():
    stream = stream_with_estimate(1.0)
    effect = stream.propagator.effects[0]
    noise = np.random.default_rng(2).normal(scale=1e-3, size=(64, 3))
    window = BIAS + noise
    for k in range(64):                                  # t = 0 … 63/64 < 1 s: the window
        stream.add(round(k * DT * 1e9), window[k])
        # the body is at rest and the corrected rate is zero: the attitude does not move
        np.testing.assert_array_equal(stream.propagator.state.attitude, Q0)
        np.testing.assert_array_equal(stream.propagator.state.omega_body, np.zeros(3))
    assert effect.estimating
    omega_true = np.array([0.3, -0.1, 0.2])
    for k in range(64, 128):                             # from t = 1 s: the body turns
        stream.add(round(k * DT * 1e9), BIAS + omega_true)
    assert not effect.estimating
    assert effect.sample_count == 64
    # the estimate is the window's mean (summation order: a few round-offs)
    np.testing.assert_allclose(effect.bias, window.mean(axis=0), rtol=1e-14)
    # exp-map with the held rate: the interval [1, 2 − 1/64] at ω_true + (b − mean)
    corrected = omega_true + BIAS - window.mean(axis=0)
    np.testing.assert_allclose(stream.propagator.state.omega_body, corrected, atol=1e-17)
    expected = quat.multiply(Q0, quat.exp(corrected * 63 * DT))
    assert quat.attitude_error(stream.propagator.state.attitude, expected) <= 64 * 4e-16


def test_time_jump_restarts_the_estimate():
    stream = stream_with_estimate(0.5)
    effect = stream.propagator.effects[0]
    for k in range(64):
        stream.add(round((10.0 + k * DT) * 1e9), BIAS)
    assert not effect.estimating
    np.testing.assert_allclose(effect.bias, BIAS, rtol=1e-14)
    # A looping bag: the jump back is taken when two more samples confirm it, then reset.
    assert stream.add(0, 2.0 * BIAS).pending and stream.add(round(DT * 1e9), 2.0 * BIAS).pending
    assert stream.add(round(2 * DT * 1e9), 2.0 * BIAS).reason == 'time_jump'
    assert effect.estimating and effect.sample_count == 3
    for k in range(3, 40):
        stream.add(round(k * DT * 1e9), 2.0 * BIAS)
    np.testing.assert_allclose(effect.bias, 2.0 * BIAS, rtol=1e-14)
    np.testing.assert_array_equal(stream.propagator.state.attitude, Q0)


def test_negative_window_rejected():
    with pytest.raises(SceneError, match=re.escape(
            "Effect 'gyro_bias': parameter 'estimate_seconds' must be a number >= 0, got -1")):
        EFFECTS['gyro_bias']({'estimate_seconds': -1}, BODY)
