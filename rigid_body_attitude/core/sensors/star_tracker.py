"""A simulated star tracker: the body's attitude measured through the sensor's noise.

The scene's ``sensors: {star_tracker: {...}}`` section (:func:`star_tracker_spec`) gives a
:class:`StarTrackerSpec`; a :class:`StarTrackerModel` turns the body's attitude at a sample
instant into one measured body attitude and the covariance its message carries.

**Frames.** The boresight is the sensor's z axis. The sensor frame sits in the body at
``mount_rpy`` (roll, pitch, yaw, tf2's ``setRPY``) or, given ``boresight`` (a body vector),
at the shortest rotation taking body z onto it (the roll about the boresight does not change
the statistics: the noise is the same across both cross axes). ``M = R(q_mount)`` turns
sensor components into body components; ``b = M e_z`` is the boresight in the body.

**Measurement** (quaternions of :mod:`~rigid_body_attitude.core.attitude.quaternion`:
Hamilton, ``q`` body → world)::

    q_meas = q ⊗ q_mount ⊗ exp(μ) ⊗ exp(ν_k) ⊗ q_mount*
           = q ⊗ exp(M δθ_k)    to first order,   δθ_k = μ + ν_k   (sensor axes)

``ν_k = (σ⊥ n_x, σ⊥ n_y, σ∥ n_z)`` is the noise of sample k, ``n`` unit normal, ``σ⊥`` the
noise-equivalent angle across the boresight (``cross_boresight_noise``, 1σ per cross axis)
and ``σ∥`` about it (``about_boresight_noise``). ``μ`` is the misalignment of the sensor on
its mount, drawn once per run with ``misalignment_stddev`` per axis: a constant bias of the
measured attitude, which no published covariance holds. The error rotation is applied on the
right, in the sensor's axes mapped into the body's: the multiplicative attitude error of F. L.
Markley, J. L. Crassidis, "Fundamentals of Spacecraft Attitude Determination and Control",
Springer, 2014, written for Hamilton quaternions; the noise in the sensor frame, as NASA 42's
star tracker adds it (E. Stoneking, 42 spacecraft simulation, ``StarTrackerModel``; Basilisk's
``starTracker``, AVS Lab, adds a Gauss-Markov error in the body frame instead).

**Covariance** (the orientation block of ``geometry_msgs/PoseWithCovarianceStamped``, rad²,
about fixed world axes as the node's ``pose_with_covariance``: ``q_true = exp(δθ_w) ⊗
q_meas``)::

    P = R C diag(σ⊥², σ⊥², σ∥²) Cᵀ Rᵀ = σ⊥² I + (σ∥² − σ⊥²) b_w b_wᵀ,    b_w = R b

with ``R = R(q_meas)`` (what the sensor itself can compute: the difference from the true
attitude is second order) and ``C = M``. It holds the noise only.

**Sun exclusion.** With ``sun_exclusion_angle`` α > 0 and a Sun direction ``s`` in the scene
(:mod:`~rigid_body_attitude.core.environment.sun`), no sample is given when the true boresight
in world axes, ``R(q) M exp(μ) e_z``, is within α of ``s``: ``b_w · s > cos α`` (42's test).

**Seeded.** A generator seeded with ``(seed, 2)`` (its stream differs from the IMU's and the
magnetometer's of the same ``seed``) draws the misalignment (3 unit normals, whatever its
standard deviation), then 3 unit normals per sample instant in blocks, an excluded instant
included: the noise of an instant does not depend on earlier exclusions or on the grouping.

**Assumptions and limitations.** A point sample at the instant: no exposure time, no latency,
no loss of track at high body rates, a noise that does not depend on the stars in view; no
Earth or Moon occultation (scenes have no orbit for it), no stellar aberration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.attitude.float_quaternion import q_exp, q_multiply
from rigid_body_attitude.core.environment.sun import SunDirectionModel
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.sensors.section import (
    NOISE_BLOCK, NormalRows, Quat, SampledSensorSpec, SensorSection, Vector, check_section_keys,
    mount_quaternion, unit_vector)

__all__ = ['ARCSECOND', 'MAX_STAR_TRACKER_RATE', 'STREAM', 'StarTrackerModel',
           'StarTrackerSpec', 'star_tracker_spec', 'world_covariance']

#: One second of arc [rad].
ARCSECOND = math.pi / (180.0 * 3600.0)
#: Highest sample rate [Hz].
MAX_STAR_TRACKER_RATE = 1000.0
#: The key of the star tracker's random stream beside its ``seed``.
STREAM = 2
#: Numeric keys: (default, lowest, highest) in SI units; ``rate`` and the noises exclude their
#: lowest.
_BOUNDS: dict[str, tuple[float, float, float]] = {
    'rate': (math.nan, 0.0, MAX_STAR_TRACKER_RATE),
    'cross_boresight_noise': (5.0 * ARCSECOND, 0.0, 0.1),
    'about_boresight_noise': (35.0 * ARCSECOND, 0.0, 0.1),
    'misalignment_stddev': (0.0, 0.0, 0.1),
    'sun_exclusion_angle': (0.0, 0.0, math.pi),
}
_POSITIVE = ('rate', 'cross_boresight_noise', 'about_boresight_noise')
_OTHER_KEYS = {'frame_id', 'topic', 'mount_rpy', 'boresight', 'seed'}
_SECTION = SensorSection('star_tracker')
#: Largest |component| of a given boresight (it is normalised).
_BORESIGHT_LIMIT = 1e6


@dataclass(frozen=True)
class StarTrackerSpec(SampledSensorSpec):
    """A validated ``sensors.star_tracker`` section (SI units, radians; see the module
    docstring). ``boresight``: the body vector the sensor's z axis points along, given
    instead of ``mount_rpy`` (``None``: the mount is ``mount_rpy``)."""

    rate: float
    frame_id: str = 'star_tracker_link'
    topic: str = 'star_tracker'
    mount_rpy: Vector = (0.0, 0.0, 0.0)
    boresight: Vector | None = None
    seed: int = 0
    cross_boresight_noise: float = _BOUNDS['cross_boresight_noise'][0]
    about_boresight_noise: float = _BOUNDS['about_boresight_noise'][0]
    misalignment_stddev: float = 0.0
    sun_exclusion_angle: float = 0.0

    def mount(self) -> Quat:
        """Rotation (w, x, y, z) of the sensor frame in the body frame."""
        if self.boresight is None:
            return mount_quaternion(self.mount_rpy)
        return _shortest_rotation_from_z(self.boresight)

    def boresight_body(self) -> Vector:
        """The nominal boresight ``b = M e_z`` in body axes (unit)."""
        w, x, y, z = self.mount()
        return 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)

    def sensor_variances(self) -> Vector:
        """``(σ⊥², σ⊥², σ∥²)`` [rad²]: the noise's variances about the sensor's axes."""
        across = self.cross_boresight_noise ** 2
        return across, across, self.about_boresight_noise ** 2

    def orientation_covariance(self, attitude: Quat) -> tuple[float, ...]:
        """The 9 entries (row major, rad², about world x, y, z) of the covariance of a
        measurement ``attitude`` (w, x, y, z): ``σ⊥² I + (σ∥² − σ⊥²) b_w b_wᵀ``."""
        across, _, about = self.sensor_variances()
        return world_covariance(attitude, self.boresight_body(), across, about)


def world_covariance(attitude: Quat, boresight_body: Vector, across: float,
                     about: float) -> tuple[float, ...]:
    """``σ⊥² I + (σ∥² − σ⊥²) b_w b_wᵀ`` (9 entries, row major), ``b_w`` the unit
    ``boresight_body`` turned by ``attitude``; ``across`` = σ⊥², ``about`` = σ∥² [rad²]."""
    bx, by, bz = quaternion.rotate_floats(attitude, boresight_body)
    extra = about - across
    xy, xz, yz = extra * bx * by, extra * bx * bz, extra * by * bz
    return (across + extra * bx * bx, xy, xz, xy, across + extra * by * by, yz,
            xz, yz, across + extra * bz * bz)


def _shortest_rotation_from_z(direction: Vector) -> Quat:
    """The rotation by the smallest angle taking ``(0, 0, 1)`` onto the unit ``direction``:
    ``(1 + d_z, e_z × d)`` normalised; half a turn about x for ``−e_z``."""
    dx, dy, dz = direction
    w, x, y = 1.0 + dz, -dy, dx
    norm = math.sqrt(w * w + x * x + y * y)
    if norm == 0.0:  # guard the opposite direction: the axis is any one across z
        return 0.0, 1.0, 0.0, 0.0
    return w / norm, x / norm, y / norm, 0.0


def star_tracker_spec(data: Any) -> StarTrackerSpec:
    """Validate a ``sensors.star_tracker`` mapping; one SceneError naming the key otherwise."""
    data = _SECTION.mapping(data, set(_BOUNDS) | _OTHER_KEYS, ('rate',))
    numbers: dict[str, Any] = _SECTION.numbers(data, _BOUNDS, _POSITIVE)
    spec = replace(StarTrackerSpec(rate=numbers.pop('rate')), **numbers)
    if 'mount_rpy' in data and 'boresight' in data:
        raise SceneError('sensors.star_tracker takes mount_rpy or boresight, not both')
    spec = replace(spec, **_SECTION.placement(data))
    if 'boresight' in data:
        given = _SECTION.triple('boresight', data['boresight'], _BORESIGHT_LIMIT)
        spec = replace(spec, boresight=unit_vector('sensors.star_tracker.boresight', given))
    return spec


class StarTrackerModel:
    """One simulated star tracker: misalignment drawn at :meth:`reset`, one measurement per
    :meth:`sample`."""

    def __init__(self, spec: StarTrackerSpec, sun: SunDirectionModel | None = None,
                 noise_block: int = NOISE_BLOCK) -> None:
        """The star tracker of ``spec``; ``sun`` gives the Sun's direction (required by a
        ``sun_exclusion_angle``: InputError without it). ``noise_block``: rows of normals
        drawn at a time (the samples do not depend on it)."""
        if spec.sun_exclusion_angle > 0.0 and sun is None:
            raise InputError('Expected a Sun direction for sensors.star_tracker.'
                             'sun_exclusion_angle, got none')
        self.spec = spec
        self.sun = sun
        self._mount = spec.mount()
        #: ``M``: sensor components → body components.
        self.sensor_to_body = quaternion.to_matrix(self._mount).tolist()
        self._cos_exclusion = math.cos(spec.sun_exclusion_angle)
        self._boresight = spec.boresight_body()
        self._variances = spec.sensor_variances()
        self._noise_block = noise_block
        self.reset()

    def reset(self) -> None:
        """A new run of the same unit: the generator seeded again, the misalignment drawn
        again (the same)."""
        spec = self.spec
        rng = np.random.default_rng([spec.seed, STREAM])
        mx, my, mz = (rng.standard_normal(3) * spec.misalignment_stddev).tolist()
        #: The misalignment ``μ`` [rad, sensor axes] drawn for this run.
        self.misalignment: Vector = (mx, my, mz)
        self._misaligned = q_exp(mx, my, mz) if any(self.misalignment) else None
        true_mount = q_multiply(self._mount, q_exp(mx, my, mz))
        #: The true boresight (misalignment included) in body axes.
        self.true_boresight_body = quaternion.rotate_floats(true_mount, (0.0, 0.0, 1.0))
        self._rows = NormalRows(rng, 3, self._noise_block)

    def excluded(self, t: float, attitude: Quat) -> bool:
        """Whether the Sun is within the exclusion angle of the boresight at scene time ``t``
        [s] for a body at ``attitude`` (never without a ``sun_exclusion_angle``)."""
        if self.spec.sun_exclusion_angle == 0.0 or self.sun is None:
            return False
        bx, by, bz = quaternion.rotate_floats(attitude, self.true_boresight_body)
        sx, sy, sz = self.sun.sun_direction_world(t)
        return bx * sx + by * sy + bz * sz > self._cos_exclusion

    def sample(self, t: float, attitude: Quat) -> tuple[Quat, tuple[float, ...]] | None:
        """The measured body attitude (w, x, y, z) at scene time ``t`` [s] of a body at
        ``attitude`` and its covariance (:meth:`StarTrackerSpec.orientation_covariance`), or
        ``None`` when the Sun excludes the instant (its noise is drawn all the same)."""
        measured = self.measure(attitude)
        if self.excluded(t, attitude):
            return None
        across, _, about = self._variances
        return measured, world_covariance(measured, self._boresight, across, about)

    def measure(self, attitude: Quat) -> Quat:
        """One measured body attitude of a body at ``attitude`` (no exclusion)."""
        n0, n1, n2 = self._rows.next()
        across, about = self.spec.cross_boresight_noise, self.spec.about_boresight_noise
        error = q_exp(across * n0, across * n1, about * n2)
        if self._misaligned is not None:
            error = q_multiply(self._misaligned, error)
        ew, ex, ey, ez = error
        (a, b, c), (d, e, f), (g, h, i) = self.sensor_to_body
        body_error = (ew, a * ex + b * ey + c * ez, d * ex + e * ey + f * ez,
                      g * ex + h * ey + i * ez)
        w, x, y, z = q_multiply(attitude, body_error)
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not math.isfinite(norm):
            raise InputError(f'Expected a finite attitude, got {attitude!r}')
        return w / norm, x / norm, y / norm, z / norm


check_section_keys('star_tracker', StarTrackerSpec, set(_BOUNDS) | _OTHER_KEYS)
