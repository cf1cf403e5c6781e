"""A gyro scene's ``estimation:`` section: which measurement updates the node runs.

A gyro scene without the section is pure propagation (``strapdown``). With it the node runs
the attitude filter (:mod:`.estimator`) on the propagated error state, each update opt-in::

    estimation:
      gravity: true          # tilt from the Imu's accelerometer (default true)
      magnetometer: true     # heading from imu/mag, sensor_msgs/MagneticField (default false)
      attitude: false        # attitude_measurement, PoseWithCovarianceStamped (default false)
      start: levelling       # or attitude_measurement: start at the first one (needs attitude)
      settings:              # optional: fields of EstimatorSettings (SI units, angles in rad)
        magnetic_disturbance_stddev: 0.035

``settings`` takes the names of
:class:`~rigid_body_attitude.core.estimation.estimator_settings.EstimatorSettings` (its
docstring gives each one's meaning and default), except those the node's parameters set
(``declination``: parameter ``magnetic_declination``; ``magnetometer_noise_density``: the
parameter of that name; ``accelerometer_random_walk``: likewise). Every value is checked as
the settings check it; a fault is one :class:`~rigid_body_attitude.core.errors.SceneError`
naming the key.

``start`` says where the filter's start comes from: ``levelling`` (the default: the gyro
session's levelling, or the scene's attitude without it) or ``attitude_measurement``: the
first accepted ``attitude_measurement``, its attitude and covariance at its stamp, which is
also the gyro stream's first instant (a spacecraft's filter starts from its star tracker; no
gyro sample is integrated before it).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.estimation.estimator_settings import EstimatorSettings
from rigid_body_attitude.core.yaml_files import Fields, quote

__all__ = ['EstimationSpec', 'PARAMETER_SETTINGS', 'STARTS', 'estimation_section']

_FIELDS = Fields(SceneError)
_SWITCHES = ('gravity', 'magnetometer', 'attitude')
_KEYS = {*_SWITCHES, 'settings', 'start'}
#: Where the filter's start comes from (module docstring).
STARTS = ('levelling', 'attitude_measurement')
#: Settings the node's parameters give (parameter name → settings field).
PARAMETER_SETTINGS = {'magnetic_declination': 'declination',
                      'magnetometer_noise_density': 'magnetometer_noise_density',
                      'accelerometer_random_walk': 'accelerometer_random_walk'}


@dataclass(frozen=True)
class EstimationSpec:
    """The section (module docstring): the updates switched on and the settings given.

    Attributes:
        gravity: tilt from the accelerometer (and the zero-rate update at rest).
        magnetometer: heading from ``imu/mag``.
        attitude: external attitude measurements.
        settings: ``EstimatorSettings`` field → value, as the section gives them.
        start: ``levelling`` or ``attitude_measurement`` (:data:`STARTS`).
    """

    gravity: bool = True
    magnetometer: bool = False
    attitude: bool = False
    settings: Mapping[str, Any] = field(default_factory=dict)
    start: str = 'levelling'

    def estimator_settings(self, **given: Any) -> EstimatorSettings:
        """The filter's settings: the section's, then ``given`` (the parameters')."""
        return EstimatorSettings(**{**self.settings, **given})


def estimation_section(data: Any) -> EstimationSpec | None:
    """The scene's ``estimation`` section (``None``: none); SceneError naming the key."""
    if data is None:
        return None
    data = _FIELDS.mapping(data, 'estimation', _KEYS, none_is_empty=True)
    switches = {}
    for key in _SWITCHES:
        value = data.get(key, key == 'gravity')
        if not isinstance(value, bool):
            raise SceneError(f'Expected estimation.{key} to be true or false, got '
                             f'{quote(value)}')
        switches[key] = value
    settings = _settings(data.get('settings'))
    start = data.get('start', 'levelling')
    if start not in STARTS:
        raise SceneError(f'Expected estimation.start to be one of {", ".join(STARTS)}, got '
                         f'{quote(start)}')
    if start == 'attitude_measurement' and not switches['attitude']:
        raise SceneError('Expected estimation.attitude true with estimation.start '
                         'attitude_measurement (the start is the first attitude_measurement)')
    return EstimationSpec(switches['gravity'], switches['magnetometer'], switches['attitude'],
                          settings, start)


def _settings(data: Any) -> dict[str, Any]:
    """The ``settings`` mapping, each value checked by ``EstimatorSettings``."""
    given = {name for name in PARAMETER_SETTINGS.values()}
    valid = {item.name for item in fields(EstimatorSettings)} - given
    data = _FIELDS.mapping(data, 'estimation.settings', valid, none_is_empty=True)
    settings: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        try:
            EstimatorSettings(**{key: value})
        except (InputError, TypeError) as err:
            raise SceneError(f'estimation.settings.{key}: {err}') from None
        settings[key] = value
    return settings
