"""The Earth's field as a tilted dipole along the scene's orbit (world = Earth-centred inertial).

The degree-1 terms of the geomagnetic potential, ``V = R³ (d·r) / r³`` with
``d = (g₁¹, h₁¹, g₁⁰)`` in Earth-fixed axes, give

    B(r) = −∇V = (R / |r|)³ [3 (d·r̂) r̂ − d]

(``R = 6 371 200 m``, the IGRF reference radius; the potential of P. Alken et al.,
"International Geomagnetic Reference Field: the thirteenth generation", Earth, Planets and
Space 73:49, 2021, eq. 1, cut at degree 1; Markley and Crassidis, *Fundamentals of Spacecraft
Attitude Determination and Control*, 2014, sec. 11.2, the dipole model). The default
coefficients are IGRF-14's for 2025.0: ``g₁⁰ = −29 350.0``, ``g₁¹ = −1 410.3``,
``h₁¹ = 4 545.5`` nT (the dipole's axis 9.3 deg from the rotation axis). Evaluated at the
orbit's Earth-fixed position and turned into world axes at every call (a few microseconds).
Limitations: the dipole leaves out about 10 % of the field at low-Earth-orbit altitudes
(degrees 2 to 13, e.g. the South Atlantic anomaly); no secular variation.
"""

from __future__ import annotations

from dataclasses import dataclass

from rigid_body_attitude.core.environment.orbit import CircularOrbit

__all__ = ['IGRF_REFERENCE_RADIUS', 'IGRF14_2025_DIPOLE', 'TiltedDipoleField']

Vec = tuple[float, float, float]

#: The IGRF's reference radius [m].
IGRF_REFERENCE_RADIUS = 6371200.0
#: IGRF-14's degree-1 coefficients for 2025.0, ``(g₁⁰, g₁¹, h₁¹)`` [nT].
IGRF14_2025_DIPOLE = (-29350.0, -1410.3, 4545.5)


@dataclass(frozen=True)
class TiltedDipoleField:
    """The dipole field [T] along ``orbit`` in world axes (module docstring).

    Args:
        orbit: the scene's orbit.
        coefficients: ``(g₁⁰, g₁¹, h₁¹)`` [nT].
    """

    orbit: CircularOrbit
    coefficients: tuple[float, float, float] = IGRF14_2025_DIPOLE

    def field_earth_fixed(self, position: Vec) -> Vec:
        """The field [T] at ``position`` [m] (Earth-fixed axes)."""
        g10, g11, h11 = self.coefficients
        dx, dy, dz = g11 * 1e-9, h11 * 1e-9, g10 * 1e-9
        x, y, z = position
        r2 = x * x + y * y + z * z
        r = r2 ** 0.5
        scale = (IGRF_REFERENCE_RADIUS / r) ** 3
        projection = 3.0 * (dx * x + dy * y + dz * z) / r2
        return (scale * (projection * x - dx), scale * (projection * y - dy),
                scale * (projection * z - dz))

    def field_world(self, t: float) -> Vec:
        """The field [T] at the body's position at ``t``, world axes."""
        orbit = self.orbit
        return orbit.to_world(t, self.field_earth_fixed(orbit.position_earth_fixed(t)))
