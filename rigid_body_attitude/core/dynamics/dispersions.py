"""Monte-Carlo dispersions: random streams per run, attitudes on SO(3), physical inertia.

Every function is vectorised over runs and takes its randomness as arrays, so a run's draws
depend only on the run and never on which other runs share its chunk or worker:

* :class:`RunStreams`: one random stream per run, derived from a single root
  ``numpy.random.SeedSequence``: the root gives a 64-bit key, run ``i``'s stream is the
  SplitMix64 sequence at counters ``(i, category, k)`` (disjoint for distinct runs and
  categories), mixed by SplitMix64's finaliser; uniforms take the top 53 bits, normals come
  from Box–Muller. Source: Steele, Lea & Flood, "Fast splittable pseudorandom number
  generators", OOPSLA 2014 (SplitMix64, which passes BigCrush).
* :func:`uniform_quaternions`: Haar-uniform rotations (Shoemake, "Uniform random rotations",
  Graphics Gems III, 1992), unlike Euler angles drawn uniformly, which crowd near the poles.
* :func:`cone_quaternions`: a nominal attitude composed with a body-frame rotation of angle at
  most ``half_angle`` about a uniform axis, the angle drawn with the Haar density
  ``∝ 1 − cos θ`` restricted to ``[0, half_angle]`` (so ``half_angle = π`` is uniform on SO(3)).
* :func:`inertia_from_second_moments`, :func:`dispersed_inertia`, :func:`perturbed_tensors`:
  physically valid inertia. A body's principal moments are ``J₁ = S₂ + S₃`` (and cyclic) of
  its mass distribution's second moments ``Sᵢ = ∫ xᵢ² dm ≥ 0``; dispersing the ``Sᵢ`` by
  positive log-normal factors keeps every tensor positive definite and within the triangle
  inequality ``J₁ + J₂ ≥ J₃`` by construction. A perturbed tensor is brought back to the
  nearest such body by raising negative ``Sᵢ`` of its eigen-decomposition to a tiny floor.

Conventions: :mod:`rigid_body_attitude.core.attitude.quaternion` (Hamilton, (w, x, y, z), body →
world).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError

__all__ = ['RunStreams', 'cone_quaternions', 'dispersed_inertia',
           'inertia_from_second_moments', 'perturbed_tensors', 'second_moments',
           'uniform_quaternions']

FloatArray = NDArray[np.float64]
UintArray = NDArray[np.uint64]

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
#: Counters per run and per category within a run (category < 2¹², draw < 2²⁰).
_PER_CATEGORY = 1 << 20
_PER_RUN = 1 << 32


def _splitmix(counter: UintArray, key: np.uint64) -> UintArray:
    """SplitMix64 outputs at ``counter`` of the sequence that starts at ``key``."""
    with np.errstate(over='ignore'):
        z = key + _GAMMA * (counter + np.uint64(1))
        z = (z ^ (z >> np.uint64(30))) * _MIX1
        z = (z ^ (z >> np.uint64(27))) * _MIX2
    result: UintArray = z ^ (z >> np.uint64(31))
    return result


class RunStreams:
    """Independent random streams of a set of runs of one campaign.

    Attributes:
        key: the campaign's 64-bit key (from the root ``SeedSequence``).
        runs: the runs' indices in the campaign, shape (n,).
    """

    def __init__(self, root_seed: int, runs: ArrayLike) -> None:
        """Streams of ``runs`` (campaign indices) of the campaign with ``root_seed``."""
        words = np.random.SeedSequence(int(root_seed)).generate_state(1, np.uint64)
        self.key = np.uint64(words[0])
        self.runs = np.asarray(runs, dtype=np.uint64)
        if self.runs.ndim != 1:
            raise InputError(f'Expected `runs` to be a list of indices, got {self.runs.shape}')

    def seeds(self) -> UintArray:
        """Each run's seed: its stream's first counter (what reproduces it, with the key)."""
        with np.errstate(over='ignore'):
            first = self.runs * np.uint64(_PER_RUN) + np.uint64(1)
            seeds: UintArray = self.key + _GAMMA * first
        return seeds

    def bits(self, category: int, count: int) -> UintArray:
        """``count`` 64-bit words per run of one ``category`` of draws, shape (n, count)."""
        if not 0 <= category < _PER_RUN // _PER_CATEGORY or not 0 < count <= _PER_CATEGORY:
            raise InputError(f'Expected a category below 4096 and 1 to 2^20 draws, got '
                             f'{category} and {count}')
        counter = (self.runs[:, None] * np.uint64(_PER_RUN)
                   + np.uint64(category * _PER_CATEGORY)
                   + np.arange(count, dtype=np.uint64)[None, :])
        return _splitmix(counter, self.key)

    def uniform(self, category: int, count: int) -> FloatArray:
        """Uniform draws in ``[0, 1)``, shape (n, count) (53 random bits each)."""
        result: FloatArray = (self.bits(category, count) >> np.uint64(11)).astype(
            np.float64) * 2.0 ** -53
        return result

    def normal(self, category: int, count: int) -> FloatArray:
        """Standard normal draws, shape (n, count) (Box–Muller, two uniforms each)."""
        u = self.uniform(category, 2 * count)
        radius = np.sqrt(-2.0 * np.log1p(-u[:, :count]))
        result: FloatArray = radius * np.cos(2.0 * np.pi * u[:, count:])
        return result


def uniform_quaternions(u: ArrayLike) -> FloatArray:
    """Haar-uniform unit quaternions (n, 4) from uniforms ``u`` (n, 3) in ``[0, 1)``."""
    u = np.asarray(u, dtype=np.float64)
    low, high = np.sqrt(1.0 - u[:, 0]), np.sqrt(u[:, 0])
    a, b = 2.0 * np.pi * u[:, 1], 2.0 * np.pi * u[:, 2]
    q = np.stack([high * np.cos(b), low * np.sin(a), low * np.cos(a), high * np.sin(b)],
                 axis=1)
    result: FloatArray = q * np.where(q[:, :1] < 0.0, -1.0, 1.0)
    return result


def _unit_vectors(u: FloatArray) -> FloatArray:
    """Uniform directions on the sphere (n, 3) from uniforms (n, 2)."""
    z = 1.0 - 2.0 * u[:, 0]
    ring = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    angle = 2.0 * np.pi * u[:, 1]
    return np.stack([ring * np.cos(angle), ring * np.sin(angle), z], axis=1)


def _haar_angles(v: FloatArray, half_angle: float) -> FloatArray:
    """Rotation angles in ``[0, half_angle]`` with density ``∝ 1 − cos θ`` (inverse CDF by
    bisection: ``θ − sin θ = v (α − sin α)``, 60 halvings, deterministic)."""
    target = v * (half_angle - np.sin(half_angle))
    low, high = np.zeros_like(v), np.full_like(v, half_angle)
    for _ in range(60):
        middle = 0.5 * (low + high)
        above = middle - np.sin(middle) > target
        high = np.where(above, middle, high)
        low = np.where(above, low, middle)
    result: FloatArray = 0.5 * (low + high)
    return result


def cone_quaternions(nominal: ArrayLike, half_angle: float, u: ArrayLike) -> FloatArray:
    """Attitudes (n, 4) within ``half_angle`` [rad] of ``nominal`` (4,) or (n, 4), uniform
    (Haar) over that ball of SO(3); ``u`` (n, 3) uniforms. ``q = nominal ⊗ δq``: the error
    rotation is about a body axis."""
    if not 0.0 <= half_angle <= np.pi:
        raise InputError(f'Expected a cone half-angle in [0, pi] rad, got {half_angle!r}')
    u = np.asarray(u, dtype=np.float64)
    axis = _unit_vectors(u[:, :2])
    angle = _haar_angles(u[:, 2], float(half_angle))
    error = np.concatenate([np.cos(0.5 * angle)[:, None],
                            np.sin(0.5 * angle)[:, None] * axis], axis=1)
    base = np.broadcast_to(quaternion.normalize(np.asarray(nominal, dtype=np.float64)),
                           error.shape)
    result: FloatArray = quaternion.normalize(quaternion.multiply(base, error))
    return result


def second_moments(moments: ArrayLike) -> FloatArray:
    """Second moments ``Sᵢ = ∫ xᵢ² dm`` (…, 3) of principal moments ``J`` (…, 3):
    ``Sᵢ = (Jⱼ + Jₖ − Jᵢ) / 2``; all ≥ 0 exactly when ``J`` obeys the triangle inequality."""
    j = np.asarray(moments, dtype=np.float64)
    result: FloatArray = 0.5 * (j.sum(axis=-1, keepdims=True) - 2.0 * j)
    return result


def inertia_from_second_moments(second: ArrayLike, axes: ArrayLike) -> FloatArray:
    """Tensors (n, 3, 3) ``R diag(J) Rᵀ`` with ``J₁ = S₂ + S₃`` (and cyclic) from second
    moments (n, 3) and principal axes ``R`` (n, 3, 3) (columns, body frame)."""
    s = np.asarray(second, dtype=np.float64)
    moments = s.sum(axis=-1, keepdims=True) - s
    rotation = np.asarray(axes, dtype=np.float64)
    tensors: FloatArray = np.einsum('nij,nj,nkj->nik', rotation, moments, rotation)
    return 0.5 * (tensors + tensors.transpose(0, 2, 1))


def dispersed_inertia(moments: ArrayLike, axes: ArrayLike, log_sigma: float,
                      normals: ArrayLike, rotations: ArrayLike) -> FloatArray:
    """Tensors (n, 3, 3) about nominal principal ``moments`` (3,) and ``axes`` (3, 3).

    The second moments are scaled by ``exp(log_sigma · normals)`` (normals (n, 3)); the
    principal axes are ``rotations`` (n, 4) applied to the nominal ones (body frame): a
    uniform quaternion gives axes uniform on SO(3), a cone quaternion about identity a small
    misalignment. Every tensor is positive definite and obeys the triangle inequality."""
    if not np.isfinite(log_sigma) or log_sigma < 0.0:
        raise InputError(f'Expected a non-negative spread, got {log_sigma!r}')
    second = second_moments(moments)
    if np.any(second < -1e-12 * np.max(np.abs(moments))):
        raise InputError(f'Principal moments {np.asarray(moments).tolist()} violate the '
                         f'triangle inequality')
    scaled = np.maximum(second, 0.0) * np.exp(log_sigma * np.asarray(normals))
    rotation = np.einsum('ij,njk->nik', np.asarray(axes, dtype=np.float64),
                         quaternion.to_matrix(np.asarray(rotations, dtype=np.float64)))
    return inertia_from_second_moments(scaled, rotation)


def perturbed_tensors(tensor: ArrayLike, relative_sigma: float,
                      normals: ArrayLike) -> FloatArray:
    """Tensors (n, 3, 3): ``tensor`` (3, 3) plus a symmetric perturbation of standard
    deviation ``relative_sigma · trace / 3`` per entry (normals (n, 6): xx, yy, zz, xy, xz,
    yz), made physical: second moments of the perturbed eigenvalues below 1e-9 of the trace
    are raised to it (the nearest valid body), so every result is positive definite and
    within the triangle inequality."""
    base = np.asarray(tensor, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    scale = relative_sigma * np.trace(base) / 3.0
    perturbation = np.empty((n.shape[0], 3, 3))
    for column, (i, j) in enumerate([(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]):
        perturbation[:, i, j] = perturbation[:, j, i] = scale * n[:, column]
    moments, axes = np.linalg.eigh(base + perturbation)
    floor = 1e-9 * np.trace(base)
    second = np.maximum(second_moments(moments), floor)
    return inertia_from_second_moments(second, axes)
