"""earth_rate: remove the rotation of an Earth-fixed world frame from gyro rates.

A gyro measures the rate relative to inertial space; a ROS world frame (ENU, REP-103/105) is
fixed to the rotating Earth. The rate relative to the world frame is
``ω = ω_measured − R(q)ᵀ Ω_E (0, cos φ, sin φ)`` with ``φ`` the latitude and
``Ω_E = 7.2921150e−5 rad/s`` (Source: WGS-84; ROS frames: REP-103/105). Assumptions:
stationary or slowly moving platform (transport rate neglected), ENU world frame.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.base import (
    as_vec, REQUIRED, BodyProperties, RateCorrection, Parameter, nonnegative, real, register)

WGS84_EARTH_RATE = 7.2921150e-5


def _latitude(value: Any) -> float:
    number = real(value)
    if not -90.0 <= number <= 90.0:
        raise ValueError('a latitude in degrees within [-90, 90]')
    return number


@register
class EarthRate(RateCorrection):
    """Earth-rotation compensation for strapdown scenes."""

    name = 'earth_rate'
    description = "subtract the Earth's rotation at a latitude (ENU world frame)"
    parameters = {
        'latitude': Parameter(_latitude, REQUIRED, 'geodetic latitude [deg]'),
        'rate': Parameter(nonnegative, WGS84_EARTH_RATE, 'Earth rotation rate [rad/s]'),
    }

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Precompute the Earth rate in the ENU world frame."""
        super().__init__(params, body)
        latitude = math.radians(self.params['latitude'])
        self.earth_rate_world = self.params['rate'] * np.array(
            [0.0, math.cos(latitude), math.sin(latitude)])
        self.earth_rate = as_vec(self.earth_rate_world)

    def corrected_rate(self, t: float, attitude: NDArray[Any],
                       omega_measured: NDArray[Any]) -> NDArray[Any]:
        """``ω_measured − R(q)ᵀ Ω_E`` [rad/s]."""
        w, x, y, z = np.asarray(attitude, dtype=np.float64).tolist()
        corrected: NDArray[Any] = omega_measured - np.array(
            quaternion.rotate_inverse_floats((w, x, y, z), self.earth_rate))
        return corrected
