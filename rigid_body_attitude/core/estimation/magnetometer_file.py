"""The magnetometer calibration file: hard and soft iron and the figures of one magnetometer.

Format (YAML, SI units, the magnetometer's own sensor frame)::

    hard_iron: [1.0e-6, -2.0e-6, 0.5e-6]          # h [T]
    soft_iron: [[1.02, 0.01, 0.0],                 # S (3x3, rows)
                [0.01, 0.98, 0.0],
                [0.0, 0.0, 1.0]]
    noise_density: 8.0e-8                          # [T/√Hz] white noise
    delay: 0.012                                   # [s] behind its stamp
    timing: 0.0014                                 # [s] 1σ of its sample instants

``noise_density``, ``delay`` and ``timing`` are the filter's ``magnetometer_noise_density``,
``magnetometer_delay`` and ``magnetometer_timing``
(:class:`~rigid_body_attitude.core.estimation.estimator_settings.EstimatorSettings`), measured
once for a magnetometer as ``imu_noise`` measures a gyro (the delay with
:func:`~rigid_body_attitude.core.estimation.magnetometer_timing.magnetometer_delay`); the file
overrides the node's parameter of the same figure. Each key may be left out.

The convention is that of the simulated magnetometer
(:mod:`rigid_body_attitude.core.sensors.magnetometer`): the measured field is ``m = S b + h``
for the true field ``b`` in the sensor frame, so the calibration gives ``b = S⁻¹ (m − h)``,
the ellipsoid fit's centre ``h`` and shape ``S`` (R. Alonso, M. D. Shuster, "Complete linear
attitude-independent magnetometer calibration", J. Astronautical Sciences 50(4), 2002).
Hard and soft iron left out: zero and the identity. ``h`` is at most
:data:`~rigid_body_attitude.core.estimation.magnetometer.MAX_HARD_IRON` per axis; ``S`` has a
positive determinant (a mirror is a wiring fault, not iron) and a condition number below
1000. A fault is one :class:`~rigid_body_attitude.core.errors.CalibrationError` whose text
starts ``Magnetometer calibration file '<path>'``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigid_body_attitude.core.errors import CalibrationError, InputError
from rigid_body_attitude.core.estimation.magnetometer import (
    MAX_HARD_IRON, MagnetometerCalibration)
from rigid_body_attitude.core.yaml_files import Fields, bounded, read_yaml

__all__ = ['MagnetometerFile', 'load_magnetometer_calibration',
           'magnetometer_calibration_from_mapping']

_FIELDS = Fields(CalibrationError)
#: The figures a file may give: key → (the settings field, bounds [SI]).
FIGURES = {'noise_density': ('magnetometer_noise_density', 0.0, 1.0e-3),
           'delay': ('magnetometer_delay', 0.0, 0.1),
           'timing': ('magnetometer_timing', 0.0, 0.1)}
_KEYS = ('hard_iron', 'soft_iron', *FIGURES)


@dataclass(frozen=True)
class MagnetometerFile:
    """A file's correction and the settings its figures give (settings field → value)."""

    calibration: MagnetometerCalibration
    settings: Mapping[str, float]


def load_magnetometer_calibration(path: str | Path) -> MagnetometerFile:
    """Read and check a file (module docstring): the correction ``b = S⁻¹ (m − h)`` and the
    figures."""
    path = Path(path).expanduser()
    where = f'Magnetometer calibration file {str(path)!r}'
    if not path.is_file():
        raise CalibrationError(f'{where} does not exist')
    data = read_yaml(path, where, CalibrationError, 'calibration files')
    try:
        return magnetometer_calibration_from_mapping(data)
    except CalibrationError as err:
        raise CalibrationError(bounded(f'{where}: {err}')) from None


def magnetometer_calibration_from_mapping(data: Any) -> MagnetometerFile:
    """Check a parsed file (a mapping with keys of the module docstring)."""
    data = _FIELDS.mapping(data, 'a magnetometer calibration', _KEYS)
    if not data:
        raise CalibrationError(f'Expected some of {", ".join(_KEYS)}, got an empty mapping')
    settings = {field: _FIELDS.number(data[key], key, low, high)
                for key, (field, low, high) in FIGURES.items() if key in data}
    hard = _FIELDS.vector(data.get('hard_iron', [0.0, 0.0, 0.0]), 'hard_iron', 3, MAX_HARD_IRON)
    soft = np.array(_FIELDS.matrix(data.get('soft_iron', np.eye(3).tolist()), 'soft_iron',
                                   bound=1e3))
    if not np.linalg.det(soft) > 0.0 or not np.linalg.cond(soft) < 1e3:
        raise CalibrationError(f'Expected soft_iron to keep the handedness (determinant > 0) '
                               f'with a condition number below 1000, got {soft.tolist()!r}')
    correction = np.linalg.inv(soft).reshape(9).tolist()
    try:
        calibration = MagnetometerCalibration((hard[0], hard[1], hard[2]), tuple(correction))
    except InputError as err:
        raise CalibrationError(str(err)) from None
    return MagnetometerFile(calibration, settings)
