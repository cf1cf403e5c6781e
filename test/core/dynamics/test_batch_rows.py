"""The batch's row kernels (batch_rows) against the per-body formulas, one body at a time.

Inputs are drawn in [−1, 1], so each result component is a sum of three products of size
≤ 1: the kernels and the reference round differently at most in the last place of the two
additions and three products, below 3·2⁻⁵³·3 ≈ 1e-15 (:data:`ROUND_OFF`). The matrix kinds
are the three a batch meets: one full matrix per body, one shared full matrix, diagonal ones.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_attitude.core.dynamics.batch_rows import (
    BatchChunk, cross_rows, matrix_rows_product)

BODIES = 37
ROUND_OFF = 1e-15


def rows(rng: np.random.Generator, *shape: int) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, shape)


@pytest.mark.parametrize('kind', ['per body', 'shared', 'diagonal per body', 'diagonal shared'])
def test_matrix_rows_product_is_each_body_matrix_times_its_vector(kind):
    rng = np.random.default_rng(5)
    columns = 1 if 'shared' in kind else BODIES
    matrix = rows(rng, 3, 3, columns)
    if kind.startswith('diagonal'):
        matrix *= np.eye(3)[:, :, None]
    vector = rows(rng, 3, BODIES)
    out = np.full((3, BODIES), np.nan)
    result = matrix_rows_product(matrix, vector, out, np.empty(BODIES),
                                 diagonal=kind.startswith('diagonal'))
    assert result is out
    for body in range(BODIES):
        expected = matrix[:, :, body % columns] @ vector[:, body]
        np.testing.assert_allclose(out[:, body], expected, rtol=0.0, atol=ROUND_OFF)


@pytest.mark.parametrize('accumulate', [False, True])
def test_cross_rows_is_each_body_cross_product(accumulate):
    rng = np.random.default_rng(6)
    a, b, start = rows(rng, 3, BODIES), rows(rng, 3, BODIES), rows(rng, 3, BODIES)
    out = start.copy()
    cross_rows(a, b, out, np.empty(BODIES), accumulate=accumulate)
    expected = np.cross(a.T, b.T).T + (start if accumulate else 0.0)
    np.testing.assert_allclose(out, expected, rtol=0.0, atol=ROUND_OFF)


def test_batch_chunk_scratch_is_kept_and_inertia_product_scales():
    rng = np.random.default_rng(7)
    tensor = rows(rng, 3, 3, BODIES)
    chunk = BatchChunk(tensor, np.ones(BODIES), {})
    work = chunk.scratch('work', 3)
    assert work.shape == (3, BODIES) and chunk.scratch('work', 3) is work
    vector = rows(rng, 3, BODIES)
    scaled = chunk.inertia_product(vector, np.empty((3, BODIES)), 2.5)
    for body in range(BODIES):  # 2.5 J v: the scale multiplies entries of size ≤ 1
        np.testing.assert_allclose(scaled[:, body], 2.5 * tensor[:, :, body] @ vector[:, body],
                                   rtol=0.0, atol=2.5 * ROUND_OFF)
