"""A simulated strapdown IMU: the gyro error model of the attitude covariance, made real.

The scene's ``sensors: {imu: {...}}`` section (:func:`sensors_spec`) gives an :class:`ImuSpec`;
an :class:`ImuModel` turns the body's motion over one sample interval into one sample. Both
sensors sit at the body frame's origin (no lever arm), in the sensor frame of the mount
``mount_rpy`` (roll, pitch, yaw of the sensor frame in the body frame, tf2's ``setRPY``).

**Gyroscope** (sensor frame, rad/s), the model of
:mod:`~rigid_body_attitude.core.estimation.gyro_error_model` with its names and units (kalibr's)::

    ω_m,k = (I + E) C ω̄_k + b_k + σ_d n_k,    b_k = b_{k−1} + σ_bd w_k

``ω̄_k = log(q_{k−1}* ⊗ q_k) / Δt`` is the **mean** body rate over the sample interval, taken
from the attitude increment (the sample a MEMS gyro delivers when it averages over its
interval), so the strapdown method ``delta_single`` integrates noise-free samples back to the
true attitude exactly. ``C`` turns body components into sensor components. ``E`` (scale
factors on the diagonal, misalignment off it) and the turn-on bias ``b_0`` are drawn once per
run from the priors (``gyroscope_scale_stddev``, ``gyroscope_misalignment_stddev``,
``gyroscope_turn_on_bias``); ``n_k``, ``w_k`` are unit normal. Discrete-time densities
(kalibr's IMU noise model; J. L. Crassidis, "Sigma-point Kalman filtering for integrated GPS
and inertial navigation", IEEE Trans. Aerospace and Electronic Systems 42(2), 2006,
eqs. 22-23): ``σ_d = N / √Δt`` (white noise of density ``gyroscope_noise_density`` N),
``σ_bd = K √Δt`` (bias walk of density ``gyroscope_random_walk`` K).

**Accelerometer** (sensor frame, m/s²): the specific force, the mean over the interval,

    f_m,k = C R(q_mid)ᵀ (Δv_k / Δt − g) + b_a,k + σ_a n_a,k

with ``Δv_k`` the change of the centre of mass's world velocity over the interval (zero for a
scene without translation: the body's origin is held in place), ``g`` the world gravity
(:func:`~rigid_body_attitude.core.sensors.imu.ImuModel` takes it from the scene) and
``q_mid`` the attitude half way through the interval. The same discrete densities, the
turn-on bias drawn once, no scale or misalignment term.

Both then saturate at ``±range`` and are quantised to ``resolution`` (0: neither). A
generator seeded with ``seed`` draws the constants first (gyro bias, accelerometer bias, the
9 entries of ``E``), then 12 unit normals per sample, in blocks: the same spec and motion give
the same samples, however the samples are grouped in time.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel
from rigid_body_attitude.core.sensors.section import (
    MAX_RATE, NOISE_BLOCK, Quat, SampledSensorSpec, SensorSection, Vector, check_section_keys,
    limited)

__all__ = ['ImuModel', 'ImuSpec', 'MAX_RATE', 'imu_spec']

FloatArray = NDArray[np.float64]

#: One sample's error terms in a block (native doubles).
_ERROR_ROW = struct.Struct('=12d')
_DEFAULTS = GyroErrorModel()
#: Numeric keys: (default, lowest, highest) in SI units; ``rate`` excludes its lowest.
_BOUNDS: dict[str, tuple[float, float, float]] = {
    'rate': (math.nan, 0.0, MAX_RATE),
    'gyroscope_noise_density': (_DEFAULTS.gyroscope_noise_density, 0.0, 1.0),
    'gyroscope_random_walk': (_DEFAULTS.gyroscope_random_walk, 0.0, 1.0),
    'gyroscope_turn_on_bias': (_DEFAULTS.gyroscope_turn_on_bias, 0.0, 1.0),
    'gyroscope_scale_stddev': (_DEFAULTS.gyroscope_scale_stddev, 0.0, 0.5),
    'gyroscope_misalignment_stddev': (_DEFAULTS.gyroscope_misalignment_stddev, 0.0, 0.5),
    'gyroscope_range': (0.0, 0.0, 1e6),
    'gyroscope_resolution': (0.0, 0.0, 1.0),
    'accelerometer_noise_density': (_DEFAULTS.accelerometer_noise_density, 0.0, 10.0),
    'accelerometer_random_walk': (0.0, 0.0, 10.0),
    'accelerometer_turn_on_bias': (_DEFAULTS.accelerometer_bias_stddev, 0.0, 100.0),
    'accelerometer_range': (0.0, 0.0, 1e6),
    'accelerometer_resolution': (0.0, 0.0, 100.0),
}
_OTHER_KEYS = {'frame_id', 'topic', 'mount_rpy', 'seed', 'gravity'}
_SECTION = SensorSection('imu')
#: Largest |gravity component| [m/s²].
_GRAVITY_LIMIT = 1000.0


@dataclass(frozen=True)
class ImuSpec(SampledSensorSpec):
    """A validated ``sensors.imu`` section (SI units; see the module docstring).

    ``gravity``: the world gravity [m/s²] a body held in place feels (only for scenes without
    translation or a gravity effect; ``None``: none given). ``*_range`` and ``*_resolution``
    of 0 mean no saturation and no quantisation.
    """

    rate: float
    frame_id: str = 'imu_link'
    topic: str = 'imu'
    mount_rpy: Vector = (0.0, 0.0, 0.0)
    seed: int = 0
    gravity: Vector | None = None
    gyroscope_noise_density: float = _BOUNDS['gyroscope_noise_density'][0]
    gyroscope_random_walk: float = _BOUNDS['gyroscope_random_walk'][0]
    gyroscope_turn_on_bias: float = _BOUNDS['gyroscope_turn_on_bias'][0]
    gyroscope_scale_stddev: float = _BOUNDS['gyroscope_scale_stddev'][0]
    gyroscope_misalignment_stddev: float = _BOUNDS['gyroscope_misalignment_stddev'][0]
    gyroscope_range: float = 0.0
    gyroscope_resolution: float = 0.0
    accelerometer_noise_density: float = _BOUNDS['accelerometer_noise_density'][0]
    accelerometer_random_walk: float = 0.0
    accelerometer_turn_on_bias: float = _BOUNDS['accelerometer_turn_on_bias'][0]
    accelerometer_range: float = 0.0
    accelerometer_resolution: float = 0.0

    def error_model(self) -> GyroErrorModel:
        """The gyro's figures as the attitude covariance takes them."""
        return GyroErrorModel(
            gyroscope_noise_density=self.gyroscope_noise_density,
            gyroscope_random_walk=self.gyroscope_random_walk,
            gyroscope_turn_on_bias=self.gyroscope_turn_on_bias,
            gyroscope_scale_stddev=self.gyroscope_scale_stddev,
            gyroscope_misalignment_stddev=self.gyroscope_misalignment_stddev,
            accelerometer_noise_density=self.accelerometer_noise_density,
            accelerometer_bias_stddev=self.accelerometer_turn_on_bias)

    def sample_variances(self) -> tuple[float, float]:
        """Per-sample variance of the white noise of the gyro [(rad/s)²] and of the
        accelerometer [(m/s²)²], ``N²/Δt``, plus the quantisation's ``resolution²/12``: the
        diagonal of the published covariances (REP-145)."""
        dt = self.period
        return (self.gyroscope_noise_density ** 2 / dt + self.gyroscope_resolution ** 2 / 12.0,
                self.accelerometer_noise_density ** 2 / dt
                + self.accelerometer_resolution ** 2 / 12.0)


def imu_spec(data: Any) -> ImuSpec:
    """Validate a ``sensors.imu`` mapping; one :class:`SceneError` naming the key otherwise."""
    data = _SECTION.mapping(data, set(_BOUNDS) | _OTHER_KEYS, ('rate',))
    numbers: dict[str, Any] = _SECTION.numbers(data, _BOUNDS)
    spec = replace(ImuSpec(rate=numbers.pop('rate')), **numbers, **_SECTION.placement(data))
    if 'gravity' in data:
        spec = replace(spec, gravity=_SECTION.triple('gravity', data['gravity'],
                                                     _GRAVITY_LIMIT))
    return spec


class ImuModel:
    """One simulated IMU: constants drawn at :meth:`reset`, one sample per :meth:`sample`."""

    def __init__(self, spec: ImuSpec, gravity_world: Vector = (0.0, 0.0, 0.0)) -> None:
        """The IMU of ``spec`` in a world whose gravity is ``gravity_world`` [m/s²]."""
        self.spec = spec
        self.gravity_world = gravity_world
        #: Body components → sensor components.
        self.body_to_sensor = quaternion.to_matrix(spec.mount()).T
        dt = self._dt = spec.period
        root = math.sqrt(dt)
        self._gyro_limits = spec.gyroscope_range, spec.gyroscope_resolution
        self._acc_limits = spec.accelerometer_range, spec.accelerometer_resolution
        self._limits = any(self._gyro_limits + self._acc_limits)
        self._sigmas = (spec.gyroscope_noise_density / root, spec.gyroscope_random_walk * root,
                        spec.accelerometer_noise_density / root,
                        spec.accelerometer_random_walk * root)
        self.reset()

    def reset(self) -> None:
        """A new run of the same unit: generator re-seeded, constants drawn again (the same)."""
        spec = self.spec
        rng = np.random.default_rng(spec.seed)
        gyro_bias = rng.standard_normal(3) * spec.gyroscope_turn_on_bias
        accelerometer_bias = rng.standard_normal(3) * spec.accelerometer_turn_on_bias
        intrinsic_stddev = np.sqrt(spec.error_model().intrinsic_variances())
        #: Scale factors and misalignment ``E`` (sensor frame).
        self.intrinsic = (rng.standard_normal(9) * intrinsic_stddev).reshape(3, 3)
        self._gyro_matrix = ((np.eye(3) + self.intrinsic) @ self.body_to_sensor).tolist()
        self._acc_matrix = self.body_to_sensor.tolist()
        self._rng = rng
        #: The biases after the last sample (gyro, accelerometer), where the next block starts.
        self._biases = np.concatenate([gyro_bias, accelerometer_bias])
        self._errors = b''
        self._offset = 0

    @property
    def gyro_bias(self) -> list[float]:
        """The gyro bias [rad/s, sensor frame] of the last sample (the turn-on bias before)."""
        return self._last_biases()[:3]

    @property
    def accelerometer_bias(self) -> list[float]:
        """The accelerometer bias [m/s², sensor frame] of the last sample (turn-on before)."""
        return self._last_biases()[3:]

    def _last_biases(self) -> list[float]:
        if self._offset == 0:  # none taken from this block: where it starts
            return list(self._biases.tolist())
        row = _ERROR_ROW.unpack_from(self._errors, self._offset - _ERROR_ROW.size)
        return [*row[0:3], *row[6:9]]

    def _draw_block(self) -> None:
        """The error terms of the next :data:`NOISE_BLOCK` samples, one row each: gyro bias,
        gyro white noise, accelerometer bias, accelerometer white noise. The bias walks are
        running sums from the last bias (``np.cumsum`` adds in order: the same floats as
        adding sample by sample)."""
        noise = self._rng.standard_normal((NOISE_BLOCK, 12))
        white, walk, white_a, walk_a = self._sigmas
        steps = np.empty((NOISE_BLOCK + 1, 6))
        steps[0] = self._biases
        np.multiply(noise[:, 3:6], walk, out=steps[1:, :3])
        np.multiply(noise[:, 9:12], walk_a, out=steps[1:, 3:])
        biases = np.cumsum(steps, axis=0)[1:]
        self._biases = biases[-1].copy()
        errors = np.empty((NOISE_BLOCK, 12))
        errors[:, 0:3] = biases[:, :3]
        np.multiply(noise[:, 0:3], white, out=errors[:, 3:6])
        errors[:, 6:9] = biases[:, 3:]
        np.multiply(noise[:, 6:9], white_a, out=errors[:, 9:12])
        self._errors = errors.tobytes()  # unpacked row by row: no list of 12 288 floats
        self._offset = 0

    def sample(self, q_start: Quat, q_end: Quat,
               velocity_change_world: Vector = (0.0, 0.0, 0.0)) -> tuple[Vector, Vector]:
        """The gyro [rad/s] and accelerometer [m/s²] sample (sensor frame) of one interval of
        the nominal period, from the attitudes (w, x, y, z) at its ends and the change of the
        world velocity over it (plain floats throughout: the arithmetic of
        :func:`~rigid_body_attitude.core.attitude.quaternion.scalar_step_rate` and
        :func:`~rigid_body_attitude.core.attitude.quaternion.rotate_inverse_floats` written
        out; the attitude half way through from the square root of the increment, no sine or
        cosine)."""
        dt = self._dt
        # ω̄ = log(q_start* ⊗ q_end) / Δt, the shorter way round
        qw, qx, qy, qz = q_start
        w1, x1, y1, z1 = q_end
        w = qw * w1 + qx * x1 + qy * y1 + qz * z1
        x = qw * x1 - qx * w1 - qy * z1 + qz * y1
        y = qw * y1 + qx * z1 - qy * w1 - qz * x1
        z = qw * z1 - qx * y1 + qy * x1 - qz * w1
        sine = math.sqrt(x * x + y * y + z * z)
        if sine > quaternion.SERIES_THRESHOLD * abs(w):
            k = 2.0 * math.atan2(sine, abs(w)) / sine
        else:
            k = 2.0 / abs(w) * (1.0 - sine * sine / (3.0 * w * w))
        k = math.copysign(k, w) / dt
        rx, ry, rz = k * x, k * y, k * z
        # q_mid = q_start ⊗ √(Δq), the half rotation: (|Δq| + w, x, y, z) normalised, w ≥ 0
        if not math.isfinite(k * sine):
            raise InputError(f'Expected finite attitudes, got {q_start!r} and {q_end!r}')
        if w < 0.0:
            w, x, y, z = -w, -x, -y, -z
        w += math.sqrt(w * w + sine * sine)
        inv = 1.0 / math.sqrt(w * w + sine * sine)
        ew, ex, ey, ez = w * inv, x * inv, y * inv, z * inv
        w = qw * ew - qx * ex - qy * ey - qz * ez
        x = qw * ex + qx * ew + qy * ez - qz * ey
        y = qw * ey - qx * ez + qy * ew + qz * ex
        z = qw * ez + qx * ey - qy * ex + qz * ew
        # specific force in the body frame: R(q_mid)ᵀ (Δv/Δt − g)
        gx, gy, gz = self.gravity_world
        dvx, dvy, dvz = velocity_change_world
        fx, fy, fz = dvx / dt - gx, dvy / dt - gy, dvz / dt - gz
        tx, ty, tz = 2.0 * (z * fy - y * fz), 2.0 * (x * fz - z * fx), 2.0 * (y * fx - x * fy)
        return self._measured(rx, ry, rz, fx + w * tx + (z * ty - y * tz),
                              fy + w * ty + (x * tz - z * tx), fz + w * tz + (y * tx - x * ty))

    def measure(self, rate_body: Vector, specific_force_body: Vector) -> tuple[Vector, Vector]:
        """One sample of a true mean body rate and specific force (body frame): errors added,
        saturated, quantised (sensor frame)."""
        return self._measured(*rate_body, *specific_force_body)

    def _measured(self, x: float, y: float, z: float, fx: float, fy: float,
                  fz: float) -> tuple[Vector, Vector]:
        """:meth:`measure` of the rate ``(x, y, z)`` and specific force ``(fx, fy, fz)``."""
        offset = self._offset
        if offset == len(self._errors):
            self._draw_block()
            offset = 0
        row = _ERROR_ROW.unpack_from(self._errors, offset)
        b0, b1, b2, n0, n1, n2, c0, c1, c2, a0, a1, a2 = row
        self._offset = offset + _ERROR_ROW.size
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self._gyro_matrix
        gyro = (m00 * x + m01 * y + m02 * z + b0 + n0, m10 * x + m11 * y + m12 * z + b1 + n1,
                m20 * x + m21 * y + m22 * z + b2 + n2)
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self._acc_matrix
        acc = (m00 * fx + m01 * fy + m02 * fz + c0 + a0, m10 * fx + m11 * fy + m12 * fz + c1 + a1,
               m20 * fx + m21 * fy + m22 * fz + c2 + a2)
        if self._limits:
            return limited(*gyro, *self._gyro_limits), limited(*acc, *self._acc_limits)
        return gyro, acc


check_section_keys('imu', ImuSpec, set(_BOUNDS) | _OTHER_KEYS)
