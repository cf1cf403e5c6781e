"""The gyro session: strapdown integration of gyro samples, the node's hot path.

Per sample (:meth:`GyroSession.gyro`): the stamp is checked (``nanosec`` in ``[0, 1e9)``,
``sec`` non-negative; a zero stamp is refused while header stamps are used) or replaced by the
receive time (``use_header_stamps`` false); the sensor-frame sample is calibrated, rotated into
the body frame and, at start, levelled (:mod:`~rigid_body_attitude.session.levelling`: nothing
is integrated or published until then); the bias estimate is subtracted; the stream rules
decide; when the state moved the attitude goes to the sink stamped with the time used. At each
tick (:meth:`GyroSession.tick`) energy and angular momentum of the last attitude go to the
sink, once per attitude published.

Samples without accelerometer data (``angular_velocity`` input, or an Imu whose acceleration
is all zeros) and ``align_seconds`` 0 start from the scene's attitude at once (said once, at
INFO). After levelling the levelled attitude is the initial state: a time jump back (a
looping bag) returns to it; ``~/reset`` (:meth:`GyroSession.reset`) levels again.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from rigid_body_attitude.core.calibration import load_calibration
from rigid_body_attitude.core.propagator import GyroPropagator
from rigid_body_attitude.core.scene import Scene
from rigid_body_attitude.session.base import LEVEL_INFO, OutputSink, Session
from rigid_body_attitude.session.levelling import (
    FROM_SCENE, AlignmentResult, Levelling, SampleMap, heading, rpy_quaternion)
from rigid_body_attitude.session.reports import (
    LEVEL_WARN, NOT_ALIGNED, StrapdownState, gyro_bias_text)
from rigid_body_attitude.session.stream import GyroStream, INTEGRATED, Outcome
from rigid_body_attitude.session.times import NANOSECONDS_PER_SECOND, split_ns, stamp_problem

__all__ = ['GyroSession']

_DETAIL = {
    'non_finite': 'a non-finite rate (NaN or Inf); sample ignored',
    'out_of_range': 'a rate above max_angular_rate; sample ignored',
    'stale_stamp': 'a stamp not newer than the last one; sample ignored',
    'outlier_stamp': 'a stamp off the time line that the next samples did not confirm; '
                     'ignored',
    'gap': 'a gap longer than max_dt, confirmed by the next samples; not integrated across, '
           'attitude held',
}
_HINT = {'stale_stamp': 'use_header_stamps', 'out_of_range': 'max_angular_rate',
         'outlier_stamp': 'max_dt', 'gap': 'max_dt'}


_NO_ACCELEROMETER = ('not levelled: no accelerometer data (angular_velocity input or zero '
                     'linear_acceleration); initial attitude from the scene or set_pose')
_LEVELLING_OFF = ('not levelled: align_seconds is 0; initial attitude from the scene or '
                  'set_pose')


class GyroSession(Session):
    """Strapdown integration of a gyro scene's samples.

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
    #: Whether :meth:`_after_step` is called after each integrated sample.
    wants_steps = False

    def __init__(self, scene: Scene, values: Mapping[str, Any], sink: OutputSink,
                 clock_ns: Callable[[], int], monotonic: Callable[[], float]) -> None:
        """The scene's gyro propagator and stream, with the parameters ``values``."""
        self.propagator = GyroPropagator(scene)
        self.stream = GyroStream(self.propagator, values['max_dt'],
                                 values['time_jump_threshold'])
        self._fresh_output = False
        self._output_sec = self._output_nanosec = 0
        calibration = (load_calibration(values['calibration_file'],
                                        values['calibration_imu_key'])
                       if values['calibration_file'] else None)
        mount_rpy = values['mount_rpy']
        self._mount_given = bool(mount_rpy)
        self.sample_map = SampleMap(calibration, rpy_quaternion(*mount_rpy) if mount_rpy
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
        self._told_no_accelerometer = False
        self._align_samples = 0
        super().__init__(scene, values, sink, clock_ns, monotonic)

    # -- the mount and the alignment (the session API of the ROS adapter) -------------------

    def mount_needed(self, sensor_frame: str) -> bool:
        """Whether the mount must come from TF: ``mount_rpy`` is not set and the Imu's frame
        ``sensor_frame`` differs from ``body_frame``."""
        return not self._mount_given and sensor_frame != self.body_frame

    def set_mount(self, q_body_sensor: tuple[float, float, float, float] | None) -> None:
        """The rotation ``(w, x, y, z)`` mapping sensor-frame vectors into the body frame
        (``None``: identity); raises :class:`~rigid_body_attitude.core.errors.InputError` for
        a zero or non-finite quaternion."""
        self.sample_map.set_mount(q_body_sensor)
        self._update_paths()

    @property
    def alignment_done(self) -> bool:
        """Whether the integration has started (levelled, or from the scene)."""
        return not self._aligning

    def _after_step(self, q_before: tuple[float, float, float, float],
                    rate_body: tuple[float, float, float], dt: float) -> None:
        """After each integrated sample when :attr:`wants_steps`: the attitude at the start
        of the step, the bias-corrected body rate held over it [rad/s] and its length [s]."""

    def _update_paths(self) -> None:
        """Choose the per-sample path: inline affine map, or the general one."""
        refine = (self.levelling is not None and self.levelling.refine_bias_at_rest
                  and self.alignment is not None and self.alignment.source != FROM_SCENE)
        self._special = self._aligning or self.sample_map.uses_accelerometer or refine
        self._affine = None if self.sample_map.identity else self.sample_map.affine

    def apply(self, values: Mapping[str, Any]) -> None:
        """Take the run-time parameters."""
        super().apply(values)
        stream = self.stream
        stream.max_dt = values['max_dt']
        stream.time_jump_threshold = values['time_jump_threshold']
        stream.constant_dt = values['constant_dt']
        stream.max_angular_rate = values['max_angular_rate']
        stream.count_missed = values['use_header_stamps']
        self.body_frame: str = values['body_frame']

    def gyro(self, sec: int, nanosec: int, rate: Sequence[float],
             imu: bytes | None = None, accel: Sequence[float] | None = None) -> bool:
        """One gyro sample stamped ``(sec, nanosec)``: rate ``rate`` [rad/s] and specific
        force ``accel`` [m/s²] (``None``: none) in the sensor frame.

        ``imu``: the serialized ``sensor_msgs/msg/Imu`` the sample came from, if it came from
        one; it goes to the sink with the attitude (for ``imu/data``). Returns whether the
        attitude went to the sink (stamped :attr:`output_stamp`).
        """
        if not self.use_header_stamps:
            sec, nanosec = split_ns(self.clock_ns())
        elif nanosec >= NANOSECONDS_PER_SECOND or (sec <= 0 and (sec < 0 or not nanosec)):
            return self._bad_stamp(sec, nanosec)
        if self._special:
            mapped = self._special_sample(sec, nanosec, rate, accel)
            if mapped is None:
                return False
            rate = mapped
        elif self._affine is not None:
            try:
                wx, wy, wz = rate
            except (TypeError, ValueError):
                pass  # the stream refuses it
            else:
                a00, a01, a02, a10, a11, a12, a20, a21, a22, c0, c1, c2 = self._affine
                rate = (a00 * wx + a01 * wy + a02 * wz + c0, a10 * wx + a11 * wy + a12 * wz + c1,
                        a20 * wx + a21 * wy + a22 * wz + c2)
        if self.wants_steps:
            return self._stepped(sec, nanosec, rate, imu)
        stream = self.stream
        outliers = stream.outliers if stream.pending else -1  # a jump waits: watch for them
        outcome = stream.add(sec * NANOSECONDS_PER_SECOND + nanosec, rate)
        if outliers >= 0 and stream.outliers != outliers:
            self.warn('outlier_stamp', f'gyro: {_DETAIL["outlier_stamp"]} (parameter `max_dt`)')
        if outcome is not INTEGRATED:  # the common case needs no further look
            if outcome.reason:
                self._rejected(outcome)
            if not outcome.moved:
                return False
        attitude = self.tracker.attitude(self.propagator)
        if not math.isfinite(attitude[0] + attitude[1] + attitude[2] + attitude[3]):
            return self._non_finite_result()
        self.sink.attitude(sec, nanosec, attitude, imu)
        self._output_sec, self._output_nanosec = sec, nanosec
        self._fresh_output = True
        return True

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
        try:
            body_rate, body_accel = self.sample_map.body_sample(rate, accel)
        except (TypeError, ValueError):
            return rate  # not 3 numbers: the stream refuses it
        levelling = self.levelling
        if levelling is not None and levelling.refine_bias_at_rest and body_accel is not None:
            stream = self.stream
            step_ns = sec * NANOSECONDS_PER_SECOND + nanosec - stream.last_ns
            dt = step_ns * 1e-9 if 0 < step_ns <= stream.max_dt_ns else 0.0
            if math.isfinite(sum(body_rate) + sum(body_accel)):
                bias = levelling.refine(body_rate, body_accel, dt)
                if bias is not None:
                    self.sample_map.set_gyro_bias(bias)
        b = self.sample_map.gyro_bias
        return body_rate[0] - b[0], body_rate[1] - b[1], body_rate[2] - b[2]

    def _levelling_sample(self, stamp_ns: int, rate: Sequence[float],
                          accel: Sequence[float]) -> Sequence[float] | None:
        """A sample while levelling: checked, then to the aligner; the one that completes
        the levelling is returned (bias-corrected) as the integration's first sample."""
        levelling = self.levelling
        assert levelling is not None
        reason = self._sample_problem(rate, accel)
        if reason:
            self.rejections[reason] += 1
            self.warn(reason, f'gyro: {_DETAIL[reason]} (while levelling)')
            return None
        stream = self.stream
        dt = levelling.interval(stamp_ns, stream.max_dt_ns, stream.threshold_ns,
                                stream.constant_dt)
        if dt is None:
            self.rejections['stale_stamp'] += 1
            self.warn('stale_stamp', f'gyro: {_DETAIL["stale_stamp"]} (while levelling)')
            return None
        body_rate, body_accel = self.sample_map.body_sample(rate, accel)
        assert body_accel is not None
        if not levelling.add(body_rate, body_accel, dt):
            self._align_samples += 1
            return None
        self._aligned(levelling.result())
        b = self.sample_map.gyro_bias
        return body_rate[0] - b[0], body_rate[1] - b[1], body_rate[2] - b[2]

    def _sample_problem(self, rate: Sequence[float], accel: Sequence[float]) -> str:
        """``'non_finite'``, ``'out_of_range'`` or ``''`` for a sample to level with."""
        try:
            wx, wy, wz = (float(value) for value in rate)
            ax, ay, az = (float(value) for value in accel)
        except (TypeError, ValueError):
            return 'non_finite'
        if not math.isfinite(wx + wy + wz + ax + ay + az):
            return 'non_finite'
        if not wx * wx + wy * wy + wz * wz <= self.stream.max_rate_squared:
            return 'out_of_range'
        return ''

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
                 position: tuple[float, float, float]) -> None:
        """Re-initialise the attitude; while levelling, its heading is the levelled yaw."""
        accepted = self.poses_accepted
        super().set_pose(frame_id, attitude, position)
        if self._aligning and self.levelling is not None and self.poses_accepted > accepted:
            self.levelling.set_yaw(heading(self.propagator.state.attitude_tuple()))

    def alignment_text(self) -> str:
        """The alignment state in words (the diagnostics' ``alignment`` value)."""
        if self._aligning:
            if self.levelling is None or not self.levelling.samples:
                return 'not started: no gyro sample yet'
            return f'aligning: {self.levelling.status}'
        return self.alignment.status if self.alignment is not None else NOT_ALIGNED

    def strapdown_state(self) -> StrapdownState:
        """The alignment and the bias estimate for the reports (levelling: WARN, nothing is
        integrated yet)."""
        levelling = self._aligning and self.levelling is not None and self.levelling.samples > 0
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

    def _stepped(self, sec: int, nanosec: int, rate: Sequence[float],
                 imu: bytes | None) -> bool:
        """:meth:`gyro`'s integration with :meth:`_after_step` after each integrated step."""
        stream = self.stream
        outliers = stream.outliers if stream.pending else -1
        q_before = self.propagator.state.attitude_tuple()
        last_ns = stream.last_ns
        stamp_ns = sec * NANOSECONDS_PER_SECOND + nanosec
        outcome = stream.add(stamp_ns, rate)
        if outliers >= 0 and stream.outliers != outliers:
            self.warn('outlier_stamp', f'gyro: {_DETAIL["outlier_stamp"]} (parameter `max_dt`)')
        if outcome is INTEGRATED:
            x, y, z = rate
            dt = stream.constant_dt if stream.constant_dt > 0.0 else (stamp_ns - last_ns) * 1e-9
            self._after_step(q_before, (float(x), float(y), float(z)), dt)
        return self._outcome(outcome, sec, nanosec, imu)

    def _outcome(self, outcome: Outcome, sec: int, nanosec: int, imu: bytes | None) -> bool:
        """Publish the attitude when the state moved (as :meth:`gyro` does inline)."""
        if outcome is not INTEGRATED:
            if outcome.reason:
                self._rejected(outcome)
            if not outcome.moved:
                return False
        attitude = self.tracker.attitude(self.propagator)
        if not math.isfinite(attitude[0] + attitude[1] + attitude[2] + attitude[3]):
            return self._non_finite_result()
        self.sink.attitude(sec, nanosec, attitude, imu)
        self._output_sec, self._output_nanosec = sec, nanosec
        self._fresh_output = True
        return True

    @property
    def output_stamp(self) -> tuple[int, int]:
        """``(sec, nanosec)`` of the last attitude that went to the sink."""
        return self._output_sec, self._output_nanosec

    def _bad_stamp(self, sec: int, nanosec: int) -> bool:
        if sec == 0 and nanosec == 0:
            self.rejections['zero_stamp'] += 1
            self.warn('zero_stamp', 'gyro: a zero header stamp; sample ignored (unstamped '
                                    'input: set use_header_stamps:=false)')
            return False
        problem = stamp_problem(sec, nanosec)
        self.rejections['invalid_stamp'] += 1
        self.warn('invalid_stamp', f'gyro: an invalid header stamp ({problem}); sample ignored '
                                   f'(parameter `use_header_stamps`)')
        return False

    def _rejected(self, outcome: Outcome) -> None:
        reason = outcome.reason
        if outcome.reset:  # once per jump, never throttled
            self.sink.log(LEVEL_WARN, f'gyro: stamps jumped back by more than '
                                      f'time_jump_threshold ({self.stream.time_jump_threshold:g}'
                                      f' s; looping bag?), confirmed by the next samples; reset '
                                      f'to the initial state of scene {self.scene.name!r}')
            return
        hint = _HINT.get(reason)
        self.warn(reason, f'gyro: {_DETAIL[reason]}'
                          + (f' (parameter `{hint}`)' if hint else ''))

    def _non_finite_result(self) -> bool:
        """An integration whose result is not finite: refused, counted, the scene restarts."""
        self.rejections['non_finite_result'] += 1
        self.error(f'gyro: integration gave a non-finite attitude; reset to the initial state '
                   f'of scene {self.scene.name!r} (parameter `integrator`)')
        self.stream.reset()
        return False

    def tick(self) -> None:
        """The output timer: energy and angular momentum of the last attitude published."""
        if not self._fresh_output:
            return
        self._fresh_output = False
        if self.sink.wants_invariants():
            x, y, z = self.propagator.world_momentum().tolist()
            self.sink.invariants(self._output_sec, self._output_nanosec,
                                 self.propagator.energy(), (x, y, z))

    def reset(self) -> None:
        """Back to the scene's initial attitude and level again (with levelling); the next
        sample is a new baseline."""
        if self.levelling is not None:
            self.levelling.reset()
            self.propagator.scene = self.scene
            self.sample_map.set_gyro_bias((0.0, 0.0, 0.0))
            self.alignment = None
            self._aligning = True
            self._update_paths()
        self.stream.reset()

    def accepted_count(self) -> int:
        """Gyro samples (levelling included) and poses used so far."""
        return self.stream.accepted + self.poses_accepted + self._align_samples

    def missed_count(self) -> int:
        """Samples lost upstream so far (from the stamp spacing)."""
        return self.stream.missed_samples

    def step_text(self) -> str:
        """``constant_dt`` when set, else the stamps."""
        constant_dt = self.stream.constant_dt
        return f'{constant_dt:g} (constant_dt)' if constant_dt > 0.0 else 'gyro stamps'

    def time_s(self) -> float:
        """The stamp of the last attitude published [s]."""
        return self._output_sec + self._output_nanosec * 1e-9

    def _input_rejections(self) -> list[Counter[str]]:
        return [self.stream.rejected]

    def _pending_count(self) -> int:
        return len(self.stream.pending)


def _vector_text(vector: Sequence[float]) -> str:
    return ' '.join(f'{float(value):.9g}' for value in vector)
