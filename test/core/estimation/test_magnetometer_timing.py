"""The magnetometer's delay measured from gyro and magnetometer samples alone."""

import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.magnetometer_timing import magnetometer_delay

RATE = 200.0
FIELD_WORLD = np.array([0.0, 18.0, -45.0])  # µT, ENU


def recording(delay_samples, seconds=30.0, hard_iron=(1.5, -0.8, 0.6), seed=2):
    """A body turning about several axes; its gyro, and its magnetometer ``delay_samples``
    late (linear interpolation) with a hard-iron offset and noise."""
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, seconds, 1.0 / RATE)
    rates = np.stack([2.0 * np.sin(1.3 * times), 1.5 * np.cos(0.9 * times + 1.0),
                      1.8 * np.sin(0.7 * times + 2.0)], axis=1)
    q = np.array([1.0, 0.0, 0.0, 0.0])
    fields = []
    for rate in rates:
        q = quaternion.scalar_exp_step(tuple(q), tuple(rate), 1.0 / RATE)
        fields.append(quaternion.rotate_inverse(np.array(q), FIELD_WORLD))
    fields = np.array(fields)
    index = np.arange(times.size) - delay_samples
    late = np.stack([np.interp(index, np.arange(times.size), fields[:, k]) for k in range(3)],
                    axis=1)
    return rates + rng.normal(0.0, 0.002, rates.shape), late + hard_iron + rng.normal(
        0.0, 0.3, late.shape)


@pytest.mark.parametrize('delay_samples', [0.0, 2.0, 3.3])
def test_magnetometer_delay_finds_the_delay(delay_samples):
    rates, fields = recording(delay_samples)
    fit = magnetometer_delay(rates, fields, RATE)
    assert abs(fit.delay * RATE - delay_samples) < 0.15
    np.testing.assert_allclose(fit.hard_iron, (1.5, -0.8, 0.6), atol=0.2)
    assert fit.residual <= fit.residual_at_zero


def test_magnetometer_delay_refuses_a_still_recording():
    rates, fields = recording(2.0)
    with pytest.raises(InputError, match='turning'):
        magnetometer_delay(rates * 0.01, fields, RATE)


def test_magnetometer_delay_refuses_bad_arrays():
    rates, fields = recording(2.0, seconds=10.0)
    with pytest.raises(InputError, match='shape'):
        magnetometer_delay(rates, fields[:, :2], RATE)
    fields[5, 1] = math.nan
    with pytest.raises(InputError, match='finite'):
        magnetometer_delay(rates, fields, RATE)
