"""IMU calibration files: kalibr ``imu.yaml`` and imu-camera results, or a plain bias/matrix file.

Every sample is corrected with one affine map (sensor frame = the IMU frame of the file)::

    a_i = N (a_measured - b_a)                     accelerometer [m/s²]
    ω_i = K (ω_measured - b_g - G a_i)             gyroscope [rad/s]

Formats read (the kind is recognised from the keys):

* **kalibr imu-camera result** (``imu0: {gyroscopes: {M, A, C_gyro_i}, accelerometers: {M},
  update_rate, ...}``; the IMU is chosen with ``imu_key`` when the file holds several). kalibr's
  scale-misalignment model (``IccScaledMisalignedImu``) is ``ω_measured = M C ω_i + A C a_i +
  b_g`` and ``a_measured = M_a a_i + b_a``, so ``K = Cᵀ M⁻¹``, ``G = A C`` and
  ``N = M_a⁻¹``; kalibr estimates the biases as time-varying splines and writes none, so
  ``b_g = b_a = 0``. ``M`` is lower triangular in kalibr's convention (OpenVINS writes upper
  triangular matrices of its own: do not mix the two). The size effect (``rx_i`` ...) is
  not modelled.
* **kalibr ``imu.yaml``** (the noise model only: ``gyroscope_noise_density`` [rad/s/√Hz],
  ``gyroscope_random_walk`` [rad/s²/√Hz], ``accelerometer_noise_density`` [m/s²/√Hz],
  ``accelerometer_random_walk`` [m/s³/√Hz], ``update_rate`` [Hz], ``rostopic``): no
  correction, the noise model is kept in :attr:`ImuCalibration.noise`.
* **plain** (imu_tk's ``X' = T K (X − B)``): ``bias`` (3 numbers, rad/s), ``scale`` (3
  numbers or a 3×3 matrix) and ``misalignment`` (3×3), each optional, giving ``K =
  misalignment · scale``, ``b_g = bias``; ``accelerometer_bias`` [m/s²] and
  ``accelerometer_matrix`` (3×3) likewise give ``b_a`` and ``N``.

Any of them may also give the IMU's further figures the attitude filter uses
(:data:`FIGURE_BOUNDS`, kept in :attr:`ImuNoise.figures`, each optional): the 1σ of the errors
the calibration leaves (``accelerometer_bias_stddev`` [m/s²], ``gyroscope_turn_on_bias``
[rad/s], ``gyroscope_scale_stddev``, ``gyroscope_misalignment_stddev``: the fields of
:class:`~rigid_body_attitude.core.estimation.gyro_error_model.GyroErrorModel`), the
accelerometer's full scale ``accelerometer_range`` [m/s²] and the 1σ of the instant a sample
represents, ``sample_timing`` [s] (fields of
:class:`~rigid_body_attitude.core.estimation.estimator_settings.EstimatorSettings`).
:func:`calibration_noise` gives them with the noise figures.

A leading ``%YAML:1.0`` line (written by OpenCV-based tools, refused by YAML parsers) is
skipped. Files are checked as scene files are (:mod:`rigid_body_attitude.core.dynamics.scene`):
size,
UTF-8, no aliases, bounded nesting, and one :class:`CalibrationError` naming the file and the
key (``imu0.gyroscopes.M``), the expected shape or bound and the value.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import CalibrationError
from rigid_body_attitude.core.yaml_files import (
    bounded as _bounded, Fields, quote, read_yaml)

__all__ = ['CONDITION_LIMIT', 'FIGURE_BOUNDS', 'ImuCalibration', 'KIND_NAMES',
           'calibration_summary', 'calibration_terms', 'ImuNoise', 'NOISE_BOUNDS',
           'ORTHONORMAL_TOLERANCE',
           'REQUIRED_NOISE_KEYS', 'calibration_from_mapping', 'calibration_noise',
           'calibration_values', 'load_calibration']

FloatArray = NDArray[np.float64]
Vec = tuple[float, float, float]
Mat = tuple[Vec, Vec, Vec]

NOISE_KEYS = ('gyroscope_noise_density', 'gyroscope_random_walk',
              'accelerometer_noise_density', 'accelerometer_random_walk')
#: The IMU's further figures a file may give (each optional), with their bounds
#: ``(low, high)`` in SI units: the priors (1σ) of the errors a calibration leaves, the
#: accelerometer's full scale (a sensor's is 2-16 g, at least 1 m/s²), the 1σ of the instant a
#: sample represents (:mod:`.gyro_error_model`, :mod:`.estimator_settings`). The gyro's bounds
#: are the node parameters' of the same names.
FIGURE_BOUNDS = {'accelerometer_bias_stddev': (0.0, 10.0),
                 'gyroscope_turn_on_bias': (0.0, 1.0),
                 'gyroscope_scale_stddev': (0.0, 0.5),
                 'gyroscope_misalignment_stddev': (0.0, 0.5),
                 'accelerometer_range': (1.0, 1e4),
                 'sample_timing': (0.0, 0.1)}
_KALIBR_KEYS = {*NOISE_KEYS, *FIGURE_BOUNDS, 'update_rate', 'rostopic', 'model', 'gyroscopes',
                'accelerometers', 'T_i_b', 'time_offset'}
_PLAIN_KEYS = {'bias', 'scale', 'misalignment', 'accelerometer_bias', 'accelerometer_matrix',
               'update_rate', 'rostopic', *NOISE_KEYS, *FIGURE_BOUNDS}
#: Largest accepted condition number of a correction matrix (a scale-misalignment matrix of a
#: working sensor is within a few per cent of a rotation: condition number near 1).
CONDITION_LIMIT = 1e3
#: Largest accepted ``|CᵀC − I|`` entry of ``C_gyro_i`` (kalibr writes 1e-16-accurate rotations).
ORTHONORMAL_TOLERANCE = 1e-6
#: Bounds on the numbers of a file (SI units).
MAX_RATE_BIAS = 100.0  # [rad/s], beyond any gyro's range (2000 °/s = 35 rad/s)
MAX_ACCELERATION_BIAS = 1e3  # [m/s²]
MAX_G_SENSITIVITY = 1.0  # [(rad/s)/(m/s²)]; real sensors: below 1e-3
#: Largest noise figure accepted per key (SI units; 0 is refused: no sensor is noiseless).
#: The gyro bounds are the node parameters' of the same names; a consumer MEMS gyro has a
#: density near 2e-4 rad/s/√Hz, an accelerometer near 2e-3 m/s²/√Hz.
NOISE_BOUNDS = {'gyroscope_noise_density': 1.0, 'gyroscope_random_walk': 1.0,
                'accelerometer_noise_density': 10.0, 'accelerometer_random_walk': 10.0}
#: Sample rates accepted [Hz] (real IMUs run at 100 Hz to 2 kHz).
MIN_UPDATE_RATE = 1.0
MAX_UPDATE_RATE = 1e5
#: Diagonal of a scale or scale-misalignment matrix: a working sensor is within a few per cent
#: of 1; a factor of 2 or more is a unit mistake (deg/s read as rad/s is 57).
SCALE_RANGE = (0.5, 2.0)
#: Largest off-diagonal entry of a scale-misalignment matrix (0.1: about 5.7° between axes;
#: real sensors: below 0.02).
MAX_MISALIGNMENT = 0.1
#: Keys a kalibr ``imu.yaml`` (the noise model alone) must give: those the node uses.
REQUIRED_NOISE_KEYS = ('gyroscope_noise_density', 'gyroscope_random_walk', 'update_rate')
_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
_FIELDS = Fields(CalibrationError)


@dataclass(frozen=True)
class ImuNoise:
    """kalibr's continuous-time noise model (``None`` where the file gives no value).

    Attributes:
        gyroscope_noise_density: [rad/s/√Hz].
        gyroscope_random_walk: [rad/s²/√Hz].
        accelerometer_noise_density: [m/s²/√Hz].
        accelerometer_random_walk: [m/s³/√Hz].
        update_rate: [Hz].
        rostopic: the topic the calibration was recorded on ('' if none).
        figures: the filter's further figures given (:data:`FIGURE_BOUNDS`: name → value,
            SI units).
    """

    gyroscope_noise_density: float | None = None
    gyroscope_random_walk: float | None = None
    accelerometer_noise_density: float | None = None
    accelerometer_random_walk: float | None = None
    update_rate: float | None = None
    rostopic: str = ''
    figures: tuple[tuple[str, float], ...] = ()

    def gyro_sigma(self) -> float | None:
        """Discrete gyro noise per sample [rad/s]: density · √update_rate, if both are given."""
        if self.gyroscope_noise_density is None or self.update_rate is None:
            return None
        return self.gyroscope_noise_density * math.sqrt(self.update_rate)

    def accelerometer_sigma(self) -> float | None:
        """Discrete accelerometer noise per sample [m/s²], if density and rate are given."""
        if self.accelerometer_noise_density is None or self.update_rate is None:
            return None
        return self.accelerometer_noise_density * math.sqrt(self.update_rate)


def _vec(vector: FloatArray) -> Vec:
    x, y, z = vector.tolist()
    return float(x), float(y), float(z)


def _matrix_tuple(matrix: FloatArray) -> Mat:
    rows = matrix.tolist()
    return ((rows[0][0], rows[0][1], rows[0][2]), (rows[1][0], rows[1][1], rows[1][2]),
            (rows[2][0], rows[2][1], rows[2][2]))


@dataclass(frozen=True, eq=False)
class ImuCalibration:
    """The correction of every sample: ``a_i = N (a − b_a)``, ``ω_i = K (ω − b_g − G a_i)``.

    Sensor-frame quantities, rates [rad/s], specific forces [m/s²] (module docstring). The
    per-sample methods take and return plain floats (precomputed ``K``, ``K b_g``, ``K G``:
    18 multiplications per sample with the accelerometer, 9 without).

    Attributes:
        gyro_matrix: ``K`` (3×3).
        gyro_bias: ``b_g`` [rad/s].
        g_sensitivity: ``G`` [(rad/s)/(m/s²)] (3×3).
        accelerometer_matrix: ``N`` (3×3).
        accelerometer_bias: ``b_a`` [m/s²].
        noise: the noise model, if the file has one.
        kind: ``'kalibr'``, ``'kalibr_noise'``, ``'plain'`` or ``'identity'``.
        source: the file it came from, if any.
        imu_key: the section of a kalibr imu-camera result it came from (``imu0``), if any.
    """

    gyro_matrix: FloatArray = field(default_factory=lambda: np.eye(3))
    gyro_bias: FloatArray = field(default_factory=lambda: np.zeros(3))
    g_sensitivity: FloatArray = field(default_factory=lambda: np.zeros((3, 3)))
    accelerometer_matrix: FloatArray = field(default_factory=lambda: np.eye(3))
    accelerometer_bias: FloatArray = field(default_factory=lambda: np.zeros(3))
    noise: ImuNoise = field(default_factory=ImuNoise)
    kind: str = 'identity'
    source: str = ''
    imu_key: str = ''
    _k: Mat = field(init=False, repr=False, compare=False)
    _kb: Vec = field(init=False, repr=False, compare=False)
    _kg: Mat = field(init=False, repr=False, compare=False)
    _n: Mat = field(init=False, repr=False, compare=False)
    _nb: Vec = field(init=False, repr=False, compare=False)
    _uses_acc: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Precompute the float tuples of the per-sample path."""
        k, n = self.gyro_matrix, self.accelerometer_matrix
        set_ = object.__setattr__
        set_(self, '_k', _matrix_tuple(k))
        set_(self, '_kb', _vec(k @ self.gyro_bias))
        set_(self, '_kg', _matrix_tuple(k @ self.g_sensitivity))
        set_(self, '_n', _matrix_tuple(n))
        set_(self, '_nb', _vec(n @ self.accelerometer_bias))
        set_(self, '_uses_acc', bool(np.any(self.g_sensitivity != 0.0)))

    @property
    def uses_accelerometer(self) -> bool:
        """Whether the gyro correction depends on the specific force (``G ≠ 0``)."""
        return self._uses_acc

    def correct_accelerometer(self, ax: float, ay: float, az: float) -> Vec:
        """``N (a − b_a)`` [m/s²], sensor frame."""
        (n00, n01, n02), (n10, n11, n12), (n20, n21, n22) = self._n
        b0, b1, b2 = self._nb
        return (n00 * ax + n01 * ay + n02 * az - b0, n10 * ax + n11 * ay + n12 * az - b1,
                n20 * ax + n21 * ay + n22 * az - b2)

    def correct_gyro(self, wx: float, wy: float, wz: float,
                     ax: float = 0.0, ay: float = 0.0, az: float = 0.0) -> Vec:
        """``K (ω − b_g − G a_i)`` [rad/s] with ``a_i`` the corrected specific force [m/s²]."""
        (k00, k01, k02), (k10, k11, k12), (k20, k21, k22) = self._k
        b0, b1, b2 = self._kb
        x = k00 * wx + k01 * wy + k02 * wz - b0
        y = k10 * wx + k11 * wy + k12 * wz - b1
        z = k20 * wx + k21 * wy + k22 * wz - b2
        if self._uses_acc:
            (g00, g01, g02), (g10, g11, g12), (g20, g21, g22) = self._kg
            x -= g00 * ax + g01 * ay + g02 * az
            y -= g10 * ax + g11 * ay + g12 * az
            z -= g20 * ax + g21 * ay + g22 * az
        return x, y, z

    def correct(self, wx: float, wy: float, wz: float, ax: float, ay: float,
                az: float) -> tuple[Vec, Vec]:
        """Both corrections of one sample: ``(ω_i [rad/s], a_i [m/s²])``."""
        acc = self.correct_accelerometer(ax, ay, az)
        return self.correct_gyro(wx, wy, wz, acc[0], acc[1], acc[2]), acc

    def correct_rows(self, gyro: FloatArray, acc: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The corrections of ``(N, 3)`` arrays of samples (rows), as :meth:`correct`."""
        acc_i = (acc - self.accelerometer_bias) @ self.accelerometer_matrix.T
        rates = (gyro - self.gyro_bias - acc_i @ self.g_sensitivity.T) @ self.gyro_matrix.T
        return rates, acc_i


#: The kinds of file in words (log lines, /diagnostics).
KIND_NAMES = {'kalibr': 'kalibr imu-camera result', 'kalibr_noise': 'kalibr imu.yaml',
              'plain': 'plain bias-scale-misalignment', 'identity': 'none'}
_NOISE_UNITS = {'gyroscope_noise_density': 'rad/s/sqrt(Hz)',
                'gyroscope_random_walk': 'rad/s^2/sqrt(Hz)',
                'accelerometer_noise_density': 'm/s^2/sqrt(Hz)',
                'accelerometer_random_walk': 'm/s^3/sqrt(Hz)', 'update_rate': 'Hz'}


_FIGURE_UNITS = {'accelerometer_bias_stddev': 'm/s^2', 'gyroscope_turn_on_bias': 'rad/s',
                 'gyroscope_scale_stddev': '1', 'gyroscope_misalignment_stddev': '1',
                 'accelerometer_range': 'm/s^2', 'sample_timing': 's'}


def _numbers(values: FloatArray) -> str:
    return '[' + ', '.join(_numbers(row) if row.ndim else f'{float(row):.6g}'
                           for row in values) + ']'


def calibration_terms(calibration: ImuCalibration) -> list[tuple[str, str]]:
    """What a calibration applies, as (name, value) pairs: the corrections that are not the
    identity (``gyro_bias [rad/s]``, ``gyro_matrix K``, ``g_sensitivity G``,
    ``accelerometer_matrix N``, ``accelerometer_bias [m/s^2]``) and the noise figures given
    (kalibr names with units)."""
    c = calibration
    terms = [(name, _numbers(value)) for name, value, neutral in (
        ('gyro_bias [rad/s]', c.gyro_bias, np.zeros(3)),
        ('gyro_matrix K', c.gyro_matrix, np.eye(3)),
        ('g_sensitivity G [(rad/s)/(m/s^2)]', c.g_sensitivity, np.zeros((3, 3))),
        ('accelerometer_matrix N', c.accelerometer_matrix, np.eye(3)),
        ('accelerometer_bias [m/s^2]', c.accelerometer_bias, np.zeros(3)),
    ) if not np.array_equal(value, neutral)]
    for key, unit in _NOISE_UNITS.items():
        value = getattr(c.noise, key)
        if value is not None:
            terms.append((f'{key} [{unit}]', f'{value:.6g}'))
    terms.extend((f'{key} [{_FIGURE_UNITS[key]}]', f'{value:.6g}')
                 for key, value in c.noise.figures)
    return terms


def calibration_summary(calibration: ImuCalibration) -> str:
    """One line: the file, its kind, the IMU key and every term applied (for the log)."""
    c = calibration
    key = f', IMU key {c.imu_key}' if c.imu_key else ''
    terms = '; '.join(f'{name} {value}' for name, value in calibration_terms(c))
    return (f'calibration: file {c.source!r} ({KIND_NAMES[c.kind]}{key}): '
            f'{terms or "no correction, no noise figures"}')


def calibration_values(calibration: ImuCalibration | None) -> list[tuple[str, str]]:
    """A calibration as ``/diagnostics`` key-values: file, kind, IMU key and each term
    applied (``calibration``: ``none`` without a file)."""
    if calibration is None:
        return [('calibration', 'none')]
    return [('calibration', calibration.source),
            ('calibration_kind', KIND_NAMES[calibration.kind]),
            ('calibration_imu_key', calibration.imu_key or '-'),
            *((f'calibration {name}', value) for name, value in calibration_terms(
                calibration))]


def calibration_noise(calibration: ImuCalibration | None) -> dict[str, float]:
    """The noise figures a calibration gives (kalibr names) and its further figures
    (:data:`FIGURE_BOUNDS`); empty without a file or without any."""
    if calibration is None:
        return {}
    noise = calibration.noise
    given = {'gyroscope_noise_density': noise.gyroscope_noise_density,
             'gyroscope_random_walk': noise.gyroscope_random_walk,
             'accelerometer_noise_density': noise.accelerometer_noise_density,
             'accelerometer_random_walk': noise.accelerometer_random_walk}
    return {**{key: value for key, value in given.items() if value is not None},
            **dict(noise.figures)}


def load_calibration(path: str | Path, imu_key: str = '') -> ImuCalibration:
    """Read and check a calibration file (module docstring); ``imu_key`` picks an IMU
    (``imu0``) in a kalibr result holding several. Every fault is one
    :class:`CalibrationError` whose text starts ``Calibration file '<path>'``."""
    path = Path(path).expanduser()
    where = f'Calibration file {str(path)!r}'
    if not path.is_file():
        raise CalibrationError(f'{where} does not exist')
    data = read_yaml(path, where, CalibrationError, 'calibration files', skip_directive=True)
    try:
        return calibration_from_mapping(data, imu_key=imu_key, source=str(path))
    except CalibrationError as err:
        raise CalibrationError(_bounded(f'{where}: {err}')) from None


def calibration_from_mapping(data: Any, imu_key: str = '', source: str = '') -> ImuCalibration:
    """Check a parsed calibration file (a mapping) and build its :class:`ImuCalibration`."""
    if not isinstance(data, Mapping) or not data:
        raise CalibrationError(f'Expected a mapping with kalibr keys ({", ".join(NOISE_KEYS)}, '
                               f'or imu0: {{gyroscopes: ...}}) or plain keys (bias, scale, '
                               f'misalignment), got {quote(data)}')
    imu_keys = sorted(str(key) for key, value in data.items()
                      if str(key).startswith('imu') and isinstance(value, Mapping))
    if imu_key or imu_keys:
        return _kalibr_result(data, _chosen_imu(imu_key, imu_keys), source)
    if any(key in data for key in ('gyroscopes', 'accelerometers', 'model')):
        return _kalibr(data, '', source)
    if any(key in data for key in ('bias', 'scale', 'misalignment', 'accelerometer_bias',
                                   'accelerometer_matrix')):
        return _plain(data, source)
    if any(key in data for key in NOISE_KEYS):
        return _kalibr(data, '', source)
    raise CalibrationError(f'Expected kalibr keys ({", ".join(NOISE_KEYS)}, or imu0: '
                           f'{{gyroscopes: ...}}) or plain keys (bias, scale, misalignment), '
                           f'got keys {quote(sorted(str(key) for key in data))}')


def _chosen_imu(imu_key: str, imu_keys: list[str]) -> str:
    if imu_key:
        if imu_key not in imu_keys:
            raise CalibrationError(f'Missing key {imu_key!r}; the file holds '
                                   f'{", ".join(imu_keys) or "no imuN section"}')
        return imu_key
    if len(imu_keys) > 1:
        raise CalibrationError(f'The file holds several IMUs ({", ".join(imu_keys)}); choose '
                               f'one with imu_key')
    return imu_keys[0]


def _kalibr_result(data: Mapping[Any, Any], key: str, source: str) -> ImuCalibration:
    return replace(_kalibr(data[key], f'{key}.', source), imu_key=key)


def _kalibr(section: Mapping[Any, Any], prefix: str, source: str) -> ImuCalibration:
    _FIELDS.keys(section, _KALIBR_KEYS | {'rx_i', 'ry_i', 'rz_i'}, prefix.rstrip('.'))
    noise_only = not any(key in section for key in ('gyroscopes', 'accelerometers'))
    noise = _noise(section, prefix, REQUIRED_NOISE_KEYS if noise_only else ())
    gyros = _FIELDS.mapping(section.get('gyroscopes', {}), f'{prefix}gyroscopes',
                            {'M', 'A', 'C_gyro_i'})
    accs = _FIELDS.mapping(section.get('accelerometers', {}), f'{prefix}accelerometers', {'M'})
    m_gyro = _invertible(gyros.get('M', _IDENTITY), f'{prefix}gyroscopes.M')
    c_gyro = _rotation(gyros.get('C_gyro_i', _IDENTITY), f'{prefix}gyroscopes.C_gyro_i')
    a_gyro = _matrix(gyros.get('A', np.zeros((3, 3))), f'{prefix}gyroscopes.A',
                     MAX_G_SENSITIVITY)
    m_acc = _invertible(accs.get('M', _IDENTITY), f'{prefix}accelerometers.M')
    has_intrinsics = bool(gyros or accs)
    return ImuCalibration(gyro_matrix=c_gyro.T @ _inverse(m_gyro),
                          g_sensitivity=a_gyro @ c_gyro,
                          accelerometer_matrix=_inverse(m_acc), noise=noise,
                          kind='kalibr' if has_intrinsics else 'kalibr_noise', source=source)


def _plain(data: Mapping[Any, Any], source: str) -> ImuCalibration:
    _FIELDS.keys(data, _PLAIN_KEYS)
    scale_value = data.get('scale', [1.0, 1.0, 1.0])
    if isinstance(scale_value, list) and len(scale_value) == 3 and not any(
            isinstance(item, list) for item in scale_value):
        scale = _near_identity(np.diag(_vector(scale_value, 'scale', 1e3)), 'scale')
    else:
        scale = _near_identity(_matrix(scale_value, 'scale', 1e3), 'scale')
    misalignment = _near_identity(_matrix(data.get('misalignment', _IDENTITY), 'misalignment',
                                          1e3), 'misalignment')
    gyro_matrix = _conditioned(misalignment @ scale, 'misalignment · scale')
    acc_matrix = _invertible(data.get('accelerometer_matrix', _IDENTITY), 'accelerometer_matrix')
    return ImuCalibration(
        gyro_matrix=gyro_matrix,
        gyro_bias=_vector(data.get('bias', [0.0, 0.0, 0.0]), 'bias', MAX_RATE_BIAS),
        accelerometer_matrix=acc_matrix,
        accelerometer_bias=_vector(data.get('accelerometer_bias', [0.0, 0.0, 0.0]),
                                   'accelerometer_bias', MAX_ACCELERATION_BIAS),
        noise=_noise(data, ''), kind='plain', source=source)


def _noise(data: Mapping[Any, Any], prefix: str, required: tuple[str, ...] = ()) -> ImuNoise:
    """The noise figures of ``data``: each in its :data:`NOISE_BOUNDS`, densities and random
    walks in pairs, the keys ``required`` present (else one error naming the key)."""
    for key in required:
        if data.get(key) is None:
            raise CalibrationError(f'Missing key {prefix}{key} (a kalibr imu.yaml must give '
                                   f'{", ".join(REQUIRED_NOISE_KEYS)})')
    for sensor in ('gyroscope', 'accelerometer'):
        pair = (f'{sensor}_noise_density', f'{sensor}_random_walk')
        given = [data.get(key) is not None for key in pair]
        if given[0] != given[1]:
            raise CalibrationError(f'Missing key {prefix}{pair[given[0]]} (given with '
                                   f'{prefix}{pair[given[1]]}: the two come as a pair)')
    values: dict[str, float | None] = {}
    for key in NOISE_KEYS:
        values[key] = (None if data.get(key) is None
                       else _FIELDS.number(data[key], f'{prefix}{key}', 0.0,
                                           NOISE_BOUNDS[key], low_open=True))
    rate = data.get('update_rate')
    topic = data.get('rostopic', '')
    if not isinstance(topic, str):
        raise CalibrationError(f'Expected {prefix}rostopic to be a topic name, got {quote(topic)}')
    figures = tuple((key, _FIELDS.number(data[key], f'{prefix}{key}', low, high))
                    for key, (low, high) in FIGURE_BOUNDS.items() if key in data)
    return ImuNoise(
        update_rate=None if rate is None else _FIELDS.number(
            rate, f'{prefix}update_rate', MIN_UPDATE_RATE, MAX_UPDATE_RATE),
        rostopic=topic, figures=figures, **values)


def _vector(value: Any, key: str, bound: float) -> FloatArray:
    return np.array(_FIELDS.vector(value, key, 3, bound), dtype=np.float64)


def _matrix(value: Any, key: str, bound: float) -> FloatArray:
    rows = value.tolist() if isinstance(value, np.ndarray) else value
    return np.array(_FIELDS.matrix(rows, key, 3, 3, bound), dtype=np.float64)


def _conditioned(matrix: FloatArray, key: str) -> FloatArray:
    condition = float(np.linalg.cond(matrix)) if np.all(np.isfinite(matrix)) else math.inf
    if not condition <= CONDITION_LIMIT:
        raise CalibrationError(f'Expected {key} to be invertible (condition number at most '
                               f'{CONDITION_LIMIT:g}), got {quote(matrix.tolist())} (condition '
                               f'number {condition:.3g})')
    return matrix


def _inverse(matrix: FloatArray) -> FloatArray:
    inverse: FloatArray = np.linalg.inv(matrix).astype(np.float64)
    return inverse


def _invertible(value: Any, key: str) -> FloatArray:
    return _conditioned(_near_identity(_matrix(value, key, 1e3), key), key)


def _near_identity(matrix: FloatArray, key: str) -> FloatArray:
    """A scale-misalignment matrix: diagonal in :data:`SCALE_RANGE`, off-diagonal entries
    at most :data:`MAX_MISALIGNMENT` in magnitude (else one error naming the entry)."""
    low, high = SCALE_RANGE
    for row in range(3):
        for column in range(3):
            value = float(matrix[row, column])
            if row == column and not low <= value <= high:
                raise CalibrationError(f'Expected the scale factors (diagonal) of {key} to be '
                                       f'in [{low:g}, {high:g}], got {value!r} at '
                                       f'[{row}][{column}]')
            if row != column and abs(value) > MAX_MISALIGNMENT:
                raise CalibrationError(f'Expected the misalignment (off-diagonal) entries of '
                                       f'{key} to be at most {MAX_MISALIGNMENT:g} in magnitude, '
                                       f'got {value!r} at [{row}][{column}]')
    return matrix


def _rotation(value: Any, key: str) -> FloatArray:
    matrix = _matrix(value, key, 1e3)
    deviation = float(np.max(np.abs(matrix.T @ matrix - np.eye(3))))
    if deviation > ORTHONORMAL_TOLERANCE or np.linalg.det(matrix) < 0.0:
        raise CalibrationError(f'Expected {key} to be a rotation matrix (orthonormal within '
                               f'{ORTHONORMAL_TOLERANCE:g}, determinant +1), got '
                               f'{quote(matrix.tolist())} (largest |CᵀC − I| entry '
                               f'{deviation:.3g}, determinant {np.linalg.det(matrix):.3g})')
    return matrix
