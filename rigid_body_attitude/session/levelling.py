"""A real IMU's samples before integration: calibration, mount, levelling, gyro bias.

Per sample, in this order (:class:`~rigid_body_attitude.session.gyro.GyroSession` calls it):

1. **calibration** (:mod:`rigid_body_attitude.core.estimation.calibration`), in the sensor
   frame (the Imu's ``frame_id``): ``a_i = N (a − b_a)``, ``ω_i = K (ω − b_g − G a_i)``;
2. **mount**: ``v_body = R v_sensor`` with ``R`` the rotation of the sensor frame in the
   body frame (:func:`~rigid_body_attitude.core.attitude.quaternion.from_rpy` of
   ``mount_rpy``, as ``static_transform_publisher`` takes roll, pitch and yaw; or the
   transform ``body_frame`` → sensor frame from TF);
3. **levelling** at start (:class:`Levelling`, around
   :class:`~rigid_body_attitude.core.estimation.alignment.GravityAligner`): nothing is
   integrated until the body rested ``align_seconds`` (or ``align_timeout`` passed); the
   roll and pitch come from gravity, the yaw from ``initial_yaw`` or a ``set_pose``
   received meanwhile, and the window's mean rate is the gyro bias estimate ``b`` (body frame);
4. **bias**: ``ω_body − b``, optionally refined whenever the body is at rest
   (:class:`~rigid_body_attitude.core.estimation.rest.RestBiasEstimator`); with the attitude
   filter's estimate ``Ê`` of the gyro's scale-factor and misalignment errors (body frame,
   the model ``ω_m = (I + E) ω + b`` of
   :mod:`~rigid_body_attitude.core.estimation.gyro_error_model`) also
   ``ω = (I + Ê)⁻¹ (ω_body − b)``.

After levelling the whole map is one affine map of the measured rate, ``ω = A ω_measured +
c`` with ``A = (I + Ê)⁻¹ R K`` and ``c = −(I + Ê)⁻¹ (R K b_g + b)`` (:attr:`SampleMap.affine`:
12 floats, 9 multiplications and 9 additions per sample); only a calibration whose gyro
correction depends on the specific force (kalibr's ``A`` matrix) takes the accelerometer on
that path.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.alignment import ALIGNED, GravityAligner
from rigid_body_attitude.core.estimation.calibration import ImuCalibration
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.rest import RestBiasEstimator, RestDetector

__all__ = ['AlignmentResult', 'Levelling', 'SampleMap', 'heading']

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]
FloatArray = NDArray[np.float64]
Affine = tuple[float, float, float, float, float, float, float, float, float, float, float,
               float]

#: Where the initial attitude came from (:attr:`AlignmentResult.source`).
FROM_GRAVITY, FROM_TIMEOUT, FROM_SCENE = 'gravity', 'timeout', 'scene'


def heading(attitude: Sequence[float]) -> float:
    """The yaw [rad] of a body → world attitude ``(w, x, y, z)`` about the world z axis (the
    ``z`` angle of its z-y'-x'' decomposition)."""
    w, x, y, z = attitude
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@dataclass(frozen=True)
class AlignmentResult:
    """How the strapdown integration started.

    Attributes:
        attitude: the initial body → world attitude ``(w, x, y, z)``.
        gyro_bias: the initial gyro bias estimate [rad/s], body frame (zeros if none).
        window_seconds: the rest averaged [s] (0 without levelling at rest).
        at_rest: whether the window was at rest (false after the timeout or without
            levelling).
        source: ``'gravity'`` (levelled at rest), ``'timeout'`` (levelled from the quietest
            window after ``align_timeout``) or ``'scene'`` (no accelerometer data or
            ``align_seconds`` 0: the scene's attitude).
        status: the alignment state in words (the diagnostics' ``alignment`` value).
    """

    attitude: Quat
    gyro_bias: Vec
    window_seconds: float
    at_rest: bool
    source: str
    status: str


class SampleMap:
    """Calibration and mount of every sample; the affine map of the hot path.

    Args:
        calibration: the sensor-frame correction (``None``: none).
        mount: rotation ``(w, x, y, z)`` of the sensor frame in the body frame (``None``:
            identity).
    """

    def __init__(self, calibration: ImuCalibration | None = None,
                 mount: Sequence[float] | None = None) -> None:
        self.calibration = calibration if calibration is not None else ImuCalibration()
        self.gyro_bias: Vec = (0.0, 0.0, 0.0)
        #: ``(I + Ê)⁻¹``, the inverse of the gyro's estimated intrinsic errors (body frame).
        self._intrinsic_inverse: FloatArray = np.eye(3)
        self.set_mount(mount)

    def set_mount(self, mount: Sequence[float] | None) -> None:
        """The rotation of the sensor frame in the body frame (``None``: identity); raises
        :class:`InputError` for a non-finite or zero quaternion."""
        if mount is None:
            self.mount: Quat = (1.0, 0.0, 0.0, 0.0)
        else:
            q = quaternion.normalize(quaternion.as_quaternion(mount, 'mount'))
            if q.shape != (4,):
                raise InputError(f'Expected the mount as 4 numbers (w, x, y, z), got {mount!r}')
            w, x, y, z = q.tolist()
            self.mount = (w, x, y, z)
        rotation = quaternion.to_matrix(np.array(self.mount))
        calibration = self.calibration
        r = rotation.ravel().tolist()
        self._rotation_floats = (r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8])
        self._gyro_matrix = rotation @ calibration.gyro_matrix
        self._gyro_offset = -(self._gyro_matrix @ calibration.gyro_bias)
        self._update_affine()

    def set_gyro_bias(self, bias: Vec, intrinsic: Sequence[float] | None = None) -> None:
        """The body-frame gyro bias estimate ``b`` [rad/s] the affine map subtracts and the
        estimate ``Ê`` of the intrinsic errors it undoes (9 numbers, row-major, body frame;
        ``None``: none): ``ω = (I + Ê)⁻¹ (ω_body − b)`` (module docstring)."""
        self.gyro_bias = bias
        inverse: FloatArray = np.eye(3)
        if intrinsic is not None:
            matrix: FloatArray = np.reshape(np.asarray(intrinsic, dtype=np.float64), (3, 3))
            inverse = np.asarray(np.linalg.inv(inverse + matrix), dtype=np.float64)
        self._intrinsic_inverse = inverse
        self._update_affine()

    def bias_removed(self, body_rate: Sequence[float]) -> Vec:
        """``(I + Ê)⁻¹ (ω_body − b)`` [rad/s] of a body rate of :meth:`body_sample`."""
        b = self.gyro_bias
        x, y, z = body_rate[0] - b[0], body_rate[1] - b[1], body_rate[2] - b[2]
        if self._intrinsic_identity:
            return x, y, z
        (k00, k01, k02), (k10, k11, k12), (k20, k21, k22) = self._intrinsic_inverse.tolist()
        return (k00 * x + k01 * y + k02 * z, k10 * x + k11 * y + k12 * z,
                k20 * x + k21 * y + k22 * z)

    def _update_affine(self) -> None:
        inverse = self._intrinsic_inverse
        self._intrinsic_identity = bool(np.array_equal(inverse, np.eye(3)))
        a = (inverse @ self._gyro_matrix).ravel().tolist()
        c = (inverse @ (self._gyro_offset - np.array(self.gyro_bias))).tolist()
        self.affine: Affine = (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8],
                               c[0], c[1], c[2])
        #: Whether the affine map is the identity (nothing to do per sample).
        self.identity = self.affine == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0,
                                        0.0)

    @property
    def uses_accelerometer(self) -> bool:
        """Whether the gyro correction depends on the specific force."""
        return self.calibration.uses_accelerometer

    def body_sample(self, rate: Sequence[float], accel: Sequence[float] | None
                    ) -> tuple[Vec, Vec | None]:
        """``(ω_body, a_body)`` of a measured sample, before the bias: rate [rad/s] and
        specific force [m/s²] (``None`` stays ``None``), body frame (plain float math)."""
        wx, wy, wz = rate
        calibration = self.calibration
        if accel is None:
            return self._rotated(calibration.correct_gyro(wx, wy, wz)), None
        omega, specific_force = calibration.correct(wx, wy, wz, accel[0], accel[1], accel[2])
        return self._rotated(omega), self._rotated(specific_force)

    def _rotated(self, vector: Vec) -> Vec:
        """``R v``: a sensor-frame vector in the body frame."""
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = self._rotation_floats
        x, y, z = vector
        return (r00 * x + r01 * y + r02 * z, r10 * x + r11 * y + r12 * z,
                r20 * x + r21 * y + r22 * z)


class Levelling:
    """The start of a strapdown run: wait for rest, level, estimate the bias (module docstring).

    Args:
        align_seconds: rest averaged [s].
        align_timeout: time after which a body that has not rested is levelled anyway [s].
        initial_yaw: heading of the levelled attitude [rad].
        world_axes: ``'enu'``, ``'ned'`` or ``'nwu'``.
        gyro_noise: known gyro noise per sample [rad/s] (0: measured).
        refine_bias_at_rest: refine the bias estimate at rest after levelling.
    """

    def __init__(self, align_seconds: float, align_timeout: float, initial_yaw: float,
                 world_axes: str, gyro_noise: float = 0.0,
                 refine_bias_at_rest: bool = False) -> None:
        self.align_seconds = align_seconds
        self.initial_yaw = initial_yaw
        self.refine_bias_at_rest = refine_bias_at_rest
        self.aligner = GravityAligner(align_seconds, align_timeout, initial_yaw, world_axes,
                                      RestDetector(gyro_noise=gyro_noise))
        self.bias_estimator = RestBiasEstimator(initial_seconds=align_seconds)
        self.last_ns: int | None = None
        #: Samples the aligner took in the current run.
        self.samples = 0

    def reset(self) -> None:
        """Wait for rest again (``~/reset``), yaw from ``initial_yaw``."""
        self.aligner.reset()
        self.aligner.initial_yaw = self.initial_yaw
        self.last_ns = None
        self.samples = 0

    def set_yaw(self, yaw: float) -> None:
        """The heading of the attitude the levelling will give [rad] (from ``set_pose``)."""
        self.aligner.initial_yaw = yaw

    def interval(self, stamp_ns: int, max_dt_ns: int, threshold_ns: int,
                 constant_dt: float) -> float | None:
        """The interval [s] a sample stamped ``stamp_ns`` stands for, 0 for a new baseline
        (first sample, a gap longer than ``max_dt``, a jump back beyond the threshold), or
        ``None`` for a stale stamp (not newer, within the threshold)."""
        last, self.last_ns = self.last_ns, stamp_ns
        if last is None:
            return 0.0
        step_ns = stamp_ns - last
        if 0 < step_ns <= max_dt_ns:
            return constant_dt if constant_dt > 0.0 else step_ns * 1e-9
        if step_ns <= 0 and -step_ns <= threshold_ns:
            self.last_ns = last
            return None
        return 0.0

    def add(self, rate: Vec, accel: Vec, dt: float) -> bool:
        """One body-frame sample (rate [rad/s], specific force [m/s²]) of interval ``dt``
        [s]; returns whether the levelling is done."""
        self.samples += 1
        if dt <= 0.0:
            return False
        return self.aligner.update(rate[0], rate[1], rate[2], accel[0], accel[1], accel[2], dt)

    def result(self) -> AlignmentResult:
        """The levelled attitude and bias (once :meth:`add` returned true)."""
        aligner = self.aligner
        at_rest = aligner.state == ALIGNED
        self.bias_estimator.reset(aligner.gyro_bias, self.align_seconds if at_rest else 0.0)
        return AlignmentResult(
            attitude=aligner.attitude, gyro_bias=aligner.gyro_bias,
            window_seconds=self.align_seconds if at_rest else 0.0, at_rest=at_rest,
            source=FROM_GRAVITY if at_rest else FROM_TIMEOUT, status=aligner.status)

    @property
    def status(self) -> str:
        """The aligner's state in words."""
        return self.aligner.status

    def refine(self, rate: Vec, accel: Vec, dt: float) -> Vec | None:
        """After levelling, with ``refine_bias_at_rest``: feed the rest detector a body-frame
        sample (before the bias); returns the new bias estimate [rad/s] when the body is at
        rest, else ``None``."""
        detector = self.aligner.detector
        if dt <= 0.0 or not detector.update(rate[0], rate[1], rate[2], accel[0], accel[1],
                                            accel[2], dt):
            return None
        bias = self.bias_estimator.update(True, detector.delayed_gyro, dt)
        detector.set_gyro_bias(bias)
        return bias
