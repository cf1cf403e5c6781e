"""Many torque-free bodies at once: Monte-Carlo dispersions of initial states or inertia.

:class:`TorqueFreeBatch` advances N bodies with the same classical RK4 (+ renormalisation)
as the ``rk4`` dynamics integrator, vectorised over bodies. Two things make it fast with plain
NumPy:

* each body is integrated in its own **principal frame**: ``q_p = q ⊗ P``, ``ω_p = Pᵀ ω``
  (``P`` the principal axes). Euler's equations become ``ω̇₁ = (J₂ − J₃)/J₁ ω₂ ω₃`` (and
  cyclic): 6 products instead of the 39 operations of a full tensor. RK4 commutes with a
  constant linear change of variables, so the result equals the body-frame RK4 step up to
  round-off;
* the bodies are processed in **chunks** that stay in the CPU cache for all the steps of a
  call, with preallocated work arrays (structure of arrays, no temporaries).

Conventions: :mod:`rigid_body_attitude.core.quaternion`. Order 4; cost per body-step about 170
vector operations / chunk size; invariants as RK4 (``|q|`` by projection).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.inertia import Inertia

__all__ = ['TorqueFreeBatch']

FloatArray = NDArray[np.float64]

#: Bodies per chunk: the state and the work arrays (about 1 MB) stay in the L2 cache.
DEFAULT_CHUNK = 4096


def _principal(inertia: ArrayLike, count: int) -> tuple[FloatArray, FloatArray]:
    """Principal moments (N, 3) and right-handed axes (N, 3, 3) of one or N tensors."""
    try:
        tensors = np.asarray(inertia, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `inertia` to be numeric, got {inertia!r}') from err
    if tensors.shape in ((3,), (3, 3)):
        single = Inertia(tensors)
        return (np.broadcast_to(single.principal_moments, (count, 3)),
                np.broadcast_to(single.principal_axes, (count, 3, 3)))
    if tensors.shape == (count, 3):
        tensors = tensors[:, :, None] * np.eye(3)
    if tensors.shape != (count, 3, 3):
        raise InputError(f'Expected `inertia` of shape (3,), (3, 3), ({count}, 3) or '
                         f'({count}, 3, 3), got {tensors.shape}')
    for index in np.flatnonzero(~np.all(np.isfinite(tensors), axis=(1, 2))
                                | np.any(np.abs(tensors - tensors.transpose(0, 2, 1))
                                         > 1e-12 * np.abs(tensors).max(axis=(1, 2))[:, None,
                                                                                    None],
                                         axis=(1, 2)))[:1]:
        Inertia(tensors[index])
    moments, axes = np.linalg.eigh(tensors)
    bad = (moments[:, 0] <= 0.0) | (moments[:, 0] + moments[:, 1] < moments[:, 2] * (1 - 1e-12))
    if np.any(bad):
        Inertia(tensors[np.flatnonzero(bad)[0]])
    axes[np.linalg.det(axes) < 0.0, :, 2] *= -1.0
    return moments, axes


class TorqueFreeBatch:
    """N torque-free rigid bodies advanced together with RK4.

    Attributes:
        count: number of bodies N.
    """

    def __init__(self, inertia: ArrayLike, attitude: ArrayLike, omega_body: ArrayLike,
                 chunk: int = DEFAULT_CHUNK) -> None:
        """Bodies with ``inertia`` (one tensor or moments for all, or one per body),
        ``attitude`` (N, 4) unit quaternions and ``omega_body`` (N, 3) [rad/s]."""
        attitude = quaternion.normalize(quaternion.as_quaternion(attitude, 'attitude'))
        omega = quaternion.as_vector(omega_body, 'omega_body')
        if attitude.ndim != 2 or omega.shape != (attitude.shape[0], 3):
            raise InputError(f'Expected `attitude` (N, 4) and `omega_body` (N, 3), got '
                             f'{attitude.shape} and {omega.shape}')
        self.count = attitude.shape[0]
        self.chunk = max(1, int(chunk))
        moments, axes = _principal(inertia, self.count)
        self._axes = np.ascontiguousarray(axes)
        self._axes_quaternion = quaternion.from_matrix(self._axes)
        j1, j2, j3 = moments.T
        self._gain = np.ascontiguousarray(np.stack([(j2 - j3) / j1, (j3 - j1) / j2,
                                                    (j1 - j2) / j3]))
        self._moments = np.ascontiguousarray(moments)
        self._state = np.empty((7, self.count))
        self._state[:4] = quaternion.multiply(attitude, self._axes_quaternion).T
        self._state[4:] = np.einsum('nji,nj->in', self._axes, omega)

    @property
    def attitude(self) -> FloatArray:
        """(N, 4) body → world quaternions."""
        principal = self._state[:4].T
        return quaternion.multiply(principal, quaternion.conjugate(self._axes_quaternion))

    @property
    def omega_body(self) -> FloatArray:
        """(N, 3) body rates [rad/s]."""
        return np.einsum('nij,jn->ni', self._axes, self._state[4:])

    def kinetic_energy(self) -> FloatArray:
        """(N,) kinetic energies ``½ Σ J_i ω_i²`` [J]."""
        return 0.5 * np.sum(self._moments.T * self._state[4:] ** 2, axis=0)

    def world_angular_momentum(self) -> FloatArray:
        """(N, 3) world-frame angular momenta [N m s]."""
        momentum_principal = (self._moments.T * self._state[4:]).T
        return quaternion.rotate(self._state[:4].T, momentum_principal)

    def rk4(self, h: float, steps: int = 1) -> None:
        """Advance every body by ``steps`` RK4 steps of ``h`` seconds."""
        if not np.isfinite(h) or h <= 0.0:
            raise InputError(f'Expected `h` to be a positive number of seconds, got {h!r}')
        for start in range(0, self.count, self.chunk):
            stop = min(start + self.chunk, self.count)
            block = np.ascontiguousarray(self._state[:, start:stop])
            gain = np.ascontiguousarray(self._gain[:, start:stop])
            _rk4_block(block, gain, h, int(steps))
            self._state[:, start:stop] = block


def _derivative(y: FloatArray, gain: FloatArray, out: FloatArray,
                half_rate: FloatArray, scratch: FloatArray) -> None:
    """``(q̇, ω̇)`` of the principal-frame torque-free body into ``out`` (7, n)."""
    qw, qx, qy, qz, p, q, r = y
    np.multiply(y[4:], 0.5, out=half_rate)
    hx, hy, hz = half_rate
    t = scratch[0]
    # q̇ = q ⊗ (0, ω/2)
    np.multiply(qx, hx, out=out[0])
    np.multiply(qy, hy, out=t)
    out[0] += t
    np.multiply(qz, hz, out=t)
    out[0] += t
    np.negative(out[0], out=out[0])
    _combine(out[1], qw, hx, qy, hz, qz, hy, t)
    _combine(out[2], qw, hy, qz, hx, qx, hz, t)
    _combine(out[3], qw, hz, qx, hy, qy, hx, t)
    # ω̇ᵢ = gainᵢ ωⱼ ωₖ
    np.multiply(q, r, out=out[4])
    out[4] *= gain[0]
    np.multiply(r, p, out=out[5])
    out[5] *= gain[1]
    np.multiply(p, q, out=out[6])
    out[6] *= gain[2]


def _combine(out: FloatArray, a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray,
             e: FloatArray, f: FloatArray, t: FloatArray) -> None:
    """``out = a b + c d − e f``."""
    np.multiply(a, b, out=out)
    np.multiply(c, d, out=t)
    out += t
    np.multiply(e, f, out=t)
    out -= t


def _rk4_block(y: FloatArray, gain: FloatArray, h: float, steps: int) -> None:
    """RK4 + renormalisation on one cache-sized block, in place."""
    n = y.shape[1]
    k = np.empty((7, n))
    total = np.empty((7, n))
    stage = np.empty((7, n))
    half_rate = np.empty((3, n))
    scratch = np.empty((1, n))
    norm = np.empty(n)
    for _ in range(steps):
        _derivative(y, gain, total, half_rate, scratch)
        np.multiply(total, 0.5 * h, out=stage)
        stage += y
        _derivative(stage, gain, k, half_rate, scratch)
        np.multiply(k, 2.0, out=k)
        total += k
        np.multiply(k, 0.25 * h, out=stage)
        stage += y
        _derivative(stage, gain, k, half_rate, scratch)
        np.multiply(k, 2.0, out=k)
        total += k
        np.multiply(k, 0.5 * h, out=stage)
        stage += y
        _derivative(stage, gain, k, half_rate, scratch)
        total += k
        total *= h / 6.0
        y += total
        np.einsum('in,in->n', y[:4], y[:4], out=norm)
        np.sqrt(norm, out=norm)
        y[:4] /= norm
