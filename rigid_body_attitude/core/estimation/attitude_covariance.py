"""Attitude-error covariance carried with a gyro-driven attitude, sample by sample.

Convention (REP-145: orientation covariance about fixed world axes): the attitude error is a
small rotation vector ``δθ`` in the **world** frame,

    q_true = exp(δθ) ⊗ q_est,

so ``cov(δθ)`` is the covariance about the world's x, y, z axes (east, north, up in ENU); roll
and pitch errors about world horizontal axes are its x and y entries, yaw its z entry.

Error state ``x = (δθ, δb, e)`` (15 entries,
:data:`~rigid_body_attitude.core.estimation.gyro_error_model.ERROR_STATE_SIZE`):
``δb = b − b_est`` the gyro bias error (body, rad/s), ``e`` the 9 entries of the
intrinsic-error matrix ``E`` (row-major; see
:mod:`~rigid_body_attitude.core.estimation.gyro_error_model`).
With the estimated rate ``ω = ω_m − b_est`` and ``R = R(q_est)``, to first order::

    dδθ/dt = −R (δb + E ω + n),      dδb/dt = w,      de/dt = 0.

In a world-frame error the attitude block of the transition is the identity, so over a step
of length ``Δt`` with ``ω`` held (the strapdown step ``q ⊗ exp(ω Δt)``) the transition is
exactly ``Φ = [[I, B], [0, I]]`` with ``B = −[M, M Ω(ω)]``, ``M = ∫ R(τ) dτ = R_k J(ω Δt) Δt``
(``J`` the left Jacobian of SO(3)) and ``M Ω(ω)`` the 3×9 matrix with column ``3i + j`` equal to
``M[:, i] ω_j``. Products of such transitions add their ``B``, so samples are gathered and
folded in every ``batch_size`` samples (and whenever the covariance is read) with one
``P ← Φ P Φᵀ + Q``: the transition is exact for any batch; the process noise is
``N² T I`` on the attitude (exact), ``K² T I`` on the bias, and the bias walk's effect on the
attitude within one batch (``K² T³/3``, ``−K² T²/2``) with the batch's mean rotation.

Cost: :meth:`AttitudeCovariance.add_sample` appends to a buffer (no NumPy); each fold is a
handful of small NumPy operations (``bench/attitude_covariance_cost.py`` measures both).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.gyro_error_model import (
    ERROR_STATE_SIZE,
    GyroErrorModel,
    initial_covariance,
)

__all__ = ['AttitudeCovariance', 'AttitudeStddev', 'DEFAULT_BATCH_SIZE', 'MAX_ATTITUDE_VARIANCE',
           'checked_attitude_covariance', 'propagated_covariance', 'transition_blocks']

FloatArray = NDArray[np.float64]

#: Samples gathered before a fold (the covariance read in between is always current).
DEFAULT_BATCH_SIZE = 64
#: Smallest variance kept on the diagonal [rad², (rad/s)², 1] (a known-exact parameter).
VARIANCE_FLOOR = 1e-24
#: Largest variance [rad²] of an attitude covariance given from outside (``set_pose``): π²,
#: a 1σ of 180°. The error state is a rotation vector; a larger variance says no more than
#: "unknown about this axis" and is refused, so the propagated covariance stays finite.
MAX_ATTITUDE_VARIANCE = math.pi ** 2
#: Largest asymmetry accepted, relative to the largest entry of a covariance.
SYMMETRY_TOLERANCE = 1e-9
#: Most negative eigenvalue accepted, relative to the largest entry (round-off of a
#: positive semi-definite matrix computed elsewhere).
PSD_TOLERANCE = 1e-12
_SERIES_ANGLE = 0.1
_TINY_ANGLE = 1e-4
_EYE3 = np.eye(3)


class AttitudeStddev(NamedTuple):
    """1σ attitude errors [rad] about fixed world axes.

    ``world_x``, ``world_y``: roll/pitch-like errors about the world's horizontal axes;
    ``tilt``: the largest 1σ about any horizontal axis; ``yaw``: about the world's vertical.
    """

    world_x: float
    world_y: float
    tilt: float
    yaw: float


def _rotation_coefficients() -> FloatArray:
    """(16, 9): ``R(q)`` flattened = ``vec(q qᵀ) @ C / |q|²`` (each entry a quadratic form)."""
    terms = {  # entry -> {(i, j): coefficient} with q = (w, x, y, z) = indices 0..3
        0: {(0, 0): 1, (1, 1): 1, (2, 2): -1, (3, 3): -1}, 1: {(1, 2): 2, (0, 3): -2},
        2: {(1, 3): 2, (0, 2): 2}, 3: {(1, 2): 2, (0, 3): 2},
        4: {(0, 0): 1, (1, 1): -1, (2, 2): 1, (3, 3): -1}, 5: {(2, 3): 2, (0, 1): -2},
        6: {(1, 3): 2, (0, 2): -2}, 7: {(2, 3): 2, (0, 1): 2},
        8: {(0, 0): 1, (1, 1): -1, (2, 2): -1, (3, 3): 1},
    }
    coefficients = np.zeros((16, 9))
    for entry, products in terms.items():
        for (i, j), value in products.items():
            coefficients[4 * i + j, entry] = value
    return coefficients


def _skew_coefficients() -> FloatArray:
    """(3, 9): ``vec([φ×]) = φ @ C`` (row-major)."""
    coefficients = np.zeros((3, 9))
    for k, entry, sign in ((2, 1, -1), (1, 2, 1), (2, 3, 1), (0, 5, -1), (1, 6, -1),
                           (0, 7, 1)):
        coefficients[k, entry] = sign
    return coefficients


_ROTATION = _rotation_coefficients()
_SKEW = _skew_coefficients()


def _jacobian_coefficients(theta2: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``α = (1 − cos θ)/θ²``, ``β = (θ − sin θ)/θ³`` from ``θ²``: their series to θ⁴ when every
    θ < 0.1 (truncation below 3·10⁻¹¹ relative), else the closed forms (series below 10⁻⁴)."""
    if float(theta2.max(initial=0.0)) < _SERIES_ANGLE * _SERIES_ANGLE:
        theta4 = theta2 * theta2
        return (0.5 - theta2 / 24.0 + theta4 / 720.0,
                1.0 / 6.0 - theta2 / 120.0 + theta4 / 5040.0)
    theta = np.sqrt(theta2)
    small = theta < _TINY_ANGLE
    safe = np.where(small, 1.0, theta)
    alpha = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(safe)) / (safe * safe))
    beta = np.where(small, 1.0 / 6.0 - theta2 / 120.0, (safe - np.sin(safe)) / safe ** 3)
    return alpha, beta


def transition_blocks(q: FloatArray, rates: FloatArray, dt: FloatArray) -> FloatArray:
    """Sum over the samples of the coupling block ``B`` (3, 12) of the transition.

    ``q`` (n, 4) the estimated attitudes at the start of each step, ``rates`` (n, 3) the
    estimated body rates held over it [rad/s], ``dt`` (n,) the step lengths [s].
    ``M = R(q) J(φ) Δt`` with ``φ = ω Δt`` and the left Jacobian
    ``J = I + α [φ×] + β [φ×]² = (1 − β θ²) I + α [φ×] + β φ φᵀ``,
    ``α``, ``β`` from :func:`_jacobian_coefficients`.
    """
    count = q.shape[0]
    outer = (q[:, :, None] * q[:, None, :]).reshape(count, 16)
    rotation = (outer @ _ROTATION / outer[:, ::5].sum(axis=1)[:, None]).reshape(count, 3, 3)
    phi = rates * dt[:, None]
    theta2 = np.einsum('ni,ni->n', phi, phi)
    alpha, beta = _jacobian_coefficients(theta2)
    jacobian = (beta[:, None, None] * phi[:, :, None]) * phi[:, None, :]
    jacobian += ((phi * alpha[:, None]) @ _SKEW).reshape(count, 3, 3)
    jacobian += (1.0 - beta * theta2)[:, None, None] * _EYE3
    m = (rotation * dt[:, None, None]) @ jacobian
    weights = np.empty((count, 4))
    weights[:, 0] = 1.0
    weights[:, 1:] = rates
    sums = m.reshape(count, 9).T @ weights  # (9, 4): Σ M and Σ M[a, i] ω_j
    coupling = np.empty((3, 12))
    coupling[:, :3] = sums[:, 0].reshape(3, 3)
    coupling[:, 3:] = sums[:, 1:].reshape(3, 9)
    return -coupling


class AttitudeCovariance:
    """The 15×15 error-state covariance of a strapdown attitude (see the module docstring).

    Args:
        model: the gyro error budget (defaults: a consumer MEMS gyro).
        covariance: initial 15×15 covariance; default :func:`initial_covariance` of ``model``
            with ``window_seconds``.
        window_seconds: the levelling window [s] (``None``: not levelled).
        batch_size: samples gathered before a fold (1: fold every sample).
    """

    def __init__(self, model: GyroErrorModel | None = None, *,
                 covariance: ArrayLike | None = None, window_seconds: float | None = 1.0,
                 batch_size: int = DEFAULT_BATCH_SIZE) -> None:
        """Start from ``covariance`` or from the model's levelled initial covariance."""
        self.model = model or GyroErrorModel()
        if covariance is None:
            covariance = initial_covariance(self.model, window_seconds)
        self._p = _checked_covariance(covariance, 'covariance', ERROR_STATE_SIZE)
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
            raise InputError(f'Expected `batch_size` to be an integer >= 1, got {batch_size!r}')
        self.batch_size = batch_size
        self.rejected_samples = 0
        self._samples: list[tuple[float, ...]] = []

    def add_sample(self, q: tuple[float, float, float, float],
                   rate: tuple[float, float, float], dt: float) -> None:
        """Record one strapdown step: attitude ``q`` (w, x, y, z) at its start, the estimated
        body rate [rad/s] held over it, its length ``dt`` [s]. Folds every ``batch_size``."""
        self._samples.append((*q, *rate, dt))
        if len(self._samples) >= self.batch_size:
            self._fold()

    def add_samples(self, q: ArrayLike, rates: ArrayLike, dt: ArrayLike) -> None:
        """Record many steps at once (``q`` (n, 4), ``rates`` (n, 3), ``dt`` (n,) or scalar):
        pending samples are folded first, then the rows in chunks of ``batch_size``."""
        self._fold()
        q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
        rates = np.asarray(rates, dtype=np.float64).reshape(-1, 3)
        dt = np.broadcast_to(np.asarray(dt, dtype=np.float64), (q.shape[0],))
        if rates.shape[0] != q.shape[0]:
            raise InputError(f'Expected `q` and `rates` to have as many rows, got '
                             f'{q.shape[0]} and {rates.shape[0]}')
        for start in range(0, q.shape[0], self.batch_size):
            stop = start + self.batch_size
            self._apply(q[start:stop], rates[start:stop], dt[start:stop])

    def _fold(self) -> None:
        if self._samples:
            try:
                rows = np.array(self._samples, dtype=np.float64)
            except (TypeError, ValueError):
                rows = np.empty((0, 0))
            finally:
                self._samples.clear()
            if rows.ndim != 2 or rows.shape[1] != 8:
                raise InputError('Expected 4 attitude, 3 rate and 1 step values per sample')
            self._apply(rows[:, :4], rows[:, 4:7], rows[:, 7])

    def _apply(self, q: FloatArray, rates: FloatArray, dt: FloatArray) -> None:
        """``P ← Φ P Φᵀ + Q`` for the steps given; non-finite or non-positive steps dropped."""
        if dt.size == 0:
            return
        if not _all_good(q, rates, dt):
            good = (np.isfinite(q).all(axis=1) & np.isfinite(rates).all(axis=1)
                    & np.isfinite(dt) & (dt > 0.0) & (np.abs(q).sum(axis=1) > 0.0))
            self.rejected_samples += int((~good).sum())
            q, rates, dt = q[good], rates[good], dt[good]
            if dt.size == 0:
                return
        coupling = transition_blocks(q, rates, dt)
        self._p = propagated_covariance(self._p, coupling, float(dt.sum()), self.model)

    @property
    def covariance(self) -> FloatArray:
        """The full 15×15 covariance (a copy), with every recorded sample folded in."""
        self._fold()
        return self._p.copy()

    @property
    def attitude_covariance(self) -> FloatArray:
        """3×3 covariance [rad²] of the attitude error about fixed world axes (REP-145)."""
        self._fold()
        return self._p[:3, :3].copy()

    @property
    def folded_attitude_covariance(self) -> FloatArray:
        """The 3×3 world-frame attitude covariance at the last fold (at most
        ``batch_size − 1`` samples old), without folding: a cheap read for every sample."""
        return self._p[:3, :3].copy()

    def stddev(self) -> AttitudeStddev:
        """1σ errors about the world axes, the worst horizontal axis (tilt) and yaw [rad]."""
        p = self.attitude_covariance
        horizontal = np.linalg.eigvalsh(p[:2, :2])
        return AttitudeStddev(math.sqrt(p[0, 0]), math.sqrt(p[1, 1]),
                              math.sqrt(max(float(horizontal[-1]), 0.0)), math.sqrt(p[2, 2]))

    def set_pose(self, covariance: ArrayLike | None = None,
                 stddev: float | None = None) -> None:
        """Reset the attitude uncertainty after a pose is set.

        ``covariance``: the new 3×3 world-frame attitude covariance [rad²] (as a
        PoseWithCovarianceStamped's orientation block); or ``stddev`` [rad] on each axis.
        Bias and intrinsic uncertainties are kept; their correlation with the attitude is
        cleared (the new pose does not come from the gyro).
        """
        self._fold()
        if covariance is None:
            value = float('nan') if stddev is None else float(stddev)
            if not math.isfinite(value) or value <= 0.0:
                raise InputError(f'Expected `stddev` to be finite and > 0, got {stddev!r}')
            covariance = np.eye(3) * value * value
        block = checked_attitude_covariance(covariance)
        self._p[:3, 3:] = 0.0
        self._p[3:, :3] = 0.0
        self._p[:3, :3] = block


def _all_good(q: FloatArray, rates: FloatArray, dt: FloatArray) -> bool:
    """Whether every step is finite with ``dt > 0`` and a non-zero ``q`` (a few whole-array
    reductions: the common case of a fold)."""
    return bool(np.isfinite(q.sum() + rates.sum()) and float(dt.min()) > 0.0
                and np.isfinite(dt.sum()) and float(np.abs(q).sum(axis=1).min()) > 0.0)


def propagated_covariance(p: FloatArray, coupling: FloatArray, duration: float,
                          model: GyroErrorModel) -> FloatArray:
    """``Φ P Φᵀ + Q`` with ``Φ = [[I, coupling], [0, I]]``, symmetrised and floored."""
    pax = p[:3, 3:]
    cross = pax + coupling @ p[3:, 3:]
    attitude = p[:3, :3] + coupling @ pax.T + cross @ coupling.T
    mean_rotation = -coupling[:, :3] / duration
    walk = model.gyroscope_random_walk ** 2
    attitude += (model.gyroscope_noise_density ** 2 * duration * _EYE3
                 + walk * duration ** 3 / 3.0 * (mean_rotation @ mean_rotation.T))
    cross[:, :3] -= walk * duration ** 2 / 2.0 * mean_rotation
    out = p.copy()
    out[:3, :3] = 0.5 * (attitude + attitude.T)
    out[:3, 3:] = cross
    out[3:, :3] = cross.T
    out[3:6, 3:6] += walk * duration * _EYE3
    diagonal = np.einsum('ii->i', out)
    np.maximum(diagonal, VARIANCE_FLOOR, out=diagonal)
    if not np.all(np.isfinite(out)):
        raise InputError('Expected the propagated attitude covariance to stay finite; the '
                         'gyro error model or the steps are out of range')
    return out


def checked_attitude_covariance(value: ArrayLike, name: str = 'covariance') -> FloatArray:
    """``value`` as a 3×3 attitude covariance [rad²] (:func:`_checked_covariance`) whose
    diagonal is at most :data:`MAX_ATTITUDE_VARIANCE`; else InputError naming ``name``, the
    entry and the bound."""
    matrix = _checked_covariance(value, name, 3)
    largest = int(np.argmax(np.diag(matrix)))
    if matrix[largest, largest] > MAX_ATTITUDE_VARIANCE:
        raise InputError(f'Expected the variances of `{name}` to be at most pi^2 = '
                         f'{MAX_ATTITUDE_VARIANCE:.6g} rad^2 (1-sigma 180 deg: the attitude '
                         f'about that axis unknown), got {matrix[largest, largest]!r} on axis '
                         f'{"xyz"[largest]}')
    return matrix


def _checked_covariance(value: ArrayLike, name: str, size: int) -> FloatArray:
    """``value`` as a symmetric positive semi-definite (size, size) matrix, diagonal floored at
    :data:`VARIANCE_FLOOR`; else InputError. The checks and the symmetrising work on the
    matrix scaled by its largest entry, so no value up to the largest float overflows."""
    try:
        matrix = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f'Expected `{name}` to be a matrix of numbers') from None
    if matrix.shape != (size, size):
        raise InputError(f'Expected `{name}` to have shape ({size}, {size}), got {matrix.shape}')
    if not np.all(np.isfinite(matrix)):
        raise InputError(f'Expected `{name}` to be finite')
    scale = max(float(np.abs(matrix).max()), VARIANCE_FLOOR)
    unit = matrix / scale  # entries in [-1, 1]
    if np.abs(unit - unit.T).max() > SYMMETRY_TOLERANCE:
        raise InputError(f'Expected `{name}` to be symmetric')
    if not np.array_equal(matrix, matrix.T):
        unit = 0.5 * (unit + unit.T)
        matrix = unit * scale
    try:
        smallest = float(np.linalg.eigvalsh(unit)[0])
    except np.linalg.LinAlgError:
        smallest = -math.inf
    if not smallest >= -PSD_TOLERANCE:
        raise InputError(f'Expected `{name}` to be positive semi-definite')
    diagonal = np.einsum('ii->i', matrix)
    np.maximum(diagonal, VARIANCE_FLOOR, out=diagonal)
    return matrix
