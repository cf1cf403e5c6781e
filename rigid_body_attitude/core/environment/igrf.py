"""The International Geomagnetic Reference Field along the scene's orbit, through ``ppigrf``.

The field is IGRF-14 (P. Alken et al., "International Geomagnetic Reference Field: the
fourteenth generation", IAGA Working Group V-MOD, 2024, the coefficients of the package's
``IGRF14.shc``; the model's form: Alken et al., Earth, Planets and Space 73:49, 2021, eq. 1),
evaluated by ``ppigrf`` (pure Python IGRF of IAGA's V-MOD group, pinned in requirements.txt)
in geocentric coordinates with the coefficients at the orbit's epoch (the secular variation
over a run, about 0.04 nT a day, is ignored). A call of ``ppigrf`` costs tens of milliseconds,
so the field along the orbit is sampled every :data:`SAMPLE_PERIOD` seconds, a block of
:data:`BLOCK_SAMPLES` samples at a time as the run reaches it, and interpolated with the cubic
through the four nearest samples (``test/core/environment/test_igrf.py`` measures the
interpolation error against the direct evaluation over an orbit). The result is in the world
(Earth-centred inertial) axes of :mod:`.orbit`. The epoch must lie within the model's years
(1900 to 2030).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timezone

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.environment.orbit import CircularOrbit
from rigid_body_attitude.core.errors import InputError

__all__ = ['BLOCK_SAMPLES', 'IgrfField', 'SAMPLE_PERIOD', 'igrf_earth_fixed']

Vec = tuple[float, float, float]
FloatArray = NDArray[np.float64]

#: Spacing [s] of the field samples along the orbit and samples computed per block.
SAMPLE_PERIOD = 10.0
BLOCK_SAMPLES = 256
#: Years the model covers.
FIRST_YEAR, LAST_YEAR = 1900, 2030


def igrf_earth_fixed(positions: FloatArray, epoch: datetime) -> FloatArray:
    """IGRF-14 [T] at ``positions`` (n, 3) [m] (Earth-fixed axes), coefficients at ``epoch``;
    the field in the same axes, (n, 3)."""
    import ppigrf  # type: ignore[import-untyped]
    x, y, z = positions.T
    radius = np.sqrt(x * x + y * y + z * z)
    colatitude = np.degrees(np.arccos(np.clip(z / radius, -1.0, 1.0)))
    longitude = np.degrees(np.arctan2(y, x))
    naive = epoch.astimezone(timezone.utc).replace(tzinfo=None)
    b_r, b_theta, b_phi = (np.ravel(part) * 1e-9 for part in ppigrf.igrf_gc(
        radius / 1000.0, colatitude, longitude, naive))
    theta, phi = np.radians(colatitude), np.radians(longitude)
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    # r̂ = (st cp, st sp, ct), θ̂ = (ct cp, ct sp, −st), φ̂ = (−sp, cp, 0)
    result: FloatArray = np.stack([b_r * st * cp + b_theta * ct * cp - b_phi * sp,
                                   b_r * st * sp + b_theta * ct * sp + b_phi * cp,
                                   b_r * ct - b_theta * st], axis=1)
    return result


@dataclass(frozen=True)
class IgrfField:
    """IGRF-14 [T] along ``orbit`` in world axes, sampled and interpolated (module docstring).
    The samples are a cache, not a field: two fields of the same orbit are equal.
    """

    orbit: CircularOrbit

    def __post_init__(self) -> None:
        """Check the epoch; compute the first block of samples."""
        year = self.orbit.epoch.year
        if not FIRST_YEAR <= year < LAST_YEAR:
            raise InputError(f'Expected the orbit epoch within {FIRST_YEAR} to {LAST_YEAR} for '
                             f'IGRF-14, got {self.orbit.epoch.isoformat()}')
        object.__setattr__(self, 'samples', [])
        self._extend(BLOCK_SAMPLES)

    def _extend(self, count: int) -> None:
        """``count`` more samples (world axes)."""
        samples: list[Vec] = getattr(self, 'samples')
        start = len(samples)
        times = [(start + k) * SAMPLE_PERIOD for k in range(count)]
        positions = np.array([self.orbit.position_earth_fixed(t) for t in times])
        fields = igrf_earth_fixed(positions, self.orbit.epoch)
        for t, value in zip(times, fields.tolist()):
            x, y, z = self.orbit.to_world(t, (value[0], value[1], value[2]))
            samples.append((x, y, z))

    def field_direct(self, t: float) -> Vec:
        """The field [T] at ``t`` evaluated by ``ppigrf`` itself (no interpolation)."""
        position = np.array([self.orbit.position_earth_fixed(t)])
        x, y, z = igrf_earth_fixed(position, self.orbit.epoch)[0].tolist()
        return self.orbit.to_world(t, (x, y, z))

    def field_world(self, t: float) -> Vec:
        """The field [T] at ``t`` (``t ≥ 0``), world axes: the cubic through the four nearest
        samples."""
        position = max(t, 0.0) / SAMPLE_PERIOD
        index = max(int(math.floor(position)) - 1, 0)
        samples: list[Vec] = getattr(self, 'samples')
        while index + 4 > len(samples):
            self._extend(BLOCK_SAMPLES)
        s = position - index  # in [1, 2) except at the start
        w0 = -(s - 1.0) * (s - 2.0) * (s - 3.0) / 6.0
        w1 = s * (s - 2.0) * (s - 3.0) / 2.0
        w2 = -s * (s - 1.0) * (s - 3.0) / 2.0
        w3 = s * (s - 1.0) * (s - 2.0) / 6.0
        a, b, c, d = samples[index:index + 4]
        return (w0 * a[0] + w1 * b[0] + w2 * c[0] + w3 * d[0],
                w0 * a[1] + w1 * b[1] + w2 * c[1] + w3 * d[1],
                w0 * a[2] + w1 * b[2] + w2 * c[2] + w3 * d[2])
