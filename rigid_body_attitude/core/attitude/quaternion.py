"""Quaternion algebra: the one place where the package's conventions are stated.

Conventions (every other module refers here):

* **Hamilton quaternions**, stored **scalar first** as ``(w, x, y, z)`` in arrays of shape
  ``(..., 4)``; vectors have shape ``(..., 3)``. Leading dimensions are batch dimensions.
  The product is ``p ⊗ q = (pw qw − pv·qv, pw qv + qw pv + pv × qv)``.
* **ROS messages carry (x, y, z, w)**. Convert only at the message boundary with
  :func:`to_ros` and :func:`from_ros`.
* **q maps body-frame vectors into the world frame**: ``v_world = q ⊗ (0, v_body) ⊗ q*``
  (:func:`rotate`). This is the meaning of a ROS pose orientation (the child/body frame
  expressed in the parent/world frame), and :func:`to_matrix` gives ``R`` with
  ``v_world = R v_body``.
* **Angular rates and torques are body-frame** (what a gyro measures). The Poisson kinematics
  are ``q̇ = ½ q ⊗ (0, ω_body)``; for a rate held constant over ``h`` the exact update is
  ``q ⊗ exp(h ω_body)``. A world-frame rate gives ``q̇ = ½ (0, ω_world) ⊗ q``.
* **Rotation vectors** ``v`` (axis times angle, radians) map to quaternions by
  :func:`exp`: ``exp(v) = (cos(|v|/2), sin(|v|/2) v/|v|)``; :func:`log` is its inverse and
  returns angles in ``[0, π]``.
* **Double cover**: ``q`` and ``−q`` are the same attitude. :func:`canonical` picks ``w ≥ 0``;
  :func:`continuous` picks the sign closest to a previous output so published streams never
  jump. :func:`attitude_error` is sign-invariant.
* **Euler angles (ZXZ)** ``(ψ, θ, φ)``: ``q = exp(ψ e_z) ⊗ exp(θ e_x) ⊗ exp(φ e_z)``
  (intrinsic z–x′–z″, seeds 000 eq. 20 and 002). **Bryant angles (XYZ)** ``(α₁, α₂, α₃)``:
  ``q = exp(α₁ e_x) ⊗ exp(α₂ e_y) ⊗ exp(α₃ e_z)`` (Wittenburg, *Dynamics of Multibody Systems*, 2nd
  ed., 2008, §2.2).
* Units SI, frames right-handed (REP-103), the world frame ENU by default.

Small angles use series (``sin(a/2)/a ≈ ½ − a²/48 + a⁴/3840``) below ``SERIES_THRESHOLD`` so
zero and subnormal rates never divide by zero.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.errors import InputError

__all__ = [
    'SERIES_THRESHOLD',
    'as_bryant_xyz',
    'as_euler_zxz',
    'as_quaternion',
    'as_vector',
    'attitude_error',
    'canonical',
    'conjugate',
    'continuous',
    'exp',
    'from_bryant_xyz',
    'from_euler_zxz',
    'from_rpy',
    'from_matrix',
    'from_ros',
    'identity',
    'log',
    'multiply',
    'multiply_floats',
    'norm_error',
    'normalize',
    'rotate',
    'rotate_floats',
    'rotate_inverse',
    'rotate_inverse_floats',
    'rotate_rows',
    'scalar_step_rate',
    'to_matrix',
    'to_ros',
]

FloatArray = NDArray[np.float64]

#: Below this angle (rad) exp, log and their derivatives use series expansions.
SERIES_THRESHOLD = 1e-4


def _checked(value: ArrayLike, name: str, size: int, finite: bool) -> FloatArray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `{name}` to be numeric with shape (..., {size}), '
                         f'got {value!r}') from err
    if array.ndim == 0 or array.shape[-1] != size:
        raise InputError(f'Expected `{name}` to have shape (..., {size}), got {array.shape}')
    if finite and not np.all(np.isfinite(array)):
        raise InputError(f'Expected `{name}` to be finite, got {array.tolist()!r}')
    return array


def as_quaternion(value: ArrayLike, name: str = 'q', finite: bool = True) -> FloatArray:
    """Return ``value`` as a float array of shape ``(..., 4)`` or raise :class:`InputError`.

    The error names ``name``, the shape or values received, and the shape expected.
    """
    return _checked(value, name, 4, finite)


def as_vector(value: ArrayLike, name: str = 'v', finite: bool = True) -> FloatArray:
    """Return ``value`` as a float array of shape ``(..., 3)`` or raise :class:`InputError`."""
    return _checked(value, name, 3, finite)


def identity(shape: tuple[int, ...] = ()) -> FloatArray:
    """Identity quaternion(s) ``(1, 0, 0, 0)`` with batch shape ``shape``."""
    q = np.zeros(shape + (4,))
    q[..., 0] = 1.0
    return q


def multiply(p: ArrayLike, q: ArrayLike) -> FloatArray:
    """Hamilton product ``p ⊗ q`` (broadcast over batch dimensions)."""
    p = as_quaternion(p, 'p', finite=False)
    q = as_quaternion(q, 'q', finite=False)
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    ], axis=-1)


def multiply_floats(p: Sequence[float],
                    q: Sequence[float]) -> tuple[float, float, float, float]:
    """:func:`multiply` for two plain-float quaternions (no NumPy: hot paths)."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw)


def conjugate(q: ArrayLike) -> FloatArray:
    """Conjugate ``q* = (w, −x, −y, −z)``, the inverse rotation of a unit quaternion."""
    q = as_quaternion(q, finite=False)
    conjugated: FloatArray = q * np.array([1.0, -1.0, -1.0, -1.0])
    return conjugated


def normalize(q: ArrayLike) -> FloatArray:
    """Scale ``q`` to unit norm; a zero or non-finite quaternion is an :class:`InputError`."""
    q = as_quaternion(q)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        raise InputError(f'Expected `q` to be non-zero to normalise, got {q.tolist()!r}')
    unit: FloatArray = q / norm
    return unit


def norm_error(q: ArrayLike) -> FloatArray | float:
    """``| |q| − 1 |``, the quaternion norm error tracked by the diagnostics."""
    q = as_quaternion(q, finite=False)
    result = np.abs(np.linalg.norm(q, axis=-1) - 1.0)
    return float(result) if result.ndim == 0 else result


def _half_sinc(angle: FloatArray) -> FloatArray:
    """``sin(a/2)/a`` with the series ``½ − a²/48 + a⁴/3840`` below the threshold."""
    small = angle < SERIES_THRESHOLD
    safe = np.where(small, 1.0, angle)
    series = 0.5 - angle * angle / 48.0 + angle ** 4 / 3840.0
    return np.where(small, series, np.sin(0.5 * safe) / safe)


def exp(rotation_vector: ArrayLike) -> FloatArray:
    """Unit quaternion of the rotation vector ``v``: ``(cos(|v|/2), sin(|v|/2) v/|v|)``.

    Exact for any angle; the series branch keeps zero and subnormal vectors exact.
    """
    v = as_vector(rotation_vector, 'rotation_vector')
    angle = np.linalg.norm(v, axis=-1)
    scale = _half_sinc(angle)
    return np.concatenate([np.cos(0.5 * angle)[..., None], v * scale[..., None]], axis=-1)


def log(q: ArrayLike) -> FloatArray:
    """Rotation vector of the unit quaternion ``q`` with angle in ``[0, π]`` (inverse of exp).

    Uses ``atan2`` so that angles near 0 and near π stay accurate; ``q`` and ``−q`` give the
    same result.
    """
    q = as_quaternion(q)
    q = np.where(q[..., :1] < 0.0, -q, q)
    w = q[..., 0]
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1)
    small = s < SERIES_THRESHOLD * np.maximum(w, 1e-300)
    safe_s = np.where(small, 1.0, s)
    ratio = np.where(w > 0, s / np.where(w > 0, w, 1.0), 0.0)
    series = (2.0 / np.where(w > 0, w, 1.0)) * (1.0 - ratio ** 2 / 3.0 + ratio ** 4 / 5.0)
    scale = np.where(small, series, 2.0 * np.arctan2(s, w) / safe_s)
    return v * scale[..., None]


def rotate(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """Body-frame vector ``v`` expressed in the world frame: ``q ⊗ (0, v) ⊗ q*``."""
    q = as_quaternion(q, finite=False)
    v = as_vector(v, finite=False)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def rotate_floats(q: Sequence[float], v: Sequence[float]) -> tuple[float, float, float]:
    """:func:`rotate` for one plain-float quaternion and vector (no NumPy: hot paths).

    ``v + w t + u × t`` with ``t = 2 u × v`` (18 products).
    """
    w, x, y, z = q
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


def rotate_inverse_floats(q: Sequence[float],
                          v: Sequence[float]) -> tuple[float, float, float]:
    """:func:`rotate_inverse` for one plain-float quaternion and vector: rotation by ``q*``."""
    w, x, y, z = q
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (z * vy - y * vz), 2.0 * (x * vz - z * vx), 2.0 * (y * vx - x * vy)
    return (vx + w * tx + (z * ty - y * tz), vy + w * ty + (x * tz - z * tx),
            vz + w * tz + (y * tx - x * ty))


def rotate_rows(q: FloatArray, v: FloatArray, inverse: bool = False) -> FloatArray:
    """:func:`rotate` (or, with ``inverse``, :func:`rotate_inverse`) in structure-of-arrays
    layout: ``q`` of shape (4, n) (rows w, x, y, z), ``v`` of shape (3, n) or (3, 1); returns
    (3, n). For batch kernels: components as rows keep every operation on contiguous rows."""
    w, x, y, z = q
    if v.shape[1] == 1:  # one vector for every quaternion: plain floats broadcast fastest
        vx, vy, vz = (float(c) for c in v[:, 0])
    else:
        vx, vy, vz = v
    if inverse:  # rotation by q* = (w, -x, -y, -z): the same formula, bit for bit
        x, y, z = -x, -y, -z
    out = np.empty((3, q.shape[1]))
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    np.add(vx + w * tx, y * tz - z * ty, out=out[0])
    np.add(vy + w * ty, z * tx - x * tz, out=out[1])
    np.add(vz + w * tz, x * ty - y * tx, out=out[2])
    return out


def rotate_inverse(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """World-frame vector ``v`` expressed in the body frame: ``q* ⊗ (0, v) ⊗ q``."""
    return rotate(conjugate(q), v)


def to_matrix(q: ArrayLike) -> FloatArray:
    """Rotation matrix ``R`` (shape ``(..., 3, 3)``) with ``v_world = R v_body``."""
    q = normalize(q)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=-2)


def from_matrix(matrix: ArrayLike) -> FloatArray:
    """Unit quaternion (``w ≥ 0``) of a rotation matrix, by Shepperd's stable branch choice."""
    m = np.asarray(matrix, dtype=np.float64)
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise InputError(f'Expected `matrix` to have shape (..., 3, 3), got {m.shape}')
    if not np.all(np.isfinite(m)):
        raise InputError(f'Expected `matrix` to be finite, got {m.tolist()!r}')
    trace = np.trace(m, axis1=-2, axis2=-1)
    diag = np.diagonal(m, axis1=-2, axis2=-1)
    candidates = np.stack([
        np.stack([1 + trace, m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                  m[..., 1, 0] - m[..., 0, 1]], -1),
        np.stack([m[..., 2, 1] - m[..., 1, 2], 1 + 2 * diag[..., 0] - trace,
                  m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0]], -1),
        np.stack([m[..., 0, 2] - m[..., 2, 0], m[..., 0, 1] + m[..., 1, 0],
                  1 + 2 * diag[..., 1] - trace, m[..., 1, 2] + m[..., 2, 1]], -1),
        np.stack([m[..., 1, 0] - m[..., 0, 1], m[..., 0, 2] + m[..., 2, 0],
                  m[..., 1, 2] + m[..., 2, 1], 1 + 2 * diag[..., 2] - trace], -1),
    ], axis=-2)
    pivots = np.concatenate([trace[..., None], diag], axis=-1)
    best = np.argmax(pivots, axis=-1)
    chosen = np.take_along_axis(candidates, best[..., None, None], axis=-2)[..., 0, :]
    return canonical(normalize(chosen))


def canonical(q: ArrayLike) -> FloatArray:
    """The representative of ``±q`` with ``w ≥ 0``."""
    q = as_quaternion(q, finite=False)
    return np.where(q[..., :1] < 0.0, -q, q)


def continuous(q: ArrayLike, previous: ArrayLike) -> FloatArray:
    """The representative of ``±q`` closest to ``previous`` (``q · previous ≥ 0``)."""
    q = as_quaternion(q, finite=False)
    previous = as_quaternion(previous, 'previous', finite=False)
    dot = np.sum(q * previous, axis=-1, keepdims=True)
    return np.where(dot < 0.0, -q, q)


def attitude_error(p: ArrayLike, q: ArrayLike) -> FloatArray | float:
    """Angle (rad, in ``[0, π]``) of the rotation between ``p`` and ``q``; sign-invariant.

    ``2 atan2(|vec(p* ⊗ q)|, |scalar(p* ⊗ q)|)``: the rotation angle of ``p* ⊗ q`` (Shuster,
    "A survey of attitude representations", 1993, §5).
    """
    d = multiply(conjugate(p), q)
    result = 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))
    return float(result) if result.ndim == 0 else result


def to_ros(q: ArrayLike) -> FloatArray:
    """Scalar-first ``(w, x, y, z)`` → ROS message order ``(x, y, z, w)``."""
    q = as_quaternion(q, finite=False)
    return q[..., [1, 2, 3, 0]]


def from_ros(xyzw: ArrayLike) -> FloatArray:
    """ROS message order ``(x, y, z, w)`` → scalar-first ``(w, x, y, z)``."""
    q = as_quaternion(xyzw, 'xyzw', finite=False)
    return q[..., [3, 0, 1, 2]]


def _axis_quaternion(angle: FloatArray, axis: int) -> FloatArray:
    angle = np.asarray(angle, dtype=np.float64)
    q = np.zeros(angle.shape + (4,))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., axis + 1] = np.sin(0.5 * angle)
    return q


def _three_angles(angles: ArrayLike, name: str) -> FloatArray:
    return _checked(angles, name, 3, True)


def from_euler_zxz(angles: ArrayLike) -> FloatArray:
    """Quaternion of Euler angles ``(ψ, θ, φ)``: ``exp(ψ e_z) ⊗ exp(θ e_x) ⊗ exp(φ e_z)``."""
    a = _three_angles(angles, 'angles')
    return multiply(multiply(_axis_quaternion(a[..., 0], 2), _axis_quaternion(a[..., 1], 0)),
                    _axis_quaternion(a[..., 2], 2))


def as_euler_zxz(q: ArrayLike) -> FloatArray:
    """Euler angles ``(ψ, θ, φ)``, ``θ ∈ [0, π]``; at ``sin θ = 0`` only ψ ± φ is defined.

    In the gimbal-lock case (θ = 0 or π) φ is set to 0 and ψ carries the whole rotation.
    Read from the quaternion, not the matrix: ``q = (cos(θ/2) cos((ψ+φ)/2),
    sin(θ/2) cos((ψ−φ)/2), sin(θ/2) sin((ψ−φ)/2), cos(θ/2) sin((ψ+φ)/2))``, so θ comes from
    atan2 (accurate near 0 and π) and ψ ± φ from well-conditioned half-angles.
    """
    w, x, y, z = np.moveaxis(normalize(q), -1, 0)
    sin_half, cos_half = np.hypot(x, y), np.hypot(w, z)
    theta = 2.0 * np.arctan2(sin_half, cos_half)
    angle_sum, angle_difference = 2.0 * np.arctan2(z, w), 2.0 * np.arctan2(y, x)
    return _locked_angles(angle_sum, theta, angle_difference, cos_half, sin_half)


def from_bryant_xyz(angles: ArrayLike) -> FloatArray:
    """Quaternion of Bryant angles ``(α₁, α₂, α₃)``.

    ``q = exp(α₁ e_x) ⊗ exp(α₂ e_y) ⊗ exp(α₃ e_z)``.
    """
    a = _three_angles(angles, 'angles')
    return multiply(multiply(_axis_quaternion(a[..., 0], 0), _axis_quaternion(a[..., 1], 1)),
                    _axis_quaternion(a[..., 2], 2))


def from_rpy(angles: ArrayLike) -> FloatArray:
    """Quaternion of roll, pitch and yaw ``(..., 3)`` [rad] as REP-103 and tf2's ``setRPY``
    take them (``static_transform_publisher``'s angles): ``Rz(yaw) Ry(pitch) Rx(roll)``,
    intrinsic z-y'-x'', the product of the three axis quaternions; ``(..., 4)``.

    The one conversion of the package: scene parameters (``target_rpy``, ``mount_rpy``), the
    node's and the controller's parameters and the levelled attitude all go through it.
    """
    a = _three_angles(angles, 'angles')
    return multiply(multiply(_axis_quaternion(a[..., 2], 2), _axis_quaternion(a[..., 1], 1)),
                    _axis_quaternion(a[..., 0], 0))


def as_bryant_xyz(q: ArrayLike) -> FloatArray:
    """Bryant angles ``(α₁, α₂, α₃)``, ``α₂ ∈ [−π/2, π/2]``; singular at ``cos α₂ = 0``.

    In the gimbal-lock case α₃ is set to 0 and α₁ carries the remaining rotation.
    Read from the quaternion: with ``β = α₂/2 + π/4``, ``(w + y, x + z) = √2 sin β
    (cos, sin)((α₁+α₃)/2)`` and ``(w − y, x − z) = √2 cos β (cos, sin)((α₁−α₃)/2)``.
    """
    w, x, y, z = np.moveaxis(normalize(q), -1, 0)
    sin_beta, cos_beta = np.hypot(w + y, x + z), np.hypot(w - y, x - z)
    alpha2 = 2.0 * np.arctan2(sin_beta, cos_beta) - 0.5 * np.pi
    angle_sum = 2.0 * np.arctan2(x + z, w + y)
    angle_difference = 2.0 * np.arctan2(x - z, w - y)
    return _locked_angles(angle_sum, alpha2, angle_difference, sin_beta / np.sqrt(2.0),
                          cos_beta / np.sqrt(2.0))


def _locked_angles(angle_sum: FloatArray, middle: FloatArray, angle_difference: FloatArray,
                   sum_weight: FloatArray, difference_weight: FloatArray) -> FloatArray:
    """``(first, middle, last)`` from ``first ± last``, wrapped to ``[−π, π)``.

    ``sum_weight`` and ``difference_weight`` are the lengths of the half-angle vectors the sum
    and the difference were read from. Where ``sin`` of the middle angle (their doubled
    product) is below 1e−12 only the one with the larger weight is defined: the last angle is
    set to 0 and the first carries that one.
    """
    locked = 2.0 * sum_weight * difference_weight < 1e-12
    first = 0.5 * (angle_sum + angle_difference)
    last = 0.5 * (angle_sum - angle_difference)
    defined = np.where(sum_weight >= difference_weight, angle_sum, angle_difference)
    first = np.where(locked, defined, first)
    last = np.where(locked, 0.0, last)
    return np.stack([_wrapped(first), middle, _wrapped(last)], axis=-1)


def _wrapped(angle: FloatArray) -> FloatArray:
    """``angle`` wrapped to ``[−π, π)``."""
    return np.remainder(angle + np.pi, 2.0 * np.pi) - np.pi


def scalar_exp_step(q: Any, omega: Any, dt: float) -> tuple[float, float, float, float]:
    """``q ⊗ exp(dt ω)`` for one body in plain float math (no NumPy per-call overhead).

    ``q`` is a 4-sequence ``(w, x, y, z)``, ``omega`` a 3-sequence (rad/s, body frame). The
    result is renormalised, so the norm error stays at round-off however many steps are taken.
    A non-finite ``omega * dt`` or a zero or non-finite ``q`` raises :class:`InputError`.
    """
    qw, qx, qy, qz = q
    vx, vy, vz = omega[0] * dt, omega[1] * dt, omega[2] * dt
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    if not math.isfinite(angle):
        raise InputError(f'Expected a finite rotation `omega * dt`, got omega={tuple(omega)!r}, '
                         f'dt={dt!r}')
    if angle < SERIES_THRESHOLD:
        a2 = angle * angle
        scale = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        scale = math.sin(0.5 * angle) / angle
    ew, ex, ey, ez = math.cos(0.5 * angle), vx * scale, vy * scale, vz * scale
    w = qw * ew - qx * ex - qy * ey - qz * ez
    x = qw * ex + qx * ew + qy * ez - qz * ey
    y = qw * ey - qx * ez + qy * ew + qz * ex
    z = qw * ez + qx * ey - qy * ex + qz * ew
    norm_squared = w * w + x * x + y * y + z * z
    if not 0.0 < norm_squared < math.inf:
        raise InputError(f'Expected `q` to be a finite non-zero quaternion, got {tuple(q)!r}')
    inv = 1.0 / math.sqrt(norm_squared)
    return w * inv, x * inv, y * inv, z * inv


def scalar_step_rate(q_before: Sequence[float], q_after: Sequence[float],
                     dt: float) -> tuple[float, float, float]:
    """The body rate [rad/s] held over ``dt`` that turns ``q_before`` into ``q_after``:
    ``log(q_before* ⊗ q_after) / dt`` (the shorter way round), in plain float math.

    The inverse of :func:`scalar_exp_step`; the two (non-zero) quaternions need not be of
    norm 1. ``dt`` must be > 0.
    """
    w0, x0, y0, z0 = q_before
    w1, x1, y1, z1 = q_after
    w = w0 * w1 + x0 * x1 + y0 * y1 + z0 * z1
    x = w0 * x1 - x0 * w1 - y0 * z1 + z0 * y1
    y = w0 * y1 + x0 * z1 - y0 * w1 - z0 * x1
    z = w0 * z1 - x0 * y1 + y0 * x1 - z0 * w1
    sine = math.sqrt(x * x + y * y + z * z)  # |q| sin(angle / 2)
    if sine > SERIES_THRESHOLD * abs(w):
        k = 2.0 * math.atan2(sine, abs(w)) / sine
    else:  # 2 atan(s/w)/s = 2/w (1 − (s/w)²/3 + (s/w)⁴/5 ...): last term below 3e-17
        k = 2.0 / abs(w) * (1.0 - sine * sine / (3.0 * w * w))
    k = math.copysign(k, w) / dt
    return k * x, k * y, k * z
