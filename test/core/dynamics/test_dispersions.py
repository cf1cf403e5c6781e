"""Dispersion sampling: per-run streams, Haar SO(3), cones, physical inertia."""

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.dispersions import (
    cone_quaternions, dispersed_inertia, perturbed_tensors, RunStreams, second_moments,
    uniform_quaternions)
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.dynamics.inertia import Inertia


def test_a_runs_draws_do_not_depend_on_the_other_runs_requested():
    everything = RunStreams(42, np.arange(1000))
    some = RunStreams(42, [999, 3, 500])
    assert np.array_equal(some.bits(5, 7), everything.bits(5, 7)[[999, 3, 500]])
    assert np.array_equal(some.normal(1, 3), everything.normal(1, 3)[[999, 3, 500]])
    assert np.array_equal(some.seeds(), everything.seeds()[[999, 3, 500]])


def test_streams_differ_between_seeds_runs_and_categories():
    a, b = RunStreams(1, np.arange(100)), RunStreams(2, np.arange(100))
    assert not np.any(a.bits(0, 4) == b.bits(0, 4))
    words = np.concatenate([a.bits(0, 4).ravel(), a.bits(1, 4).ravel()])
    assert np.unique(words).size == words.size


def test_uniforms_and_normals_have_their_moments():
    streams = RunStreams(7, np.arange(200_000))
    u = streams.uniform(0, 1)[:, 0]
    assert 0.0 <= u.min() and u.max() < 1.0
    assert abs(u.mean() - 0.5) < 3e-3 and abs(u.var() - 1 / 12) < 2e-3
    n = streams.normal(1, 1)[:, 0]
    assert abs(n.mean()) < 1e-2 and abs(n.std() - 1.0) < 1e-2
    assert abs(np.mean(n ** 4) - 3.0) < 0.1  # Gaussian kurtosis


def test_uniform_quaternions_are_haar_distributed():
    q = uniform_quaternions(RunStreams(3, np.arange(200_000)).uniform(0, 3))
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    # Haar: rotation angle density (1 - cos θ)/π, so E[cos θ] = -1/2 ... and any fixed axis
    # maps to a uniform direction on the sphere (mean 0, second moment 1/3 per component).
    angle = 2.0 * np.arccos(np.clip(np.abs(q[:, 0]), 0.0, 1.0))
    assert abs(np.mean(np.cos(angle)) + 0.5) < 5e-3
    z = quaternion.rotate(q, np.array([0.0, 0.0, 1.0]))
    assert np.all(np.abs(z.mean(axis=0)) < 5e-3)
    assert np.allclose((z ** 2).mean(axis=0), 1 / 3, atol=5e-3)
    # Euler angles drawn uniformly would fail this: their z axis crowds the poles.


def test_cone_quaternions_stay_within_the_cone_with_haar_density():
    nominal = quaternion.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    half_angle = np.radians(10.0)
    q = cone_quaternions(nominal, half_angle, RunStreams(4, np.arange(100_000)).uniform(0, 3))
    error = quaternion.attitude_error(np.broadcast_to(nominal, q.shape), q)
    assert np.max(error) <= half_angle * (1 + 1e-12)
    # Haar density ∝ 1 - cos θ ≈ θ²/2 on a small ball: P(θ < α/2) = 1/8 (to O(α²)).
    assert abs(np.mean(error < half_angle / 2) - 0.125) < 5e-3
    whole = cone_quaternions(nominal, np.pi, RunStreams(4, np.arange(100_000)).uniform(0, 3))
    angle = quaternion.attitude_error(np.broadcast_to(nominal, whole.shape), whole)
    assert abs(np.mean(np.cos(angle)) + 0.5) < 1e-2


def test_dispersed_inertia_is_always_physical_and_centred():
    moments = np.array([500.0, 200.0, 300.0])
    streams = RunStreams(5, np.arange(50_000))
    tensors = dispersed_inertia(moments, np.eye(3), 0.5, streams.normal(1, 3),
                                uniform_quaternions(streams.uniform(2, 3)))
    eigen = np.linalg.eigvalsh(tensors)
    assert np.all(eigen[:, 0] > 0.0)
    assert np.all(eigen[:, 0] + eigen[:, 1] >= eigen[:, 2] * (1 - 1e-12))
    for index in range(0, 50_000, 5000):
        Inertia(tensors[index])  # the package's own validation accepts them
    assert np.allclose(np.median(np.sort(eigen, axis=1), axis=0), [200, 300, 500], rtol=0.15)


def test_dispersed_inertia_refuses_moments_beyond_the_triangle_inequality():
    with pytest.raises(InputError, match='triangle'):
        dispersed_inertia([1.0, 1.0, 3.0], np.eye(3), 0.1, np.zeros((1, 3)),
                          [[1.0, 0.0, 0.0, 0.0]])


def test_perturbed_tensors_are_made_physical():
    base = Inertia([1.0, 1.0, 1.9]).tensor  # close to the triangle inequality's edge
    tensors = perturbed_tensors(base, 0.3, RunStreams(6, np.arange(20_000)).normal(3, 6))
    eigen = np.linalg.eigvalsh(tensors)
    assert np.all(eigen[:, 0] > 0.0)
    assert np.all(eigen[:, 0] + eigen[:, 1] >= eigen[:, 2] * (1 - 1e-12))
    assert np.all(second_moments(eigen) >= 0.0)
    small = perturbed_tensors(base, 1e-3, RunStreams(6, np.arange(100)).normal(3, 6))
    assert np.allclose(small, base, atol=1e-2)
