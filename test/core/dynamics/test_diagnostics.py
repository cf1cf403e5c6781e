"""Tests of the energy and momentum diagnostics (diagnostics.py) against hand computations.

All quantities are a few products and sums of exactly representable inputs, so they agree with
the hand values to a few round-offs (rtol 1e−15); the drift tests use exact arithmetic.
"""

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.diagnostics import (
    body_angular_momentum, DiagnosticsTracker, kinetic_energy, world_angular_momentum)
from rigid_body_attitude.core.dynamics.inertia import Inertia

INERTIA = Inertia([1.0, 2.0, 3.0])
OMEGA = np.array([1.0, -2.0, 0.5])


def test_kinetic_energy_hand_value():
    # ½ (1·1 + 2·4 + 3·0.25) = 4.875
    assert kinetic_energy(INERTIA, OMEGA) == pytest.approx(4.875, rel=1e-15)
    # + ½ m v² with translation: ½ · 2 · (9 + 16) = 25
    assert kinetic_energy(INERTIA, OMEGA, 2.0, [3.0, 4.0, 0.0]) == pytest.approx(29.875,
                                                                                 rel=1e-15)


def test_kinetic_energy_full_tensor():
    inertia = Inertia([[2.0, -0.5, 0.0], [-0.5, 3.0, 0.25], [0.0, 0.25, 4.0]])
    omega = np.array([1.0, 2.0, -1.0])
    # ½ ωᵀ J ω = ½ (2 + 12 + 4 − 2·0.5·2 − 2·0.25·2) = ½ (18 − 2 − 1) = 7.5
    assert kinetic_energy(inertia, omega) == pytest.approx(7.5, rel=1e-15)


def test_body_and_world_momentum():
    np.testing.assert_allclose(body_angular_momentum(INERTIA, OMEGA), [1.0, -4.0, 1.5],
                               rtol=1e-15)
    np.testing.assert_allclose(body_angular_momentum(INERTIA, OMEGA, [0.0, 1.0, 0.0]),
                               [1.0, -3.0, 1.5], rtol=1e-15)
    # a body turned 90° about z: body x → world y, body y → world −x
    attitude = quat.exp([0.0, 0.0, 0.5 * np.pi])
    np.testing.assert_allclose(world_angular_momentum(attitude, INERTIA, OMEGA),
                               [4.0, 1.0, 1.5], atol=1e-15)
    np.testing.assert_allclose(world_angular_momentum(attitude, INERTIA, OMEGA, [0.0, 1.0, 0.0]),
                               [3.0, 1.0, 1.5], atol=1e-15)


def test_world_momentum_invariant_under_attitude_sign():
    attitude = quat.normalize([0.3, -0.1, 0.7, 0.2])
    np.testing.assert_allclose(world_angular_momentum(-attitude, INERTIA, OMEGA),
                               world_angular_momentum(attitude, INERTIA, OMEGA), atol=0)


def test_tracker_drift_and_energy_balance():
    tracker = DiagnosticsTracker(4.0, np.array([3.0, 0.0, 4.0]))
    tracker.add_work(0.5)
    tracker.add_work(0.25)
    snapshot = tracker.snapshot([1.0, 0.0, 0.0, 1e-3], 5.0, np.array([3.0, 0.0, 4.5]))
    assert snapshot.kinetic_energy == 5.0
    assert snapshot.energy_drift == 0.25              # (5 − 4)/4
    assert snapshot.energy_balance_residual == 0.25   # 5 − 4 − 0.75
    assert snapshot.momentum_drift == 0.1             # 0.5/5
    np.testing.assert_array_equal(snapshot.world_angular_momentum, [3.0, 0.0, 4.5])
    assert snapshot.quaternion_norm_error == pytest.approx(5e-7, rel=1e-6)  # √(1+1e−6) − 1


def test_tracker_absolute_drift_from_rest():
    # T₀ = 0 and H₀ = 0 (a body at rest): the drifts are absolute, not divided by zero
    tracker = DiagnosticsTracker(0.0, np.zeros(3))
    snapshot = tracker.snapshot(quat.identity(), 0.125, np.array([0.0, 0.0, 0.5]))
    assert snapshot.energy_drift == 0.125
    assert snapshot.momentum_drift == 0.5
    assert snapshot.energy_balance_residual == 0.125
    assert snapshot.quaternion_norm_error == 0.0
