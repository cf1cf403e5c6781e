"""A simulated strapdown IMU: the gyro error model of the attitude covariance, made real.

The scene's ``sensors: {imu: {...}}`` section (:func:`sensors_spec`) gives an :class:`ImuSpec`;
an :class:`ImuModel` turns the body's motion over one sample interval into one sample. Both
sensors sit at the body frame's origin (no lever arm), in the sensor frame of the mount
``mount_rpy`` (roll, pitch, yaw of the sensor frame in the body frame, tf2's ``setRPY``).

**Gyroscope** (sensor frame, rad/s), the model of
:mod:`~rigid_body_attitude.core.imu.gyro_error_model` with its names and units (kalibr's)::

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
import re
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.imu.gyro_error_model import GyroErrorModel
from rigid_body_attitude.core.yaml_files import Fields, quote

__all__ = ['ImuModel', 'ImuSpec', 'MAX_RATE', 'imu_spec', 'sensors_spec']

FloatArray = NDArray[np.float64]
Vector = tuple[float, float, float]
Quat = tuple[float, float, float, float]

#: Highest sample rate [Hz] (real IMUs: 100 Hz to a few kHz).
MAX_RATE = 10_000.0
#: Unit normals drawn at a time (12 per sample).
NOISE_BLOCK = 1024
_DEFAULTS = GyroErrorModel()
_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*')
_FRAME = re.compile(r'[A-Za-z0-9_./-]{1,256}')
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
_FIELDS = Fields(SceneError)
#: Largest |mount angle| [rad] and |gravity component| [m/s²].
_ANGLE_LIMIT, _GRAVITY_LIMIT = 10.0, 1000.0


@dataclass(frozen=True)
class ImuSpec:
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

    @property
    def period_ns(self) -> int:
        """Sample period [ns]: samples are taken at the clock times that are its multiples."""
        return round(1e9 / self.rate)

    @property
    def period(self) -> float:
        """Sample period Δt [s]."""
        return self.period_ns * 1e-9

    def mount(self) -> Quat:
        """Rotation (w, x, y, z) of the sensor frame in the body frame: ``Rz(yaw) Ry(pitch)
        Rx(roll)`` (tf2's ``setRPY``, static_transform_publisher's angles)."""
        roll, pitch, yaw = self.mount_rpy
        q = quaternion.multiply(quaternion.exp([0.0, 0.0, yaw]),
                                quaternion.multiply(quaternion.exp([0.0, pitch, 0.0]),
                                                    quaternion.exp([roll, 0.0, 0.0])))
        w, x, y, z = q.tolist()
        return w, x, y, z

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


def sensors_spec(data: Any) -> ImuSpec | None:
    """The scene's ``sensors`` section (``None`` or a mapping with the key ``imu``)."""
    if data is None:
        return None
    data = _FIELDS.mapping(data, 'sensors', {'imu'})
    return imu_spec(data['imu']) if 'imu' in data else None


def imu_spec(data: Any) -> ImuSpec:
    """Validate a ``sensors.imu`` mapping; one :class:`SceneError` naming the key otherwise."""
    data = _FIELDS.mapping(data, 'sensors.imu', set(_BOUNDS) | _OTHER_KEYS, ('rate',))
    numbers: dict[str, Any] = {key: _bounded_number(key, data[key]) for key in _BOUNDS
                               if key in data}
    spec = replace(ImuSpec(rate=numbers.pop('rate')), **numbers)
    if 'frame_id' in data:
        spec = replace(spec, frame_id=_matching('frame_id', data['frame_id'], _FRAME))
    if 'topic' in data:
        spec = replace(spec, topic=_matching('topic', data['topic'], _NAME))
    if 'mount_rpy' in data:
        spec = replace(spec, mount_rpy=_triple('mount_rpy', data['mount_rpy'], _ANGLE_LIMIT))
    if 'gravity' in data:
        spec = replace(spec, gravity=_triple('gravity', data['gravity'], _GRAVITY_LIMIT))
    if 'seed' in data:
        seed = data['seed']
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
            raise SceneError(f'Expected sensors.imu.seed to be an integer in [0, 2^63), got '
                             f'{quote(seed)}')
        spec = replace(spec, seed=seed)
    return spec


def _bounded_number(key: str, value: Any) -> float:
    """A number in the key's bounds (``rate``: above 0)."""
    _, low, high = _BOUNDS[key]
    return _FIELDS.number(value, f'sensors.imu.{key}', low, high, low_open=key == 'rate')


def _matching(key: str, value: Any, pattern: re.Pattern[str]) -> str:
    if not isinstance(value, str) or len(value) > 256 or not pattern.fullmatch(value):
        raise SceneError(f'Expected sensors.imu.{key} to be a ROS name (letters, digits, '
                         f'underscores{", dots, dashes" if key == "frame_id" else ""} and '
                         f'slashes, at most 256 characters), got {quote(value)}')
    return value


def _triple(key: str, value: Any, limit: float) -> Vector:
    a, b, c = _FIELDS.vector(value, f'sensors.imu.{key}', 3, limit)
    return a, b, c


class ImuModel:
    """One simulated IMU: constants drawn at :meth:`reset`, one sample per :meth:`sample`."""

    def __init__(self, spec: ImuSpec, gravity_world: Vector = (0.0, 0.0, 0.0)) -> None:
        """The IMU of ``spec`` in a world whose gravity is ``gravity_world`` [m/s²]."""
        self.spec = spec
        self.gravity_world = gravity_world
        #: Body components → sensor components.
        self.body_to_sensor = quaternion.to_matrix(spec.mount()).T
        dt = spec.period
        root = math.sqrt(dt)
        self._sigmas = (spec.gyroscope_noise_density / root, spec.gyroscope_random_walk * root,
                        spec.accelerometer_noise_density / root,
                        spec.accelerometer_random_walk * root)
        self.reset()

    def reset(self) -> None:
        """A new run of the same unit: generator re-seeded, constants drawn again (the same)."""
        spec = self.spec
        rng = np.random.default_rng(spec.seed)
        self.gyro_bias = (rng.standard_normal(3) * spec.gyroscope_turn_on_bias).tolist()
        self.accelerometer_bias = (rng.standard_normal(3)
                                   * spec.accelerometer_turn_on_bias).tolist()
        intrinsic_stddev = np.sqrt(spec.error_model().intrinsic_variances())
        #: Scale factors and misalignment ``E`` (sensor frame).
        self.intrinsic = (rng.standard_normal(9) * intrinsic_stddev).reshape(3, 3)
        self._gyro_matrix = ((np.eye(3) + self.intrinsic) @ self.body_to_sensor).tolist()
        self._acc_matrix = self.body_to_sensor.tolist()
        self._rng = rng
        self._noise: list[list[float]] = []
        self._next = 0

    def sample(self, q_start: Quat, q_end: Quat,
               velocity_change_world: Vector = (0.0, 0.0, 0.0)) -> tuple[Vector, Vector]:
        """The gyro [rad/s] and accelerometer [m/s²] sample (sensor frame) of one interval of
        the nominal period, from the attitudes (w, x, y, z) at its ends and the change of the
        world velocity over it."""
        dt = self.spec.period
        rate = quaternion.scalar_step_rate(q_start, q_end, dt)
        q_mid = quaternion.scalar_exp_step(q_start, rate, 0.5 * dt)
        gx, gy, gz = self.gravity_world
        dvx, dvy, dvz = velocity_change_world
        force = quaternion.rotate_inverse_floats(q_mid, (dvx / dt - gx, dvy / dt - gy,
                                                         dvz / dt - gz))
        return self.measure(rate, force)

    def measure(self, rate_body: Vector, specific_force_body: Vector) -> tuple[Vector, Vector]:
        """One sample of a true mean body rate and specific force (body frame): errors added,
        saturated, quantised (sensor frame)."""
        if self._next == len(self._noise):
            self._noise = self._rng.standard_normal((NOISE_BLOCK, 12)).tolist()
            self._next = 0
        n = self._noise[self._next]
        self._next += 1
        white, walk, white_a, walk_a = self._sigmas
        spec = self.spec
        b = self.gyro_bias
        ba = self.accelerometer_bias
        for axis in range(3):
            b[axis] += walk * n[3 + axis]
            ba[axis] += walk_a * n[9 + axis]
        gyro = _limited(_product(self._gyro_matrix, rate_body, b, white, n[0:3]),
                        spec.gyroscope_range, spec.gyroscope_resolution)
        acc = _limited(_product(self._acc_matrix, specific_force_body, ba, white_a, n[6:9]),
                       spec.accelerometer_range, spec.accelerometer_resolution)
        return gyro, acc


def _product(matrix: list[list[float]], vector: Vector, bias: list[float], sigma: float,
             noise: list[float]) -> Vector:
    """``matrix @ vector + bias + sigma * noise`` on plain floats."""
    x, y, z = vector
    r0, r1, r2 = matrix
    return (r0[0] * x + r0[1] * y + r0[2] * z + bias[0] + sigma * noise[0],
            r1[0] * x + r1[1] * y + r1[2] * z + bias[1] + sigma * noise[1],
            r2[0] * x + r2[1] * y + r2[2] * z + bias[2] + sigma * noise[2])


def _limited(values: Vector, full_scale: float, resolution: float) -> Vector:
    """Clipped to ``±full_scale`` and rounded to a multiple of ``resolution`` (0: not)."""
    x, y, z = values
    if full_scale > 0.0:
        x, y, z = (min(max(v, -full_scale), full_scale) for v in (x, y, z))
    if resolution > 0.0:
        x, y, z = (resolution * round(v / resolution) for v in (x, y, z))
    return x, y, z


def _field_names() -> set[str]:
    """Every key of the section is a field of :class:`ImuSpec` (checked at import)."""
    names = {f.name for f in fields(ImuSpec)}
    if not (set(_BOUNDS) | _OTHER_KEYS) <= names:
        raise ImportError('sensors.imu keys and ImuSpec fields differ')
    return names


_field_names()
