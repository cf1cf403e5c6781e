"""The scene file's ``orbit:`` and ``magnetic_field:`` sections, checked once at load.

Format::

    orbit:                          # a circular orbit (core/environment/orbit.py)
      altitude: 500000.0            # [m] above the equatorial radius; or radius: [m]
      inclination_deg: 97.4
      raan_deg: 30.0                # right ascension of the ascending node
      argument_of_latitude_deg: 0.0 # at t = 0
      epoch: 2025-01-01T00:00:00Z   # UTC; the Earth's rotation angle at t = 0
      mu: 3.986004418e+14           # [m³/s²], default the Earth's
    magnetic_field:
      model: tilted_dipole          # or igrf (needs orbit), or local (a place on the ground)
      coefficients_nT: [-29350.0, -1410.3, 4545.5]   # tilted_dipole: g10, g11, h11
      # local: intensity [T], inclination_deg, declination_deg, world_axes (enu, ned, nwu)

Every fault is one :class:`SceneError` naming the key (``orbit.inclination_deg``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from datetime import date, datetime, timezone
from typing import Any

from rigid_body_attitude.core.environment.igrf import IgrfField
from rigid_body_attitude.core.environment.magnetic_field import (
    LocalMagneticField, MagneticFieldModel)
from rigid_body_attitude.core.environment.orbit import (
    CircularOrbit, EARTH_EQUATORIAL_RADIUS, EARTH_MU)
from rigid_body_attitude.core.environment.tilted_dipole import (
    IGRF14_2025_DIPOLE, TiltedDipoleField)
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.yaml_files import Fields, quote

__all__ = ['FIELD_MODELS', 'magnetic_field_section', 'orbit_section']

_FIELDS = Fields(SceneError)
_ORBIT_KEYS = {'altitude', 'radius', 'inclination_deg', 'raan_deg',
               'argument_of_latitude_deg', 'epoch', 'mu'}
FIELD_MODELS = ('tilted_dipole', 'igrf', 'local')
_FIELD_KEYS = {'tilted_dipole': {'model', 'coefficients_nT'}, 'igrf': {'model'},
               'local': {'model', 'intensity', 'inclination_deg', 'declination_deg',
                         'world_axes'}}
#: Largest orbit radius [m] (beyond the Moon's orbit a geocentric field model means nothing).
MAX_RADIUS = 1.0e9


def orbit_section(data: Any) -> CircularOrbit | None:
    """The ``orbit:`` section as a :class:`CircularOrbit` (None when absent)."""
    if data is None:
        return None
    data = _FIELDS.mapping(data, 'orbit', _ORBIT_KEYS)
    if ('altitude' in data) == ('radius' in data):
        raise SceneError('Expected orbit to give one of altitude or radius [m]')
    if 'radius' in data:
        radius = _FIELDS.number(data['radius'], 'orbit.radius', EARTH_EQUATORIAL_RADIUS,
                                MAX_RADIUS)
    else:
        radius = EARTH_EQUATORIAL_RADIUS + _FIELDS.number(
            data['altitude'], 'orbit.altitude', 0.0, MAX_RADIUS - EARTH_EQUATORIAL_RADIUS)
    angles = {key: math.radians(_FIELDS.number(data.get(key, 0.0), f'orbit.{key}', -360.0,
                                               360.0))
              for key in ('inclination_deg', 'raan_deg', 'argument_of_latitude_deg')}
    if not 0.0 <= angles['inclination_deg'] <= math.pi:
        raise SceneError(f'Expected orbit.inclination_deg to be in [0, 180], got '
                         f'{quote(data.get("inclination_deg"))}')
    return CircularOrbit(
        radius=radius, inclination=angles['inclination_deg'], raan=angles['raan_deg'],
        argument_of_latitude=angles['argument_of_latitude_deg'],
        epoch=_epoch(data.get('epoch', '2025-01-01T00:00:00Z')),
        mu=_FIELDS.number(data.get('mu', EARTH_MU), 'orbit.mu', 0.0, low_open=True))


def _epoch(value: Any) -> datetime:
    """An ISO 8601 UTC date-time (YAML may have read it as one already)."""
    parsed: datetime | None = None
    if isinstance(value, datetime):
        parsed = value
    elif isinstance(value, date):
        parsed = datetime(value.year, value.month, value.day)
    elif isinstance(value, str) and len(value) <= 64:
        try:
            parsed = datetime.fromisoformat(value.replace('Z', '+00:00'))
        except ValueError:
            parsed = None
    if parsed is None or not 1900 <= parsed.year <= 2100:
        raise SceneError(f'Expected orbit.epoch to be a UTC date-time from 1900 to 2100 '
                         f'(2025-01-01T00:00:00Z), got {quote(value)}')
    if parsed.tzinfo is None:
        return parsed.replace(tzinfo=timezone.utc)
    return parsed.astimezone(timezone.utc)


def magnetic_field_section(data: Any, orbit: CircularOrbit | None) -> MagneticFieldModel | None:
    """The ``magnetic_field:`` section as a field model (None when absent)."""
    if data is None:
        return None
    data = _FIELDS.mapping(data, 'magnetic_field', None, ('model',))
    model = data.get('model')
    if model not in FIELD_MODELS:
        raise SceneError(f'Expected magnetic_field.model to be one of '
                         f'{", ".join(FIELD_MODELS)}, got {quote(model)}')
    _FIELDS.keys(data, _FIELD_KEYS[model], 'magnetic_field')
    if model == 'local':
        return _local(data)
    if orbit is None:
        raise SceneError(f'magnetic_field.model {model} is the field along an orbit: the '
                         f'scene needs an orbit: section')
    if model == 'igrf':
        try:
            return IgrfField(orbit)
        except InputError as err:
            raise SceneError(f'magnetic_field: {err}') from None
    coefficients = _FIELDS.vector(data.get('coefficients_nT', list(IGRF14_2025_DIPOLE)),
                                  'magnetic_field.coefficients_nT', 3, 1.0e6)
    if not any(coefficients):
        raise SceneError('Expected magnetic_field.coefficients_nT to be non-zero')
    return TiltedDipoleField(orbit, (coefficients[0], coefficients[1], coefficients[2]))


def _local(data: Mapping[Any, Any]) -> LocalMagneticField:
    intensity = _FIELDS.number(data.get('intensity', 5.0e-5), 'magnetic_field.intensity', 0.0,
                               1.0e-2)
    inclination = _FIELDS.number(data.get('inclination_deg', 0.0),
                                 'magnetic_field.inclination_deg', -90.0, 90.0)
    declination = _FIELDS.number(data.get('declination_deg', 0.0),
                                 'magnetic_field.declination_deg', -180.0, 180.0)
    axes = data.get('world_axes', 'enu')
    if axes not in ('enu', 'ned', 'nwu'):
        raise SceneError(f'Expected magnetic_field.world_axes to be enu, ned or nwu, got '
                         f'{quote(axes)}')
    return LocalMagneticField(intensity, math.radians(inclination), math.radians(declination),
                              str(axes))
