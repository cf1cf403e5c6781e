"""Plain-float quaternion helpers of the per-step integrator code (tuples, no NumPy).

Conventions are those of :mod:`rigid_body_attitude.core.attitude.quaternion` (Hamilton, scalar
first, ``q`` maps body to world). Hot per-step code works on tuples of floats: NumPy costs about
1 µs per call, more than a whole plain-float quaternion product. The strapdown and kinematic
integrators (:mod:`.integrators`) and the dynamics integrators share these.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import IntegratorError

__all__ = ['Quat', 'SERIES_THRESHOLD', 'Vec', 'finite_vec3', 'q_exp', 'q_multiply',
           'q_normalize', 'q_rotate_step']

Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]

#: Below this rotation angle (rad) the exponential uses its series (quaternion.py).
SERIES_THRESHOLD = quat.SERIES_THRESHOLD


def q_multiply(a: Sequence[float], b: Sequence[float]) -> Quat:
    """Hamilton product ``a ⊗ b`` of two 4-sequences (plain floats)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def q_exp(vx: float, vy: float, vz: float) -> Quat:
    """``exp(v) = (cos(|v|/2), sin(|v|/2) v/|v|)`` with the series below the threshold."""
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    if angle < SERIES_THRESHOLD:  # guard zero and subnormal angles
        a2 = angle * angle
        scale = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        scale = math.sin(0.5 * angle) / angle
    return math.cos(0.5 * angle), vx * scale, vy * scale, vz * scale


def q_normalize(q: Sequence[float]) -> Quat:
    """``q/|q|`` (plain floats); a zero or non-finite norm raises :class:`IntegratorError`."""
    w, x, y, z = q
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if not (norm > 0.0 and math.isfinite(norm)):
        raise IntegratorError(f'Expected a finite non-zero quaternion, got {tuple(q)!r}; the '
                              f'step is unstable for this rate')
    inv = 1.0 / norm
    return w * inv, x * inv, y * inv, z * inv


def q_rotate_step(q: Sequence[float], vx: float, vy: float, vz: float) -> Quat:
    """``normalize(q ⊗ exp(v))``: the exact update for the rotation vector ``v`` (body)."""
    return q_normalize(q_multiply(q, q_exp(vx, vy, vz)))


def finite_vec3(value: object) -> Vec | None:
    """``value`` when it is a tuple of 3 finite floats, else ``None`` (for the caller's
    general check): a command's vector checked without NumPy."""
    if type(value) is tuple and len(value) == 3:
        x, y, z = value
        if (type(x) is float and type(y) is float and type(z) is float
                and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            return x, y, z
    return None
