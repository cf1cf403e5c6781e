"""The hard-iron sphere fit: learns a body-fixed offset, refuses what is not one."""

import math

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.hard_iron import HardIronFit

FIELD = np.array([0.0, 18e-6, -45e-6])  # ENU, 48.5 µT
NORM = float(np.linalg.norm(FIELD))
INTERVAL = 0.05


def turning_fields(seconds, offset, seed=3, noise=0.3e-6):
    """Interval means of the body-frame field of a body turning about several axes, with a
    hard-iron ``offset`` [T] and noise."""
    rng = np.random.default_rng(seed)
    fields = []
    for k in range(int(seconds / INTERVAL)):
        t = k * INTERVAL
        q = quaternion.exp(np.array([1.1 * math.sin(0.7 * t), 0.9 * math.cos(0.5 * t),
                                     2.0 * math.sin(0.3 * t)]))
        fields.append(quaternion.rotate_inverse(q, FIELD) + offset
                      + rng.normal(0.0, noise, 3))
    return fields


def test_hard_iron_fit_learns_a_body_fixed_offset():
    fit = HardIronFit(10.0, 0.1)
    offset = np.array([-3.5e-6, 0.2e-6, 27e-6])
    learned = None
    for field in turning_fields(40.0, offset):
        fit.add(field, INTERVAL)
        learned = fit.learned(NORM)
        if learned is not None:
            break
    assert learned is not None
    np.testing.assert_allclose(learned, offset, atol=0.5e-6)


def test_hard_iron_fit_refuses_a_small_offset():
    fit = HardIronFit(10.0, 0.1)
    for field in turning_fields(40.0, np.array([0.2e-6, 0.0, 0.0])):
        fit.add(field, INTERVAL)
        assert fit.learned(NORM) is None


def test_hard_iron_fit_refuses_a_field_that_changes_with_the_place():
    """A magnet passed by: the outside field changes along the path, the body's attitude
    does not explain it, and nothing is learned."""
    fit = HardIronFit(10.0, 0.1)
    fields = turning_fields(40.0, np.zeros(3))
    for k, field in enumerate(fields):
        near = math.exp(-((k * INTERVAL % 8.0) - 4.0) ** 2)  # every 8 s, a 20 µT bump
        fit.add(field + np.array([20e-6, 0.0, -10e-6]) * near, INTERVAL)
        assert fit.learned(NORM) is None


def test_hard_iron_fit_refuses_a_body_at_rest():
    fit = HardIronFit(10.0, 0.1)
    for _ in range(800):
        fit.add(FIELD + np.array([5e-6, 0.0, 0.0]), INTERVAL)
        assert fit.learned(NORM) is None
