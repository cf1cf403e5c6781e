"""The start of a real IMU's strapdown run: mount, calibration, levelling, bias, diagnostics.

:class:`ImuStart` is the part of :class:`~rigid_body_attitude.session.gyro.GyroSession` that
takes a sample off the inline hot path: while the session levels from gravity, when the
calibration's gyro correction takes the accelerometer, and with ``refine_bias_at_rest``
(:mod:`~rigid_body_attitude.session.levelling` says what each step does). It also gives the
ROS adapter the mount (:meth:`ImuStart.mount_needed`, :meth:`ImuStart.set_mount`) and the
reports the alignment state and the bias estimate.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from rigid_body_attitude.core.attitude.quaternion import from_rpy
from rigid_body_attitude.core.estimation.calibration import (
    calibration_noise, calibration_summary, calibration_values, load_calibration)
from rigid_body_attitude.core.propagator import GyroPropagator
from rigid_body_attitude.core.estimation.rest import SPECIFIC_FORCE_LIMIT
from rigid_body_attitude.msgs.untrusted import quoted
from rigid_body_attitude.session.base import LEVEL_INFO, Session
from rigid_body_attitude.session.levelling import (
    FROM_SCENE, AlignmentResult, Levelling, SampleMap, heading)
from rigid_body_attitude.session.reports import (
    LEVEL_WARN, NOT_ALIGNED, StrapdownState, gyro_bias_text)
from rigid_body_attitude.session.stream import GyroStream
from rigid_body_attitude.session.times import NANOSECONDS_PER_SECOND

__all__ = ['ImuStart', 'REJECTION_DETAIL', 'frame_refused']

#: Why a gyro sample was ignored, by rejection reason (the warning texts).
REJECTION_DETAIL = {
    'non_finite': 'a non-finite rate or specific force (NaN or Inf); sample ignored',
    'out_of_range': 'a rate above max_angular_rate; sample ignored',
    'accel_out_of_range': f'an accelerometer specific force out of range (above '
                          f'{SPECIFIC_FORCE_LIMIT:g} m/s², beyond any accelerometer); sample '
                          f'ignored',
    'stale_stamp': 'a stamp not newer than the last one; sample ignored',
    'outlier_stamp': 'a stamp off the time line that the next samples did not confirm; '
                     'ignored',
    'gap': 'a gap longer than max_dt, confirmed by the next samples; not integrated across, '
           'attitude held',
    'awaiting_attitude': 'the filter starts at its first attitude_measurement; sample not '
                         'integrated',
}
_NO_ACCELEROMETER = ('not levelled: no accelerometer data (angular_velocity input or zero '
                     'linear_acceleration); initial attitude from the scene or set_pose')
_SPECIFIC_FORCE_LIMIT_SQUARED = SPECIFIC_FORCE_LIMIT * SPECIFIC_FORCE_LIMIT
_LEVELLING_OFF = ('not levelled: align_seconds is 0; initial attitude from the scene or '
                  'set_pose')


class ImuStart(Session):
    """Calibration, mount, levelling and bias of a gyro session's samples.

    Read-only parameters taken at start: ``mount_rpy``, ``world_axes``, ``align_seconds``,
    ``align_timeout``, ``initial_yaw``, ``refine_bias_at_rest``, ``calibration_file`` and
    ``calibration_imu_key`` (a bad calibration file raises
    :class:`~rigid_body_attitude.core.errors.CalibrationError`).

    Attributes:
        on_aligned: called with the :class:`~.levelling.AlignmentResult` each time the
            start of the integration is settled (levelled, or from the scene).
        alignment: the last :class:`~.levelling.AlignmentResult` (``None`` while aligning).
    """

    propagator: GyroPropagator
    stream: GyroStream
    body_frame: str
    #: The IMU's frame: the first sample frame with a known mount (``mount_rpy``, being
    #: ``body_frame``, a static transform); ``None`` until then. Samples in another frame are
    #: refused (:meth:`foreign_frame`).
    imu_frame: str | None = None
    #: Gyro topic -> the IMU's frame, once a sample on it came in it (:func:`frame_refused`).
    topic_frames: dict[str, str]
    #: The body specific force [m/s²] of the last sample on the general path (unchecked).
    body_specific_force: tuple[float, float, float] | None = None

    def _start_imu(self, values: Mapping[str, Any]) -> None:
        """Read the calibration file and set up mount and levelling from ``values``."""
        calibration = (load_calibration(values['calibration_file'],
                                        values['calibration_imu_key'])
                       if values['calibration_file'] else None)
        self._calibration = calibration
        mount_rpy = values['mount_rpy']
        self._mount_given = bool(mount_rpy)
        self.topic_frames = {}
        self.sample_map = SampleMap(calibration, from_rpy(mount_rpy).tolist() if mount_rpy
                                    else None)
        gyro_noise = calibration.noise.gyro_sigma() if calibration is not None else None
        self.levelling = (Levelling(values['align_seconds'], values['align_timeout'],
                                    values['initial_yaw'], values['world_axes'],
                                    gyro_noise or 0.0, values['refine_bias_at_rest'])
                          if values['align_seconds'] > 0.0 else None)
        self.on_aligned: Callable[[AlignmentResult], None] | None = None
        self.alignment: AlignmentResult | None = None
        self._aligning = True  # until the first sample says how to start
        self._special = True  # aligning, or a sample map the inline path cannot do
        self._affine: tuple[float, ...] | None = None
        self._told_no_accelerometer, self._align_samples, self._refused_levelling = False, 0, 0

    def tell_calibration(self) -> None:
        """The INFO line naming the calibration file, its kind, the IMU key and the terms
        applied (once, at start; nothing without a file)."""
        if self._calibration is not None:
            self.sink.log(LEVEL_INFO, calibration_summary(self._calibration))

    def calibration_values(self) -> list[tuple[str, str]]:
        """The calibration in ``/diagnostics`` (:func:`calibration_values`)."""
        return calibration_values(self._calibration)

    def calibration_noise(self) -> dict[str, float]:
        """The noise figures the calibration file gives (:func:`calibration_noise`)."""
        return calibration_noise(self._calibration)

    def _restart_levelling(self) -> None:
        """``~/reset`` with levelling: the scene's attitude, no bias, level again."""
        if self.levelling is None:
            return
        self.levelling.reset()
        self._refused_levelling = 0
        self.propagator.scene = self.scene
        self.sample_map.set_gyro_bias((0.0, 0.0, 0.0))
        self.alignment = None
        self._aligning = True
        self._update_paths()

    # -- the mount and the alignment (the session API of the ROS adapter) -------------------

    def mount_needed(self, sensor_frame: str) -> bool:
        """Whether the mount must come from TF: ``mount_rpy`` is not set and the Imu's frame
        ``sensor_frame`` (not empty) differs from ``body_frame``."""
        return not self._mount_given and bool(sensor_frame) and sensor_frame != self.body_frame

    def foreign_frame(self, frame: str) -> None:
        """A gyro sample in ``frame``, not :attr:`imu_frame`: refused (``foreign_frame``)."""
        self.rejections['foreign_frame'] += 1
        self.warn('foreign_frame', f'gyro: a sample in frame {quoted(frame)}, not the IMU '
                                   f'frame {quoted(self.imu_frame or "")} (the first frame '
                                   f'with a known mount; one IMU per topic); sample ignored')

    def set_mount(self, q_body_sensor: tuple[float, float, float, float] | None) -> None:
        """The rotation ``(w, x, y, z)`` mapping sensor-frame vectors into the body frame
        (``None``: identity); raises :class:`~rigid_body_attitude.core.errors.InputError` for
        a zero or non-finite quaternion."""
        self.sample_map.set_mount(q_body_sensor)
        self._update_paths()
        self._tell_mount()

    def _tell_mount(self) -> None:
        """Give the sink the mount for ``imu/data`` (``None``: identity, nothing to compose)."""
        mount = self.sample_map.mount
        self.sink.sensor_mount(None if mount == (1.0, 0.0, 0.0, 0.0) else mount)

    @property
    def alignment_done(self) -> bool:
        """Whether the integration has started (levelled, or from the scene)."""
        return not self._aligning

    def _update_paths(self) -> None:
        """Choose the per-sample path: inline affine map, or the general one."""
        refine = (self.levelling is not None and self.levelling.refine_bias_at_rest
                  and self.alignment is not None and self.alignment.source != FROM_SCENE)
        self._special = self._aligning or self.sample_map.uses_accelerometer or refine
        self._affine = None if self.sample_map.identity else self.sample_map.affine

    # -- the general path: levelling, accelerometer-dependent calibration, bias at rest ----

    def _special_sample(self, sec: int, nanosec: int, rate: Sequence[float],
                        accel: Sequence[float] | None) -> Sequence[float] | None:
        """The body rate less the bias of a sample off the inline path, or ``None`` when the
        sample went to the levelling (or was refused there)."""
        if accel is not None and accel[0] == 0.0 and accel[1] == 0.0 and accel[2] == 0.0:
            accel = None  # an Imu without accelerometer data
        if self._aligning:
            if accel is None or self.levelling is None:
                self._start_from_scene()
            else:
                return self._levelling_sample(sec * NANOSECONDS_PER_SECOND + nanosec, rate,
                                              accel)
        if accel is not None and (self.sample_map.uses_accelerometer or (
                self.levelling is not None and self.levelling.refine_bias_at_rest)):
            reason = _accel_problem(accel)
            if reason:  # the accelerometer takes part: refused before it changes anything
                self._refuse(reason, '')
                return None
        try:
            body_rate, body_accel = self.sample_map.body_sample(rate, accel)
        except (TypeError, ValueError):
            return rate  # not 3 numbers: the stream refuses it
        self.body_specific_force = body_accel
        levelling = self.levelling
        if levelling is not None and levelling.refine_bias_at_rest and body_accel is not None:
            stream = self.stream
            step_ns = sec * NANOSECONDS_PER_SECOND + nanosec - stream.last_ns
            dt = step_ns * 1e-9 if 0 < step_ns <= stream.max_dt_ns else 0.0
            if math.isfinite(sum(body_rate) + sum(body_accel)):
                bias = levelling.refine(body_rate, body_accel, dt)
                if bias is not None:
                    self.sample_map.set_gyro_bias(bias)
        return self.sample_map.bias_removed(body_rate)

    def _levelling_sample(self, stamp_ns: int, rate: Sequence[float],
                          accel: Sequence[float]) -> Sequence[float] | None:
        """A sample while levelling: checked, then to the aligner; the one that completes
        the levelling is returned (bias-corrected) as the integration's first sample."""
        levelling = self.levelling
        assert levelling is not None
        reason = _sample_problem(rate, accel, self.stream.max_rate_squared)
        if reason:
            self._refused_levelling += 1
            self._refuse(reason, ' (while levelling)')
            return None
        stream = self.stream
        dt = levelling.interval(stamp_ns, stream.max_dt_ns, stream.threshold_ns,
                                stream.constant_dt)
        if dt is None:
            self._refused_levelling += 1
            self._refuse('stale_stamp', ' (while levelling)')
            return None
        body_rate, body_accel = self.sample_map.body_sample(rate, accel)
        assert body_accel is not None
        if not levelling.add(body_rate, body_accel, dt):
            self._align_samples += 1
            return None
        self._aligned(levelling.result())
        return self.sample_map.bias_removed(body_rate)

    def _refuse(self, reason: str, context: str) -> None:
        """A sample refused by the session before the stream saw it: counted by ``reason``,
        warned about (throttled), and told to the stream (never counted as missed)."""
        self.rejections[reason] += 1
        self.stream.refused_samples += 1
        self.warn(reason, f'gyro: {REJECTION_DETAIL[reason]}{context}')

    def _aligned(self, result: AlignmentResult) -> None:
        """Levelling done: the levelled attitude is the initial state; the bias is set."""
        self.alignment = result
        self.sample_map.set_gyro_bias(result.gyro_bias)
        self.propagator.scene = replace(self.scene,
                                        initial_attitude=np.array(result.attitude))
        self.stream.reset()
        self._aligning = False
        self._update_paths()
        w, x, y, z = result.attitude
        self.sink.log(LEVEL_INFO if result.at_rest else LEVEL_WARN,
                      f'gyro: {result.status}; initial attitude (w, x, y, z) '
                      f'({w:.6f}, {x:.6f}, {y:.6f}, {z:.6f}), gyro bias [rad/s] '
                      f'{_vector_text(result.gyro_bias)}')
        if self.on_aligned is not None:
            self.on_aligned(result)

    def _start_from_scene(self) -> None:
        """No levelling: start at once from the scene's attitude (or set_pose's)."""
        status = _LEVELLING_OFF if self.levelling is None else _NO_ACCELEROMETER
        attitude = self.propagator.state.attitude_tuple()
        self.alignment = AlignmentResult(attitude=attitude, gyro_bias=(0.0, 0.0, 0.0),
                                         window_seconds=0.0, at_rest=False, source=FROM_SCENE,
                                         status=status)
        self._aligning = False
        self._update_paths()
        if self.levelling is not None and not self._told_no_accelerometer:
            self._told_no_accelerometer = True
            self.sink.log(LEVEL_INFO, f'gyro: {status}')
        if self.on_aligned is not None:
            self.on_aligned(self.alignment)

    def set_pose(self, frame_id: str, attitude: tuple[float, float, float, float],
                 position: tuple[float, float, float],
                 covariance: Sequence[float] | None = None) -> None:
        """Re-initialise the attitude (and its ``covariance``, as the base session does);
        while levelling, its heading is the levelled yaw."""
        accepted = self.poses_accepted
        super().set_pose(frame_id, attitude, position, covariance)
        if self._aligning and self.levelling is not None and self.poses_accepted > accepted:
            self.levelling.set_yaw(heading(self.propagator.state.attitude_tuple()))

    def alignment_text(self) -> str:
        """The alignment state in words (the diagnostics' ``alignment`` value)."""
        return _alignment_text(self)

    def strapdown_state(self) -> StrapdownState:
        """The alignment and the bias estimate for the reports (levelling: WARN, nothing is
        integrated yet)."""
        levelling = self._aligning and self.levelling is not None and (
            self.levelling.samples > 0 or self._refused_levelling > 0)
        return StrapdownState(self.alignment_text(), self.bias_text(), levelling)

    def bias_text(self) -> str:
        """The gyro bias estimate [rad/s, body frame] in words (the diagnostics' value)."""
        scene_bias = gyro_bias_text(self.propagator)
        alignment = self.alignment
        if self._aligning and self.levelling is not None and self.levelling.samples:
            return 'estimating (levelling)'
        if alignment is None or alignment.source == FROM_SCENE:
            return scene_bias
        refined = ', refined at rest' if self.levelling and (
            self.levelling.refine_bias_at_rest) else ''
        text = f'{_vector_text(self.sample_map.gyro_bias)} (levelling{refined})'
        return text if scene_bias == 'none' else f'{text}; scene gyro_bias {scene_bias}'


def frame_refused(start: ImuStart, topic: str, frame: str) -> bool:
    """Whether a gyro sample on ``topic`` in ``frame`` is refused (``foreign_frame``,
    counted) once ``start.imu_frame`` is known: one IMU per topic. Until a sample on ``topic``
    came in the IMU's frame, samples in a frame that needs no mount (an empty frame,
    ``body_frame``) are taken too; after it, only those in the IMU's frame."""
    expected = start.topic_frames.get(topic)
    if expected is None and start.imu_frame is not None:
        if frame == start.imu_frame:
            start.topic_frames[topic] = frame
            return False
        refused = start.mount_needed(frame)
    else:
        refused = expected is not None and frame != expected
    if refused:
        start.foreign_frame(frame)
    return refused


def _alignment_text(start: ImuStart) -> str:
    """:meth:`ImuStart.alignment_text`: levelling, waiting, or the alignment's status."""
    if start._aligning:
        if start.levelling is not None and not start.levelling.samples and (
                start._refused_levelling):
            return (f'aligning: no usable sample yet ({start._refused_levelling} refused, '
                    f'see the rejected counts)')
        if start.levelling is None or not start.levelling.samples:
            return 'not started: no gyro sample yet'
        return f'aligning: {start.levelling.status}'
    return start.alignment.status if start.alignment is not None else NOT_ALIGNED


def _sample_problem(rate: Sequence[float], accel: Sequence[float],
                    max_rate_squared: float) -> str:
    """``'non_finite'``, ``'out_of_range'`` (rate), ``'accel_out_of_range'`` or ``''`` for a
    sample to level with."""
    try:
        wx, wy, wz = (float(value) for value in rate)
    except (TypeError, ValueError):
        return 'non_finite'
    if not (math.isfinite(wx) and math.isfinite(wy) and math.isfinite(wz)):
        return 'non_finite'  # each: the sum of finite values may overflow
    reason = _accel_problem(accel)
    if reason:
        return reason
    if not wx * wx + wy * wy + wz * wz <= max_rate_squared:
        return 'out_of_range'
    return ''


def _accel_problem(accel: Sequence[float]) -> str:
    """``'non_finite'``, ``'accel_out_of_range'`` (a magnitude above
    :data:`~rigid_body_attitude.core.estimation.rest.SPECIFIC_FORCE_LIMIT`) or ``''`` for a
    specific force [m/s²]."""
    try:
        ax, ay, az = (float(value) for value in accel)
    except (TypeError, ValueError):
        return 'non_finite'
    if not (math.isfinite(ax) and math.isfinite(ay) and math.isfinite(az)):
        return 'non_finite'  # each: the sum of finite values may overflow
    # Each component first: a square that overflows is out of range, never NaN.
    if not (abs(ax) <= SPECIFIC_FORCE_LIMIT and abs(ay) <= SPECIFIC_FORCE_LIMIT
            and abs(az) <= SPECIFIC_FORCE_LIMIT
            and ax * ax + ay * ay + az * az <= _SPECIFIC_FORCE_LIMIT_SQUARED):
        return 'accel_out_of_range'
    return ''


def _vector_text(vector: Sequence[float]) -> str:
    return ' '.join(f'{float(value):.9g}' for value in vector)
