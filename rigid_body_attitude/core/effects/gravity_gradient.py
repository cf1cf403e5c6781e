"""gravity_gradient: the gravity-gradient torque on a satellite in a circular orbit.

``M = 3 μ / r³ · r̂_b × (J r̂_b)``, ``r̂_b = R(q)ᵀ r̂_w(t)`` the unit vector from the planet's
centre to the satellite in body axes (Source: Hughes, *Spacecraft Attitude Dynamics*, §8.1;
Basilisk GravityGradientEffector). The world frame is inertial with the planet at its origin; the
orbit is circular with radius ``orbit_radius`` in the plane normal to ``orbit_normal``, mean
motion ``n = √(μ/r³)``, anomaly ``u = initial_anomaly + n t``. Assumptions: point-mass planet,
body small against ``r``, the orbit unaffected by the attitude. In a batch every body is on
the same orbit (its own inertia and attitude).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.effects.base import (
    as_vec, BatchChunk, BodyProperties, FloatArray, Parameter, positive, Quat, real, register,
    REQUIRED, TorqueEffect, Vec, vector3)
from rigid_body_attitude.core.errors import SceneError

EARTH_MU = 3.986004418e14


@register
class GravityGradient(TorqueEffect):
    """Gravity-gradient torque [N m] for a circular orbit."""

    name = 'gravity_gradient'
    description = 'gravity-gradient torque 3μ/r³ r̂ × J r̂ on a circular orbit'
    parameters = {
        'orbit_radius': Parameter(positive, REQUIRED, 'orbit radius [m]'),
        'mu': Parameter(positive, EARTH_MU, 'gravitational parameter [m³/s²]'),
        'initial_anomaly': Parameter(real, 0.0, 'argument of latitude at t = 0 [rad]'),
        'orbit_normal': Parameter(vector3, [0.0, 0.0, 1.0], 'orbit normal, world frame'),
    }

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Build an orthonormal orbit-plane basis from ``orbit_normal``."""
        super().__init__(params, body)
        normal = self.params['orbit_normal']
        norm = float(np.linalg.norm(normal))
        if norm == 0.0:
            raise SceneError("Effect 'gravity_gradient': parameter 'orbit_normal' must be "
                             f'non-zero, got {normal.tolist()!r}')
        normal = normal / norm
        helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0, 1.0, 0])
        first_axis = np.cross(helper, normal)
        first_axis /= np.linalg.norm(first_axis)
        self.first_axis = as_vec(first_axis)
        self.second_axis = as_vec(np.cross(normal, first_axis))
        radius = self.params['orbit_radius']
        self.mean_motion = math.sqrt(self.params['mu'] / radius ** 3)
        self.gain = 3.0 * self.params['mu'] / radius ** 3
        self.tensor = tuple(body.inertia.tensor.ravel().tolist())

    def radial(self, t: float) -> Vec:
        """Unit vector from the planet to the body at ``t``, world frame (plain floats)."""
        anomaly = self.params['initial_anomaly'] + self.mean_motion * t
        c, s = math.cos(anomaly), math.sin(anomaly)
        a, b = self.first_axis, self.second_axis
        return c * a[0] + s * b[0], c * a[1] + s * b[1], c * a[2] + s * b[2]

    def radial_world(self, t: float) -> FloatArray:
        """:meth:`radial` as a (3,) array."""
        return np.array(self.radial(t))

    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """``3μ/r³ r̂_b × J r̂_b`` [N m]."""
        x, y, z = quaternion.rotate_inverse_floats(q, self.radial(t))
        j00, j01, j02, j10, j11, j12, j20, j21, j22 = self.tensor
        jx = j00 * x + j01 * y + j02 * z
        jy = j10 * x + j11 * y + j12 * z
        jz = j20 * x + j21 * y + j22 * z
        gain = self.gain
        return gain * (y * jz - z * jy), gain * (z * jx - x * jz), gain * (x * jy - y * jx)

    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """The same orbit for every body; each body's own inertia and attitude."""
        radial = np.array(self.radial(t))[:, None]
        x, y, z = quaternion.rotate_rows(q, radial, inverse=True)
        tensor = chunk.tensor
        if chunk.diagonal:
            jx, jy, jz = tensor[0, 0] * x, tensor[1, 1] * y, tensor[2, 2] * z
        elif tensor.shape[2] > 1:  # a tensor per body: one contraction
            jx, jy, jz = np.einsum('ijn,jn->in', tensor, np.stack((x, y, z)))
        else:
            jx = tensor[0, 0] * x + tensor[0, 1] * y + tensor[0, 2] * z
            jy = tensor[1, 0] * x + tensor[1, 1] * y + tensor[1, 2] * z
            jz = tensor[2, 0] * x + tensor[2, 1] * y + tensor[2, 2] * z
        gain = self.gain
        out[0] += gain * (y * jz - z * jy)
        out[1] += gain * (z * jx - x * jz)
        out[2] += gain * (x * jy - y * jx)
