"""Quaternion-feedback PD attitude control: the one copy of the law.

With the attitude error ``q_err = q_target* ⊗ q_world_body`` (Hamilton, scalar first, see
:mod:`rigid_body_attitude.core.attitude.quaternion`) and the body rate ``ω`` [rad/s], the commanded
body torque is

    ``τ = −k_p · sign(q_err,w) · q_err,xyz − k_d · ω``        (``sign(0) = +1``)

each component clipped to ``±torque_limit``. This is the regulator of B. Wie, H. Weiss and
A. Arapostathis, "Quaternion feedback regulator for spacecraft eigenaxis rotations",
J. Guidance, Control, and Dynamics 12(3):375-380, 1989: their control law
``u = −K q_e − C ω`` with diagonal ``K``, ``C`` and without the gyroscopic term. The sign of
the scalar part chooses the shorter of the two rotations that ``±q_err`` describe, so ``q``
and ``−q`` (the same attitude) give the same torque. For a rigid body
``J ω̇ + ω × J ω = τ``, scalar ``k_p`` and an unclipped torque,
``V = ½ ωᵀ J ω + 2 k_p (1 − |q_err,w|)`` has ``V̇ = −k_d |ω|² ≤ 0`` (their Lyapunov argument,
with ``q̇_err = ½ q_err ⊗ (0, ω)`` giving ``d|q_err,w|/dt = −½ sign(q_err,w) q_err,xyz · ω``).

Gains ``k_p`` [N m] and ``k_d`` [N m s] are scalars or per-axis ``(3,)`` vectors (body axes),
or ``(..., 3)`` for a batch of bodies each with its own. ``torque_limit`` [N m] likewise;
0 or ``inf`` means no limit on that axis.
The quaternions must be of unit norm (the callers check incoming messages); the law itself
checks shapes and finiteness only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError

__all__ = ['as_axis_gains', 'pd_torque_body', 'pd_torque_floats']

FloatArray = NDArray[np.float64]
Triple = tuple[float, float, float]


def as_axis_gains(value: ArrayLike, name: str, allow_inf: bool = False,
                  per_body: bool = False) -> FloatArray:
    """``value`` (a scalar or 3 numbers, each ≥ 0) as a ``(3,)`` array, or :class:`InputError`.

    ``allow_inf`` admits ``inf`` (a torque limit that does not limit); ``per_body`` admits
    ``(..., 3)`` (one set per body of a batch), returned as given.
    """
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(f'Expected `{name}` to be a number or 3 numbers, got {value!r}') from err
    if array.shape not in ((), (3,)) and not (per_body and array.shape[-1:] == (3,)):
        raise InputError(f'Expected `{name}` to be a number or 3 numbers, got shape '
                         f'{array.shape}')
    valid = (array >= 0.0) & (np.isfinite(array) | (allow_inf & (array == math.inf)))
    if not np.all(valid):
        bound = '≥ 0 (inf for none)' if allow_inf else 'finite and ≥ 0'
        raise InputError(f'Expected `{name}` to be {bound}, got {array.tolist()!r}')
    return np.broadcast_to(array, array.shape if array.ndim else (3,)).astype(np.float64)


def pd_torque_body(q_world_body: ArrayLike, omega_body: ArrayLike, q_world_target: ArrayLike,
                   kp: ArrayLike, kd: ArrayLike, torque_limit: ArrayLike) -> FloatArray:
    """Body torque [N m] of the quaternion-feedback PD law, shape ``(..., 3)``.

    ``q_world_body`` and ``q_world_target`` are ``(..., 4)`` unit quaternions (w, x, y, z),
    body → world; ``omega_body`` is ``(..., 3)`` [rad/s]; leading dimensions broadcast. A single
    body (shapes ``(4,)``, ``(3,)``, ``(4,)``) takes the plain-float path
    :func:`pd_torque_floats`, which gives the same numbers.
    """
    q = quaternion.as_quaternion(q_world_body, 'q_world_body')
    omega = quaternion.as_vector(omega_body, 'omega_body')
    target = quaternion.as_quaternion(q_world_target, 'q_world_target')
    gains = as_axis_gains(kp, 'kp', per_body=True), as_axis_gains(kd, 'kd', per_body=True)
    limit = as_axis_gains(torque_limit, 'torque_limit', allow_inf=True, per_body=True)
    if q.shape == (4,) and omega.shape == (3,) and target.shape == (4,) and \
            gains[0].shape == gains[1].shape == limit.shape == (3,):
        return np.array(pd_torque_floats(q.tolist(), omega.tolist(), target.tolist(),
                                         gains[0].tolist(), gains[1].tolist(), limit.tolist()))
    try:
        np.broadcast_shapes(q.shape[:-1], omega.shape[:-1], target.shape[:-1])
    except ValueError as err:
        raise InputError(f'Expected batch shapes that broadcast, got q_world_body {q.shape}, '
                         f'omega_body {omega.shape}, q_world_target {target.shape}') from err
    error = quaternion.multiply(quaternion.conjugate(target), q)
    sign = np.where(error[..., :1] < 0.0, -1.0, 1.0)
    torque: FloatArray = -gains[0] * sign * error[..., 1:] - gains[1] * omega
    bounded = (limit > 0.0) & (limit < math.inf)
    return np.where(bounded, np.clip(torque, -limit, limit), torque)


def pd_torque_floats(q_world_body: Sequence[float], omega_body: Sequence[float],
                     q_world_target: Sequence[float], kp: Sequence[float], kd: Sequence[float],
                     torque_limit: Sequence[float]) -> Triple:
    """:func:`pd_torque_body` for one body in plain float math (no NumPy: per-tick paths).

    Gains and limits are per-axis 3-sequences, already checked (:func:`as_axis_gains`); the
    quaternions and rate are not checked here.
    """
    tw, tx, ty, tz = q_world_target
    ew, ex, ey, ez = quaternion.multiply_floats((tw, -tx, -ty, -tz), q_world_body)
    sign = -1.0 if ew < 0.0 else 1.0
    return (_clipped(-kp[0] * sign * ex - kd[0] * omega_body[0], torque_limit[0]),
            _clipped(-kp[1] * sign * ey - kd[1] * omega_body[1], torque_limit[1]),
            _clipped(-kp[2] * sign * ez - kd[2] * omega_body[2], torque_limit[2]))


def _clipped(value: float, limit: float) -> float:
    """``value`` clipped to ``±limit``; 0 and ``inf`` do not limit."""
    if 0.0 < limit < math.inf:
        return min(max(value, -limit), limit)
    return value
