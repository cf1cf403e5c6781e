"""gravity_gradient: the gravity-gradient torque on a satellite in a circular orbit.

``M = 3 μ / r³ · r̂_b × (J r̂_b)``, ``r̂_b = R(q)ᵀ r̂_w(t)`` the unit vector from the planet's
centre to the satellite in body axes (Source: Hughes, *Spacecraft Attitude Dynamics*, §8.1;
Basilisk GravityGradientEffector). The world frame is inertial with the planet at its origin; the
orbit is circular with radius ``orbit_radius`` in the plane normal to ``orbit_normal``, mean
motion ``n = √(μ/r³)``, anomaly ``u = initial_anomaly + n t``; in a scene with an ``orbit:``
section the orbit is that one (its radius, ``μ``, plane and argument of latitude; the effect's
own orbit parameters are then refused). Assumptions: point-mass planet,
body small against ``r``, the orbit unaffected by the attitude. In a batch every body is on
the same orbit (its own inertia and attitude).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.batch_rows import cross_rows
from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, BatchChunk, BodyProperties, FloatArray, Parameter, positive, Quat, real, register,
    TorqueEffect, Vec, vector3)
from rigid_body_attitude.core.errors import SceneError

EARTH_MU = 3.986004418e14


def _radius(value: Any) -> float | None:
    """A radius > 0, or none (the scene's orbit)."""
    return None if value is None else positive(value)


@register
class GravityGradient(TorqueEffect):
    """Gravity-gradient torque [N m] for a circular orbit."""

    name = 'gravity_gradient'
    description = 'gravity-gradient torque 3μ/r³ r̂ × J r̂ on a circular orbit'
    parameters = {
        'orbit_radius': Parameter(_radius, None, 'orbit radius [m]'),
        'mu': Parameter(positive, EARTH_MU, 'gravitational parameter [m³/s²]'),
        'initial_anomaly': Parameter(real, 0.0, 'argument of latitude at t = 0 [rad]'),
        'orbit_normal': Parameter(vector3, [0.0, 0.0, 1.0], 'orbit normal, world frame'),
    }

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Build an orthonormal orbit-plane basis from ``orbit_normal`` (or take the scene's
        orbit)."""
        super().__init__(params, body)
        self.tensor = tuple(body.inertia.tensor.ravel().tolist())
        orbit = body.environment.orbit
        if orbit is not None:
            given = sorted(set(params) & {'orbit_radius', 'mu', 'initial_anomaly',
                                          'orbit_normal'})
            if given:
                raise SceneError(f"Effect 'gravity_gradient': parameter {given[0]!r} is given "
                                 f"by the scene's orbit: section; remove it")
            self.first_axis, self.second_axis = orbit.axes[0], orbit.axes[1]
            self.initial_anomaly = orbit.argument_of_latitude
            self._set_orbit(orbit.radius, orbit.mu)
            return
        if self.params['orbit_radius'] is None:
            raise SceneError("Effect 'gravity_gradient': missing parameter 'orbit_radius' "
                             "(orbit radius [m]) or the scene's orbit: section")
        self.initial_anomaly = self.params['initial_anomaly']
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
        self._set_orbit(self.params['orbit_radius'], self.params['mu'])

    def _set_orbit(self, radius: float, mu: float) -> None:
        """Mean motion and torque gain of the circular orbit."""
        self.mean_motion = math.sqrt(mu / radius ** 3)
        self.gain = 3.0 * mu / radius ** 3

    def radial(self, t: float) -> Vec:
        """Unit vector from the planet to the body at ``t``, world frame (plain floats)."""
        anomaly = self.initial_anomaly + self.mean_motion * t
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
        """The same orbit for every body; each body's own inertia and attitude: ``r̂_b`` by
        the formula of :func:`~rigid_body_attitude.core.attitude.quaternion.rotate_inverse_floats`
        (``τ = 2 r̂_w × q_v`` as one product with a constant matrix), then ``r̂_b × (gain J)
        r̂_b``, row by row into work arrays kept by the chunk."""
        x, y, z = self.radial(t)
        work = chunk.scratch('work', 1)[0]
        turn = chunk.scratch('turn', 3)
        np.matmul(np.array([[0.0, -2.0 * z, 2.0 * y], [2.0 * z, 0.0, -2.0 * x],
                            [-2.0 * y, 2.0 * x, 0.0]]), q[1:], out=turn)
        radial = chunk.scratch('radial', 3)  # r̂_w + w τ + τ × q_v
        for row, component in enumerate((x, y, z)):
            np.multiply(q[0], turn[row], out=radial[row])
            radial[row] += component
        cross_rows(turn, q[1:], radial, work, accumulate=True)
        inertial = chunk.inertia_product(radial, chunk.scratch('inertial', 3), self.gain)
        cross_rows(radial, inertial, out, work, accumulate=True)
