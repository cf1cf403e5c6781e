"""The magnetometer calibration file: hard and soft iron of one magnetometer (YAML).

Format (SI units, the magnetometer's own sensor frame)::

    hard_iron: [1.0e-6, -2.0e-6, 0.5e-6]          # h [T]
    soft_iron: [[1.02, 0.01, 0.0],                 # S (3x3, rows)
                [0.01, 0.98, 0.0],
                [0.0, 0.0, 1.0]]

The convention is that of the simulated magnetometer
(:mod:`rigid_body_attitude.core.sensors.magnetometer`): the measured field is ``m = S b + h``
for the true field ``b`` in the sensor frame, so the calibration gives ``b = S⁻¹ (m − h)``,
the ellipsoid fit's centre ``h`` and shape ``S`` (R. Alonso, M. D. Shuster, "Complete linear
attitude-independent magnetometer calibration", J. Astronautical Sciences 50(4), 2002).
Either key may be left out (zero, identity). ``h`` is at most
:data:`~rigid_body_attitude.core.estimation.magnetometer.MAX_HARD_IRON` per axis; ``S`` has a
positive determinant (a mirror is a wiring fault, not iron) and a condition number below
1000. A fault is one :class:`~rigid_body_attitude.core.errors.CalibrationError` whose text
starts ``Magnetometer calibration file '<path>'``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rigid_body_attitude.core.errors import CalibrationError, InputError
from rigid_body_attitude.core.estimation.magnetometer import (
    MAX_HARD_IRON, MagnetometerCalibration)
from rigid_body_attitude.core.yaml_files import Fields, bounded, read_yaml

__all__ = ['load_magnetometer_calibration', 'magnetometer_calibration_from_mapping']

_FIELDS = Fields(CalibrationError)
_KEYS = ('hard_iron', 'soft_iron')


def load_magnetometer_calibration(path: str | Path) -> MagnetometerCalibration:
    """Read and check a file (module docstring): the correction ``b = S⁻¹ (m − h)``."""
    path = Path(path).expanduser()
    where = f'Magnetometer calibration file {str(path)!r}'
    if not path.is_file():
        raise CalibrationError(f'{where} does not exist')
    data = read_yaml(path, where, CalibrationError, 'calibration files')
    try:
        return magnetometer_calibration_from_mapping(data)
    except CalibrationError as err:
        raise CalibrationError(bounded(f'{where}: {err}')) from None


def magnetometer_calibration_from_mapping(data: Any) -> MagnetometerCalibration:
    """Check a parsed file (a mapping with ``hard_iron`` and/or ``soft_iron``)."""
    data = _FIELDS.mapping(data, 'a magnetometer calibration', _KEYS)
    if not data:
        raise CalibrationError('Expected hard_iron and/or soft_iron, got an empty mapping')
    hard = _FIELDS.vector(data.get('hard_iron', [0.0, 0.0, 0.0]), 'hard_iron', 3, MAX_HARD_IRON)
    soft = np.array(_FIELDS.matrix(data.get('soft_iron', np.eye(3).tolist()), 'soft_iron',
                                   bound=1e3))
    if not np.linalg.det(soft) > 0.0 or not np.linalg.cond(soft) < 1e3:
        raise CalibrationError(f'Expected soft_iron to keep the handedness (determinant > 0) '
                               f'with a condition number below 1000, got {soft.tolist()!r}')
    correction = np.linalg.inv(soft).reshape(9).tolist()
    try:
        return MagnetometerCalibration((hard[0], hard[1], hard[2]), tuple(correction))
    except InputError as err:
        raise CalibrationError(str(err)) from None
