"""A simulated three-axis magnetometer: the world's field seen through hard and soft iron.

The scene's ``sensors: {magnetometer: {...}}`` section (:func:`magnetometer_spec`) gives a
:class:`MagnetometerSpec`; a :class:`MagnetometerModel` turns the body's attitude at a sample
instant into one sample [T] in the sensor frame, whose mount ``mount_rpy`` is the IMU's kind
(roll, pitch, yaw of the sensor frame in the body frame, tf2's ``setRPY``).

**Measurement** (sensor frame, T), at the instant ``t_k`` (a point sample)::

    m_k = S C R(q_k)ᵀ B(t_k) + h + b_k + σ_d n_k,     b_k = b_{k−1} + σ_bd w_k,   b_0 = 0

``B(t)`` is the field in world axes: the section's local field (``intensity`` F [T],
``inclination`` I [rad], ``declination`` D [rad] in ``world_axes``:
:class:`~rigid_body_attitude.core.environment.magnetic_field.LocalMagneticField`) or the
scene's field model (:class:`MagnetometerModel` takes any
:class:`~rigid_body_attitude.core.environment.magnetic_field.MagneticFieldModel`). ``R(q_k)``
is the attitude at the instant, ``C`` turns body components into sensor components. ``n_k``,
``w_k`` are unit normal; the discrete densities are the IMU's (kalibr's noise model; J. L.
Crassidis, "Sigma-point Kalman filtering for integrated GPS and inertial navigation", IEEE
Trans. Aerospace and Electronic Systems 42(2), 2006, eqs. 22-23): ``σ_d = N / √Δt`` for the
white noise of density ``noise_density`` N [T/√Hz], ``σ_bd = K √Δt`` for the bias walk of
density ``random_walk`` K [T/√s]. Each axis then saturates at ``±range`` and is quantised to
``resolution`` (0: neither).

**Hard and soft iron: the one convention.** The soft-iron matrix ``S`` (``soft_iron``, 3×3
in sensor axes, identity by default) and the hard-iron offset ``h`` (``hard_iron`` [T],
sensor axes, zero by default) map the true field in the sensor frame, ``b = C R(q)ᵀ B``, to
the measured one::

    m = S b + h          and a calibration inverts it:   b = S⁻¹ (m − h)

(:meth:`MagnetometerSpec.corrected`). Noise-free samples lie on the ellipsoid
``|S⁻¹ (m − h)| = |B|`` centred on ``h``. ``S`` holds the vehicle's soft iron and the
sensor's own scale factors and axis misalignment; it keeps the handedness (``det S > 0``) and
its condition number is at most :data:`SOFT_IRON_CONDITION_LIMIT`. This is the measurement
model of R. Alonso, M. D. Shuster, "Complete linear attitude-independent magnetometer
calibration", J. Astronautical Sciences 50(4), 2002, ``B = (I + D)⁻¹ (Oᵀ A H + b + ε)``, with
``S = (I + D)⁻¹ Oᵀ`` and ``h = (I + D)⁻¹ b``, the noise added after the distortion; and, with
``S`` a scale factor, of Basilisk's magnetometer module (AVS Lab, ``B_measured = (B_truth +
e_noise + e_bias) f_scale``).

**The covariance a message carries**: ``sensor_msgs/MagneticField``'s
``magnetic_field_covariance``, row major about the sensor's x, y, z; the message asks for the
variance of each measurement on the diagonal when that is all that is known, and reads an
all-zero matrix as "covariance unknown". Here: ``N²/Δt + resolution²/12`` on the diagonal
(:meth:`MagnetometerSpec.magnetic_field_covariance`); the bias walk and the iron are errors a
calibration removes, not in it. ``noise_density`` is required and positive, so the matrix is
never all zero.

**Seeded.** A generator seeded with ``(seed, 1)`` (its stream differs from the IMU's of the
same ``seed``) draws 6 unit normals per sample (white noise, then walk), in blocks: the same
spec and motion give the same samples, however the samples are grouped, and a zero
``random_walk`` leaves the white noise unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.environment.magnetic_field import (
    LocalMagneticField, MagneticFieldModel, WORLD_AXES)
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.sensors.section import (
    MAX_RATE, Matrix, NOISE_BLOCK, NormalRows, Quat, SampledSensorSpec, SensorSection, Vector,
    body_to_sensor_matrix, check_section_keys, limited)

__all__ = ['MagnetometerModel', 'MagnetometerSpec', 'SOFT_IRON_CONDITION_LIMIT',
           'STREAM', 'magnetometer_spec']

#: The key of the magnetometer's random stream beside its ``seed``.
STREAM = 1
#: Largest condition number of ``soft_iron``.
SOFT_IRON_CONDITION_LIMIT = 1e3
#: Largest |entry| of ``soft_iron``.
_SOFT_IRON_LIMIT = 10.0
#: Numeric keys: (default, lowest, highest) in SI units; ``rate`` excludes its lowest.
_BOUNDS: dict[str, tuple[float, float, float]] = {
    'rate': (math.nan, 0.0, MAX_RATE),
    'intensity': (math.nan, 0.0, 1e-2),
    'inclination': (0.0, -0.5 * math.pi, 0.5 * math.pi),
    'declination': (0.0, -math.pi, math.pi),
    'noise_density': (math.nan, 0.0, 1e-3),
    'random_walk': (0.0, 0.0, 1e-3),
    'range': (0.0, 0.0, 1.0),
    'resolution': (0.0, 0.0, 1e-3),
}
_OTHER_KEYS = {'frame_id', 'topic', 'mount_rpy', 'seed', 'world_axes', 'hard_iron',
               'soft_iron'}
_FIELD_KEYS = ('intensity', 'inclination', 'declination', 'world_axes')
_SECTION = SensorSection('magnetometer')
_IDENTITY: Matrix = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
#: Largest |hard-iron component| [T].
_HARD_IRON_LIMIT = 1e-2


@dataclass(frozen=True)
class MagnetometerSpec(SampledSensorSpec):
    """A validated ``sensors.magnetometer`` section (SI units; see the module docstring).

    ``intensity`` is ``None`` when the section gives no local field (the scene's field model
    is then required). ``range`` and ``resolution`` of 0 mean no saturation and no
    quantisation.
    """

    rate: float
    noise_density: float
    frame_id: str = 'magnetometer_link'
    topic: str = 'imu/mag'
    mount_rpy: Vector = (0.0, 0.0, 0.0)
    seed: int = 0
    intensity: float | None = None
    inclination: float = 0.0
    declination: float = 0.0
    world_axes: str = 'enu'
    random_walk: float = 0.0
    hard_iron: Vector = (0.0, 0.0, 0.0)
    soft_iron: Matrix = _IDENTITY
    range: float = 0.0
    resolution: float = 0.0

    def local_field(self) -> LocalMagneticField | None:
        """The section's constant field, or ``None`` if it gives none."""
        if self.intensity is None:
            return None
        return LocalMagneticField(self.intensity, self.inclination, self.declination,
                                  self.world_axes)

    def sample_variance(self) -> float:
        """Per-sample variance [T²] of each axis: ``N²/Δt + resolution²/12``."""
        return self.noise_density ** 2 / self.period + self.resolution ** 2 / 12.0

    def magnetic_field_covariance(self) -> tuple[float, ...]:
        """The 9 entries (row major, sensor axes) ``sensor_msgs/MagneticField`` carries."""
        v = self.sample_variance()
        return (v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, v)

    def distorted(self, field_sensor: Vector) -> Vector:
        """``S b + h``: the noise-free measurement of the true field ``b`` [T, sensor axes]."""
        (a, b, c), (d, e, f), (g, h, i) = self.soft_iron
        x, y, z = field_sensor
        hx, hy, hz = self.hard_iron
        return (a * x + b * y + c * z + hx, d * x + e * y + f * z + hy,
                g * x + h * y + i * z + hz)

    def corrected(self, measured: Vector) -> Vector:
        """``S⁻¹ (m − h)``: the true field [T, sensor axes] of a measurement, what a
        calibration of this sensor gives back (the inverse of :meth:`distorted`)."""
        difference = np.subtract(measured, self.hard_iron)
        x, y, z = np.linalg.solve(np.array(self.soft_iron), difference).tolist()
        return x, y, z


def magnetometer_spec(data: Any) -> MagnetometerSpec:
    """Validate a ``sensors.magnetometer`` mapping; one SceneError naming the key otherwise."""
    data = _SECTION.mapping(data, set(_BOUNDS) | _OTHER_KEYS, ('rate', 'noise_density'))
    numbers: dict[str, Any] = _SECTION.numbers(data, _BOUNDS, ('rate', 'noise_density'))
    given = [key for key in _FIELD_KEYS if key in data]
    if given and 'intensity' not in data:
        raise SceneError(f'sensors.magnetometer.{given[0]} needs sensors.magnetometer.intensity '
                         f'(the local field is intensity, inclination, declination)')
    spec = replace(MagnetometerSpec(rate=numbers.pop('rate'),
                                    noise_density=numbers.pop('noise_density')), **numbers)
    if 'world_axes' in data:
        spec = replace(spec, world_axes=_SECTION.choice('world_axes', data['world_axes'],
                                                        tuple(sorted(WORLD_AXES))))
    spec = replace(spec, **_SECTION.placement(data))
    if 'hard_iron' in data:
        spec = replace(spec, hard_iron=_SECTION.triple('hard_iron', data['hard_iron'],
                                                       _HARD_IRON_LIMIT))
    if 'soft_iron' in data:
        spec = replace(spec, soft_iron=_soft_iron(data['soft_iron']))
    return spec


def _soft_iron(value: Any) -> Matrix:
    """A 3×3 matrix that keeps the handedness and is well conditioned."""
    matrix = _SECTION.matrix('soft_iron', value, _SOFT_IRON_LIMIT)
    array = np.array(matrix)
    determinant = float(np.linalg.det(array))
    condition = float(np.linalg.cond(array)) if determinant > 0.0 else math.inf
    if not condition <= SOFT_IRON_CONDITION_LIMIT:
        raise SceneError(f'Expected sensors.magnetometer.soft_iron to have a positive '
                         f'determinant and a condition number at most '
                         f'{SOFT_IRON_CONDITION_LIMIT:g}, got determinant {determinant:.6g} and '
                         f'condition number {condition:.6g}')
    return matrix


class MagnetometerModel:
    """One simulated magnetometer: its generator seeded at :meth:`reset`, one sample per
    :meth:`sample`."""

    def __init__(self, spec: MagnetometerSpec, field: MagneticFieldModel | None = None,
                 noise_block: int = NOISE_BLOCK) -> None:
        """The magnetometer of ``spec`` in ``field`` (``None``: the section's local field;
        InputError if it gives none). ``noise_block``: rows of normals drawn at a time (the
        samples do not depend on it)."""
        self.spec = spec
        if field is None:
            field = spec.local_field()
            if field is None:
                raise InputError('Expected a magnetic field model or sensors.magnetometer.'
                                 'intensity, got neither')
        self.field = field
        #: The field [T, world] when it is constant (a local field): computed once.
        self._constant = field.field_world(0.0) if isinstance(field, LocalMagneticField) else None
        #: ``S C``: body components → distorted sensor components.
        self.distortion = (np.array(spec.soft_iron)
                           @ np.array(body_to_sensor_matrix(spec.mount()))).tolist()
        root = math.sqrt(spec.period)
        self._white, self._walk = spec.noise_density / root, spec.random_walk * root
        self._limits = spec.range, spec.resolution
        self._noise_block = noise_block
        self.reset()

    def reset(self) -> None:
        """A new run of the same unit: the generator seeded again, the bias walk at zero."""
        self._rows = NormalRows(np.random.default_rng([self.spec.seed, STREAM]), 6,
                                self._noise_block)
        self._bias = (0.0, 0.0, 0.0)

    @property
    def bias(self) -> Vector:
        """The walked bias ``b_k`` [T, sensor axes] of the last sample (zero before)."""
        return self._bias

    def field_world(self, t: float) -> Vector:
        """The field [T, world axes] at scene time ``t`` [s]."""
        constant = self._constant
        if constant is not None:
            return constant
        x, y, z = self.field.field_world(t)
        return x, y, z

    def sample(self, t: float, attitude: Quat) -> Vector:
        """The measurement [T, sensor axes] at scene time ``t`` [s] of a body at ``attitude``
        (w, x, y, z, body → world)."""
        return self.measure(quaternion.rotate_inverse_floats(attitude, self.field_world(t)))

    def measure(self, field_body: Vector) -> Vector:
        """One sample of the true field ``field_body`` [T, body axes]: distorted, errors
        added, saturated, quantised (sensor axes)."""
        n0, n1, n2, w0, w1, w2 = self._rows.next()
        walk, white = self._walk, self._white
        b0, b1, b2 = self._bias
        bias = self._bias = (b0 + walk * w0, b1 + walk * w1, b2 + walk * w2)
        (a, b, c), (d, e, f), (g, h, i) = self.distortion
        x, y, z = field_body
        hx, hy, hz = self.spec.hard_iron
        mx = a * x + b * y + c * z + hx + bias[0] + white * n0
        my = d * x + e * y + f * z + hy + bias[1] + white * n1
        mz = g * x + h * y + i * z + hz + bias[2] + white * n2
        return limited(mx, my, mz, *self._limits)


check_section_keys('magnetometer', MagnetometerSpec, set(_BOUNDS) | _OTHER_KEYS)
