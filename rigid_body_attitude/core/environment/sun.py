"""The direction of the Sun in the world frame: what a star tracker must not look into.

A Sun model answers one question, :meth:`SunDirectionModel.sun_direction_world`: the unit
vector from the body towards the Sun in world axes at time ``t`` [s] of the scene.
:class:`ConstantSunDirection` is a fixed direction. Seen from an Earth orbit the Sun turns
once a year across an inertial frame, slowly beside the runs of minutes or hours a scene
simulates, so a held direction is the usual first model. Its motion over the year, the
parallax of the orbit and eclipses by a planet are not modelled.

A scene names it in its ``sun`` section (:func:`sun_section`)::

    sun:
      direction: [1.0, 0.0, 0.0]   # world axes, towards the Sun; normalised on load
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.yaml_files import Fields

__all__ = ['ConstantSunDirection', 'SunDirectionModel', 'sun_section']

Vec = tuple[float, float, float]

#: Largest accepted |component| of a given direction (it is normalised).
DIRECTION_LIMIT = 1e6
_FIELDS = Fields(SceneError)


class SunDirectionModel(Protocol):
    """The Sun's direction along the scene's time axis."""

    def sun_direction_world(self, t: float) -> Vec:
        """The unit vector towards the Sun in world axes at scene time ``t`` [s]."""


@dataclass(frozen=True)
class ConstantSunDirection:
    """A fixed direction towards the Sun (see the module docstring).

    Args:
        direction: world axes, any non-zero length (normalised); InputError otherwise.
    """

    direction: Vec

    def __post_init__(self) -> None:
        """Normalise ``direction`` (InputError for a zero or non-finite vector)."""
        x, y, z = (float(c) for c in self.direction)
        norm = math.hypot(x, y, z)
        if not (math.isfinite(norm) and norm > 0.0):
            raise InputError(f'Expected `direction` to be a finite non-zero vector, got '
                             f'{self.direction!r}')
        object.__setattr__(self, 'direction', (x / norm, y / norm, z / norm))

    def sun_direction_world(self, t: float) -> Vec:
        """The unit direction towards the Sun (the same at every ``t``)."""
        return self.direction


def sun_section(data: Any) -> ConstantSunDirection | None:
    """The scene's ``sun`` section (``None``: the scene has no Sun); one SceneError naming the
    key otherwise."""
    if data is None:
        return None
    data = _FIELDS.mapping(data, 'sun', {'direction'}, ('direction',))
    direction = _FIELDS.vector(data['direction'], 'sun.direction', 3, DIRECTION_LIMIT)
    try:
        return ConstantSunDirection((direction[0], direction[1], direction[2]))
    except InputError:
        raise SceneError(f'Expected sun.direction to be a non-zero direction, got '
                         f'{list(direction)!r}') from None
