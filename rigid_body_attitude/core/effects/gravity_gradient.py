"""gravity_gradient: the gravity-gradient torque on a satellite in a circular orbit.

``M = 3 μ / r³ · r̂_b × (J r̂_b)``, ``r̂_b = R(q)ᵀ r̂_w(t)`` the unit vector from the planet's
centre to the satellite in body axes (Hughes, *Spacecraft Attitude Dynamics*, §8.1; Basilisk
GravityGradientEffector). The world frame is inertial with the planet at its origin; the
orbit is circular with radius ``orbit_radius`` in the plane normal to ``orbit_normal``, mean
motion ``n = √(μ/r³)``, anomaly ``u = initial_anomaly + n t``. Assumptions: point-mass planet,
body small against ``r``, the orbit unaffected by the attitude.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.core.effects.base import (
    REQUIRED, BodyProperties, Effect, Parameter, positive, real, register, vector3)
from rigid_body_attitude.core.errors import SceneError

EARTH_MU = 3.986004418e14


@register
class GravityGradient(Effect):
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
        self.first_axis = np.cross(helper, normal)
        self.first_axis /= np.linalg.norm(self.first_axis)
        self.second_axis = np.cross(normal, self.first_axis)
        radius = self.params['orbit_radius']
        self.mean_motion = math.sqrt(self.params['mu'] / radius ** 3)
        self.gain = 3.0 * self.params['mu'] / radius ** 3

    def radial_world(self, t: float) -> NDArray[np.float64]:
        """Unit vector from the planet to the body at ``t``, world frame."""
        anomaly = self.params['initial_anomaly'] + self.mean_motion * t
        return math.cos(anomaly) * self.first_axis + math.sin(anomaly) * self.second_axis

    def torque_body(self, t: float, attitude: NDArray[Any],
                    omega_body: NDArray[Any]) -> NDArray[Any]:
        """``3μ/r³ r̂_b × J r̂_b`` [N m]."""
        radial_body = quaternion.rotate_inverse(attitude, self.radial_world(t))
        return self.gain * np.cross(radial_body, self.body.inertia.tensor @ radial_body)
