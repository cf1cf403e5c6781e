"""Tests of Inertia: validation, the shapes (Goldstein, Poole & Safko, *Classical Mechanics*, 3rd
ed., 2002, §5.3), principal axes.

Tolerances: the tensors are a few products and sums of the inputs, so they agree with the
closed forms to a few 1e−16 relative; the eigen-decomposition (LAPACK) is backward stable, so
reconstructing the tensor from it agrees to ~10 round-offs of the largest moment.
"""

import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import InertiaError
from rigid_body_attitude.core.dynamics.inertia import Inertia

MASS = 2.0
EDGES = (0.1, 0.2, 0.3)


def parallel_axis(centre_tensor, mass, offset):
    """Steiner: J_O = J_C + m (|d|² I − d dᵀ), d the centre of mass seen from O."""
    offset = np.asarray(offset, dtype=float)
    return centre_tensor + mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))


def test_box_centre_closed_form():
    a, b, c = EDGES
    expected = np.diag([b * b + c * c, c * c + a * a, a * a + b * b]) * MASS / 12.0
    inertia = Inertia.box(MASS, EDGES)
    np.testing.assert_allclose(inertia.tensor, expected, rtol=1e-15, atol=0)
    assert inertia.is_diagonal


def test_box_corner_seed_formula():
    # a box about a corner (Goldstein 2002, §5.3): J = M [[(b²+c²)/3, −ab/4, −ac/4], [−ab/4,
    # (c²+a²)/3, −bc/4], ...]
    a, b, c = EDGES
    expected = MASS * np.array([[(b * b + c * c) / 3, -a * b / 4, -a * c / 4],
                                [-a * b / 4, (c * c + a * a) / 3, -b * c / 4],
                                [-a * c / 4, -b * c / 4, (a * a + b * b) / 3]])
    inertia = Inertia.box(MASS, EDGES, about='corner')
    np.testing.assert_allclose(inertia.tensor, expected, rtol=1e-15, atol=0)
    assert not inertia.is_diagonal


def test_box_corner_is_parallel_axis_of_centre():
    # independent derivation: the corner is at −(a, b, c)/2 from the centre
    centre = Inertia.box(MASS, EDGES).tensor
    corner = Inertia.box(MASS, EDGES, about='corner').tensor
    np.testing.assert_allclose(corner, parallel_axis(centre, MASS, 0.5 * np.array(EDGES)),
                               rtol=0, atol=1e-15 * np.max(corner))


def test_box_corner_principal_decomposition():
    inertia = Inertia.box(MASS, EDGES, about='corner')
    moments, axes = inertia.principal_moments, inertia.principal_axes
    assert np.all(np.diff(moments) > 0)
    np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-15)
    assert np.linalg.det(axes) == pytest.approx(1.0, abs=1e-15)
    scale = moments[-1]
    np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, inertia.tensor,
                               atol=10 * 2.2e-16 * scale)
    for moment, axis in zip(moments, axes.T):
        np.testing.assert_allclose(inertia.tensor @ axis, moment * axis, atol=10 * 2.2e-16 * scale)
    # the invariants of the tensor: trace and determinant
    assert moments.sum() == pytest.approx(np.trace(inertia.tensor), rel=1e-15)
    assert np.prod(moments) == pytest.approx(np.linalg.det(inertia.tensor), rel=1e-13)
    # principal_rotation maps principal coordinates to body coordinates
    rotation = quat.to_matrix(inertia.principal_rotation)
    np.testing.assert_allclose(rotation @ np.diag(moments) @ rotation.T, inertia.tensor,
                               atol=10 * 2.2e-16 * scale)


def test_cube_corner_principal_moments_closed_form():
    # cube of edge s about a corner: along the body diagonal M s²/6 (the diagonal passes
    # through the centre), across it M s²/6 + M (3 s²/4) = 11 M s²/12 (Steiner)
    side = 0.4
    inertia = Inertia.box(MASS, [side] * 3, about='corner')
    small, large = MASS * side ** 2 / 6.0, 11.0 * MASS * side ** 2 / 12.0
    np.testing.assert_allclose(inertia.principal_moments, [small, large, large], rtol=1e-14)
    diagonal = inertia.principal_axes[:, 0]
    np.testing.assert_allclose(np.abs(diagonal), np.full(3, 1 / np.sqrt(3)), atol=1e-15)


def test_cylinder_and_sphere_closed_forms():
    cylinder = Inertia.cylinder(3.0, 0.2, 0.5)
    transverse = 3.0 * (3 * 0.04 + 0.25) / 12.0
    np.testing.assert_allclose(np.diag(cylinder.tensor), [transverse, transverse, 0.06],
                               rtol=1e-15)
    sphere = Inertia.sphere(5.0, 0.1)
    np.testing.assert_allclose(sphere.tensor, 0.02 * np.eye(3), rtol=1e-15)


def test_moments_and_inverse():
    inertia = Inertia([500.0, 200.0, 300.0])
    np.testing.assert_array_equal(inertia.tensor, np.diag([500.0, 200.0, 300.0]))
    np.testing.assert_array_equal(inertia.principal_moments, [200.0, 300.0, 500.0])
    np.testing.assert_allclose(inertia.inverse @ inertia.tensor, np.eye(3), atol=1e-16)


def test_full_tensor_round_off_asymmetry_is_symmetrised():
    tensor = Inertia.box(MASS, EDGES, about='corner').tensor.copy()
    tensor[0, 1] *= 1.0 + 1e-14  # below the 1e−12 relative symmetry tolerance
    inertia = Inertia(tensor)
    np.testing.assert_array_equal(inertia.tensor, inertia.tensor.T)


def test_triangle_equality_is_accepted():
    # a thin plate has J1 + J2 = J3 exactly: the limit of real mass distributions
    inertia = Inertia([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(inertia.principal_moments, [1.0, 2.0, 3.0])


@pytest.mark.parametrize('tensor, message', [
    ([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
     r'Expected `inertia` to be symmetric, got \[\[1\.0, 0\.1, 0\.0\], \[0\.0, 1\.0, 0\.0\]'),
    ([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
     r'Expected `inertia` to be positive definite, got .* with principal moments \[-1\.0'),
    ([1.0, 1.0, -1.0], r'Expected `inertia` to be positive definite'),
    ([0.0, 1.0, 1.0], r'Expected `inertia` to be positive definite'),
    ([1.0, 2.0, 3.5],
     re.escape('Expected principal moments with J1 + J2 >= J3 (a real mass distribution), '
               'got [1.0, 2.0, 3.5]')),
    ([1.0, 2.0], r'Expected `inertia` to be a 3×3 matrix or 3 principal moments, got shape'),
    ([[1.0, 0.0], [0.0, 1.0]], r'got shape \(2, 2\)'),
    ([1.0, np.nan, 1.0], r'Expected `inertia` to be finite, got \[\[1\.0, 0\.0, 0\.0\], '),
    ('heavy', r"Expected `inertia` to be a 3×3 matrix or 3 principal moments, got 'heavy'"),
])
def test_bad_tensor_rejected(tensor, message):
    with pytest.raises(InertiaError, match=message):
        Inertia(tensor)


def test_triangle_violation_by_a_rotated_tensor():
    # the check is on the principal moments, whatever axes the tensor is given in
    rotation = quat.to_matrix(quat.exp([0.3, -0.5, 0.8]))
    tensor = rotation @ np.diag([1.0, 2.0, 3.5]) @ rotation.T
    with pytest.raises(InertiaError, match=r'J1 \+ J2 >= J3 .*got \[(1\.0|0\.999)\d*, 2\.0'):
        Inertia(tensor)


@pytest.mark.parametrize('call, message', [
    (lambda: Inertia.box(-1.0, EDGES), 'Expected `mass` to be a positive number, got -1.0'),
    (lambda: Inertia.box(MASS, [0.1, 0.0, 0.3]),
     'Expected `edges` to be 3 positive numbers, got [0.1, 0.0, 0.3]'),
    (lambda: Inertia.box(MASS, [0.1, 0.2]), 'Expected `edges` to be 3 positive numbers'),
    (lambda: Inertia.box(MASS, EDGES, about='edge'),
     "Expected `about` to be 'centre' or 'corner', got 'edge'"),
    (lambda: Inertia.cylinder(MASS, 'r', 1.0),
     "Expected `radius` to be a positive number, got 'r'"),
    (lambda: Inertia.sphere(MASS, float('inf')), 'Expected `radius` to be a positive number'),
])
def test_bad_shape_parameters_rejected(call, message):
    with pytest.raises(InertiaError, match=re.escape(message)):
        call()
