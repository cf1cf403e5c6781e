"""The magnetic field in the world frame: what a magnetometer measures and a magnetorquer acts in.

A field model answers one question, :meth:`MagneticFieldModel.field_world`: the field vector
[T] in world axes at time ``t`` [s] of the scene. :class:`LocalMagneticField` is the field of a
robot on the ground, constant over its run, given as a geomagnetic model or a map states it
(NOAA/BGS World Magnetic Model, J. Chulliat et al., "The US/UK World Magnetic Model for
2020-2025", NOAA Technical Report, 2020, section 1.2):

* ``intensity`` F [T], the total field;
* ``inclination`` I [rad], the dip below the horizontal (positive when the field points down,
  as in the northern hemisphere);
* ``declination`` D [rad], the angle of the horizontal component east of true north.

With ``H = F cos I`` the horizontal and ``Z = F sin I`` the downward component, the field is
``north = H cos D``, ``east = H sin D``, ``down = Z`` (the model's X, Y, Z), mapped into the
world axes of :data:`WORLD_AXES` (REP-103: ENU by default; NED and NWU on request).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from rigid_body_attitude.core.errors import InputError

__all__ = ['LocalMagneticField', 'MagneticFieldModel', 'WORLD_AXES', 'WorldAxes',
           'field_world_vector']

Vec = tuple[float, float, float]


@dataclass(frozen=True)
class WorldAxes:
    """The unit vectors of north, east and up in a world frame's components."""

    north: Vec
    east: Vec
    up: Vec


#: The world frames of REP-103 (``enu``) and REP-105's alternatives (``ned``, ``nwu``).
WORLD_AXES: dict[str, WorldAxes] = {
    'enu': WorldAxes(north=(0.0, 1.0, 0.0), east=(1.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)),
    'ned': WorldAxes(north=(1.0, 0.0, 0.0), east=(0.0, 1.0, 0.0), up=(0.0, 0.0, -1.0)),
    'nwu': WorldAxes(north=(1.0, 0.0, 0.0), east=(0.0, -1.0, 0.0), up=(0.0, 0.0, 1.0)),
}


class MagneticFieldModel(Protocol):
    """A magnetic field along the scene's time axis."""

    def field_world(self, t: float) -> Vec:
        """The field [T] in world axes at scene time ``t`` [s]."""


def field_world_vector(intensity: float, inclination: float, declination: float,
                       world_axes: str = 'enu') -> Vec:
    """The field [T] in ``world_axes`` of total ``intensity`` [T], dip ``inclination`` [rad]
    (positive down) and ``declination`` [rad] (east of true north); InputError naming the bad
    value."""
    axes = WORLD_AXES.get(world_axes)
    if axes is None:
        raise InputError(f'Expected world_axes to be one of {", ".join(sorted(WORLD_AXES))}, '
                         f'got {world_axes!r}')
    if not (math.isfinite(intensity) and intensity >= 0.0):
        raise InputError(f'Expected `intensity` to be a finite field >= 0 T, got {intensity!r}')
    if not (math.isfinite(inclination) and abs(inclination) <= 0.5 * math.pi):
        raise InputError(f'Expected `inclination` to be in [-pi/2, pi/2] rad, got '
                         f'{inclination!r}')
    if not (math.isfinite(declination) and abs(declination) <= math.pi):
        raise InputError(f'Expected `declination` to be in [-pi, pi] rad, got {declination!r}')
    horizontal = intensity * math.cos(inclination)
    north = horizontal * math.cos(declination)
    east = horizontal * math.sin(declination)
    down = intensity * math.sin(inclination)
    n, e, u = axes.north, axes.east, axes.up
    return (north * n[0] + east * e[0] - down * u[0],
            north * n[1] + east * e[1] - down * u[1],
            north * n[2] + east * e[2] - down * u[2])


@dataclass(frozen=True)
class LocalMagneticField:
    """A constant field at a place on the ground (see the module docstring).

    Args:
        intensity: total field F [T] (Berlin, 2021: about 5.0e-5).
        inclination: dip I [rad], positive down.
        declination: D [rad], east of true north.
        world_axes: ``'enu'``, ``'ned'`` or ``'nwu'``.
    """

    intensity: float
    inclination: float
    declination: float = 0.0
    world_axes: str = 'enu'

    def __post_init__(self) -> None:
        """Check the values (InputError naming the bad one)."""
        field_world_vector(self.intensity, self.inclination, self.declination, self.world_axes)

    def field_world(self, t: float) -> Vec:
        """The field [T] in world axes (the same at every ``t``)."""
        return field_world_vector(self.intensity, self.inclination, self.declination,
                                  self.world_axes)
