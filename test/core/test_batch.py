"""TorqueFreeBatch (N bodies at once) against the single-body ``rk4`` integrator, body by body.

The batch integrates each body in its principal frame with the same classical RK4 and
renormalisation as :class:`~rigid_body_attitude.core.integrators.rigid_body_rk4.RigidBodyRk4`; RK4
commutes with a constant linear change of variables, so each body must match the single-body
result up to round-off. The issue asks for 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.batch import TorqueFreeBatch
from rigid_body_attitude.core.integrators import dynamics_integrator
from rigid_body_attitude.core.integrators.base import SimpleBodyModel

#: Bodies per test, step [s] and steps: 0.2 s of motion at |ω| up to 3 rad/s.
BODIES = 40
STEP = 1e-3
STEPS = 200
#: Round-off only: the principal-frame change of variables (eigh: axes and moments to a few ε
#: relative for the well-separated moments drawn here) and a different operation order,
#: each step rounding O(1) components a few times: 200 steps × ~10 ε ≈ 4e-13 < 1e-12.
AGREEMENT = 1e-12


def dispersion(count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Monte-Carlo dispersion: per-body inertia tensors (random principal moments with gaps
    ≥ 0.2 kg m² and random principal axes), unit attitudes and body rates up to 3 rad/s."""
    rng = np.random.default_rng(seed)
    tensors = np.empty((count, 3, 3))
    for index in range(count):
        moments = np.array([1.0, 1.2, 1.4]) + np.sort(rng.uniform(0.0, 0.5, 3)) * [1, 1.4, 1.8]
        axes = quaternion.to_matrix(quaternion.normalize(rng.normal(size=4)))
        tensors[index] = axes @ np.diag(moments) @ axes.T
    attitudes = quaternion.normalize(rng.normal(size=(count, 4)))
    omegas = rng.uniform(-1.0, 1.0, (count, 3)) * 3.0 / np.sqrt(3.0)
    return tensors, attitudes, omegas


def single_body(tensor: np.ndarray, attitude: np.ndarray, omega: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The ``rk4`` integrator on one body for the same steps."""
    return dynamics_integrator('rk4').integrate(attitude, omega, 0.0, STEP, STEPS,
                                                SimpleBodyModel(tensor))


@pytest.mark.parametrize('chunk', [7, 4096])  # several chunks with a ragged last one, and one
def test_batch_matches_single_body_rk4_per_body(chunk):
    tensors, attitudes, omegas = dispersion(BODIES, seed=7)
    batch = TorqueFreeBatch(tensors, attitudes, omegas, chunk=chunk)
    batch.rk4(STEP, STEPS)
    for index in range(BODIES):
        attitude, omega = single_body(tensors[index], attitudes[index], omegas[index])
        assert np.max(np.abs(batch.attitude[index] - attitude)) <= AGREEMENT, index
        assert np.max(np.abs(batch.omega_body[index] - omega)) <= AGREEMENT, index


def test_batch_with_one_inertia_for_all_bodies_matches_single_body_rk4():
    tensors, attitudes, omegas = dispersion(BODIES, seed=8)
    batch = TorqueFreeBatch(tensors[0], attitudes, omegas)
    batch.rk4(STEP, STEPS // 2)
    batch.rk4(STEP, STEPS // 2)  # two calls give the steps of one
    for index in range(BODIES):
        attitude, omega = single_body(tensors[0], attitudes[index], omegas[index])
        assert np.max(np.abs(batch.attitude[index] - attitude)) <= AGREEMENT, index
        assert np.max(np.abs(batch.omega_body[index] - omega)) <= AGREEMENT, index


def test_batch_invariants_agree_with_the_single_body_state():
    tensors, attitudes, omegas = dispersion(BODIES, seed=9)
    batch = TorqueFreeBatch(tensors, attitudes, omegas)
    batch.rk4(STEP, STEPS)
    for index in range(BODIES):
        attitude, omega = single_body(tensors[index], attitudes[index], omegas[index])
        energy = 0.5 * omega @ tensors[index] @ omega
        momentum = quaternion.rotate(attitude, tensors[index] @ omega)
        # Energies of ~5 J and momenta of ~5 N m s from states equal to 1e-12 (above):
        # relative 1e-12 of the size, the same round-off argument.
        assert batch.kinetic_energy()[index] == pytest.approx(energy, rel=1e-12)
        np.testing.assert_allclose(batch.world_angular_momentum()[index], momentum,
                                   rtol=0.0, atol=1e-11)
