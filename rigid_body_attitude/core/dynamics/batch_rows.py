"""Structure-of-arrays kernels shared by the batch and the effects' batch methods.

A chunk of ``n`` bodies holds every vector as rows: ``v[i]`` is component ``i`` of every body,
shape (3, n). NumPy's cost here is per pass over a row and per call, so the kernels write
into work arrays kept by the chunk (``out=``, no temporaries) and use the fewest passes over
the rows: one ``einsum`` for a product with one matrix per body, row operations with plain floats
for a matrix shared by every body.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ['BatchChunk', 'cross_rows', 'matrix_rows_product']

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class BatchChunk:
    """What a batch kernel sees of a chunk of ``n`` bodies (structure of arrays).

    Attributes:
        tensor: inertia tensors [kg m²], shape (3, 3, n) (``tensor[i, j]`` is ``J_ij`` of
            every body).
        mass: masses [kg], shape (n,).
        parameters: the effect's numeric parameters for these bodies: a dispersed parameter
            as an array over the bodies (shape (n,) or (3, n)), a shared one as a float or a
            (3, 1) array (NumPy broadcasts both the same way).
        diagonal: True when every tensor of the chunk is diagonal (kernels may then skip the
            off-diagonal products, which are exact zeros). ``tensor`` has shape (3, 3, 1)
            when every body has the same.
        workspace: the kernel's work arrays kept between calls (:meth:`scratch`).
        state: the effect's own per-body state rows (rows, n), kept by the batch across
            calls (a sampled controller's held torque); empty for effects without.
        peers: the views of every effect of the chunk by effect name (an actuator reads the
            state rows of the controller that drives it).
    """

    tensor: FloatArray
    mass: FloatArray
    parameters: Mapping[str, Any]
    diagonal: bool = False
    workspace: dict[str, FloatArray] = field(default_factory=dict, compare=False, repr=False)
    state: FloatArray = field(default_factory=lambda: np.empty((0, 0)), compare=False,
                              repr=False)
    peers: dict[str, BatchChunk] = field(default_factory=dict, compare=False, repr=False)

    def scratch(self, name: str, rows: int) -> FloatArray:
        """A work array ``name`` of shape (rows, n), allocated on first use and then reused
        (its content is whatever the last call left)."""
        array = self.workspace.get(name)
        if array is None or array.shape[0] != rows:
            array = self.workspace[name] = np.empty((rows, self.mass.shape[0]))
        return array

    def inertia_product(self, vector: FloatArray, out: FloatArray,
                        scale: float = 1.0) -> FloatArray:
        """``out = scale J v`` for every body (``vector`` and ``out`` (3, n)); ``scale J`` is
        computed once per chunk and kept."""
        key = f'inertia×{scale!r}'
        scaled = self.workspace.get(key)
        if scaled is None:
            scaled = self.workspace[key] = self.tensor * scale
        return matrix_rows_product(scaled, vector, out, self.scratch('inertia_product', 1)[0],
                                   self.diagonal)


def matrix_rows_product(matrix: FloatArray, vector: FloatArray, out: FloatArray,
                        work: FloatArray, diagonal: bool = False) -> FloatArray:
    """``out = M v`` for every body: ``matrix`` (3, 3, n) or (3, 3, 1) (one for all),
    ``vector`` and ``out`` (3, n), ``work`` (n,); ``diagonal`` skips the off-diagonal entries
    (exact zeros).

    One matrix per body takes one ``einsum`` (one pass that reads every entry once, where row
    operations take fifteen); a shared matrix takes row operations with plain floats."""
    shared = matrix.shape[2] == 1
    if diagonal:
        for i in range(3):
            np.multiply(vector[i], float(matrix[i, i, 0]) if shared else matrix[i, i],
                        out=out[i])
    elif not shared:
        np.einsum('ijn,jn->in', matrix, vector, out=out)
    else:
        for i, (m0, m1, m2) in enumerate(matrix[:, :, 0].tolist()):
            np.multiply(vector[0], m0, out=out[i])
            np.multiply(vector[1], m1, out=work)
            out[i] += work
            np.multiply(vector[2], m2, out=work)
            out[i] += work
    return out


def cross_rows(a: FloatArray, b: FloatArray, out: FloatArray, work: FloatArray,
               accumulate: bool = False) -> FloatArray:
    """``out = a × b`` (or ``out += a × b`` with ``accumulate``) for every body, row by row:
    ``a``, ``b`` and ``out`` (3, n), ``work`` (n,)."""
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        if accumulate:
            np.multiply(a[j], b[k], out=work)
            out[i] += work
        else:
            np.multiply(a[j], b[k], out=out[i])
        np.multiply(a[k], b[j], out=work)
        out[i] -= work
    return out
