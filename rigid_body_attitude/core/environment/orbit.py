"""A spacecraft scene's orbit: circular, in an Earth-centred inertial world frame.

For a spacecraft scene the world frame is Earth-centred and inertial: ``z`` along the Earth's
rotation axis, ``x`` toward the vernal equinox (of the epoch; precession and nutation, 0.7 deg
over 50 years, are ignored). The orbit is circular with radius ``r`` (or the altitude above
the equatorial radius ``R = 6 378 137 m``), inclination ``i``, right ascension of the ascending
node ``Ω`` and argument of latitude ``u₀`` at ``t = 0``:

    r(t) = r · R₃(−Ω) R₁(−i) (cos u, sin u, 0),   u = u₀ + n t,   n = √(μ / r³)

(Source: D. A. Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., 2013,
sec. 2.6, the perifocal-to-inertial rotation with the argument of latitude for a circular
orbit). The Earth-fixed frame turns about ``z`` by the Greenwich mean sidereal time
``θ(t) = θ(epoch) + ω_E t``: ``θ(epoch)`` by the IAU 1982 formula of Vallado eq. 3-47 with
``UT1 = UTC`` (within 0.9 s: 0.004 deg), ``ω_E = 7.2921158553e-5 rad/s`` its rate.
Assumptions: a point-mass Earth (no J2 precession of the node), the orbit unaffected by the
attitude.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timezone

__all__ = ['CircularOrbit', 'EARTH_EQUATORIAL_RADIUS', 'EARTH_MU', 'EARTH_ROTATION_RATE',
           'greenwich_sidereal_angle']

Vec = tuple[float, float, float]

#: WGS 84 equatorial radius [m] and Earth's gravitational parameter [m³/s²].
EARTH_EQUATORIAL_RADIUS = 6378137.0
EARTH_MU = 3.986004418e14
#: Rate of the Greenwich mean sidereal time [rad/s] (1.00273790935 turns per solar day).
EARTH_ROTATION_RATE = 7.2921158553e-5
_J2000 = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)


def greenwich_sidereal_angle(epoch: datetime) -> float:
    """Greenwich mean sidereal time [rad] at ``epoch`` (UTC taken as UT1), IAU 1982
    (Vallado 2013, eq. 3-47), in ``[0, 2π)``."""
    days = (epoch - _J2000).total_seconds() / 86400.0
    centuries = days / 36525.0
    seconds = (67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * centuries
               + 0.093104 * centuries ** 2 - 6.2e-6 * centuries ** 3)
    return math.radians((seconds % 86400.0) / 240.0)


@dataclass(frozen=True)
class CircularOrbit:
    """A circular orbit (see the module docstring).

    Args:
        radius: orbit radius [m].
        inclination: ``i`` [rad].
        raan: right ascension of the ascending node ``Ω`` [rad].
        argument_of_latitude: ``u₀`` at ``t = 0`` [rad].
        epoch: the UTC date and time of ``t = 0`` (timezone-aware).
        mu: gravitational parameter [m³/s²].
    """

    radius: float
    inclination: float = 0.0
    raan: float = 0.0
    argument_of_latitude: float = 0.0
    epoch: datetime = datetime(2025, 1, 1, tzinfo=timezone.utc)
    mu: float = EARTH_MU
    axes: tuple[Vec, Vec, Vec] = field(init=False, repr=False, compare=False)
    epoch_angle: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """The orbit plane's axes: node line, in-plane normal to it, orbit normal."""
        ci, si = math.cos(self.inclination), math.sin(self.inclination)
        co, so = math.cos(self.raan), math.sin(self.raan)
        node: Vec = (co, so, 0.0)
        along: Vec = (-so * ci, co * ci, si)
        normal: Vec = (so * si, -co * si, ci)
        object.__setattr__(self, 'axes', (node, along, normal))
        object.__setattr__(self, 'epoch_angle', greenwich_sidereal_angle(self.epoch))

    @property
    def mean_motion(self) -> float:
        """``n = √(μ / r³)`` [rad/s]."""
        return math.sqrt(self.mu / self.radius ** 3)

    @property
    def period(self) -> float:
        """``2π / n`` [s]."""
        return 2.0 * math.pi / self.mean_motion

    @property
    def normal(self) -> Vec:
        """Unit orbit normal (world)."""
        return self.axes[2]

    @property
    def node(self) -> Vec:
        """Unit vector to the ascending node (world)."""
        return self.axes[0]

    def radial(self, t: float) -> Vec:
        """Unit vector from the Earth's centre to the body at ``t`` [s] (world)."""
        u = self.argument_of_latitude + self.mean_motion * t
        c, s = math.cos(u), math.sin(u)
        (a0, a1, a2), (b0, b1, b2), _ = self.axes
        return c * a0 + s * b0, c * a1 + s * b1, c * a2 + s * b2

    def position(self, t: float) -> Vec:
        """Position [m] at ``t`` (world)."""
        x, y, z = self.radial(t)
        r = self.radius
        return r * x, r * y, r * z

    def sidereal_angle(self, t: float) -> float:
        """Greenwich mean sidereal time [rad] at scene time ``t``."""
        return self.epoch_angle + EARTH_ROTATION_RATE * t

    def position_earth_fixed(self, t: float) -> Vec:
        """Position [m] at ``t`` in the Earth-fixed frame (``x`` at Greenwich)."""
        x, y, z = self.position(t)
        angle = self.sidereal_angle(t)
        c, s = math.cos(angle), math.sin(angle)
        return c * x + s * y, -s * x + c * y, z

    def to_world(self, t: float, vector_earth_fixed: Vec) -> Vec:
        """An Earth-fixed vector at ``t`` in world (inertial) axes."""
        angle = self.sidereal_angle(t)
        c, s = math.cos(angle), math.sin(angle)
        x, y, z = vector_earth_fixed
        return c * x - s * y, s * x + c * y, z
