"""The gyro session: strapdown integration of gyro samples, the node's hot path.

Per sample (:meth:`GyroSession.gyro`): the stamp is checked (``nanosec`` in ``[0, 1e9)``,
``sec`` non-negative; a zero stamp is refused while header stamps are used) or replaced by the
receive time (``use_header_stamps`` false); the sensor-frame sample is calibrated, rotated into
the body frame and, at start, levelled (:mod:`~rigid_body_attitude.session.levelling`: nothing
is integrated or published until then); the bias estimate is subtracted; the stream rules
decide; when the state moved the attitude goes to the sink stamped with the time used. A gyro
scene simulates no body, so it has no output timer and hands no energy or angular momentum to
the sink.

Samples without accelerometer data (``angular_velocity`` input, or an Imu whose acceleration
is all zeros) and ``align_seconds`` 0 start from the scene's attitude at once (said once, at
INFO). After levelling the levelled attitude is the initial state: a time jump back (a
looping bag) returns to it; ``~/reset`` (:meth:`GyroSession.reset`) levels again.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rigid_body_attitude.core.attitude.integrators.strapdown import DeltaSingle, ExpMap
from rigid_body_attitude.core.propagator import GyroPropagator
from rigid_body_attitude.core.attitude.quaternion import scalar_step_rate
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.session.base import OutputSink
from rigid_body_attitude.session.imu_start import REJECTION_DETAIL, ImuStart
from rigid_body_attitude.session.levelling import FROM_SCENE, AlignmentResult
from rigid_body_attitude.session.reports import DiagnosticReport, LEVEL_WARN
from rigid_body_attitude.session.stream import GyroStream, INTEGRATED, Outcome
from rigid_body_attitude.session.uncertainty import Uncertainty
from rigid_body_attitude.session.times import NANOSECONDS_PER_SECOND, split_ns, stamp_problem

__all__ = ['GyroSession']

_HINT = {'stale_stamp': 'use_header_stamps', 'out_of_range': 'max_angular_rate',
         'outlier_stamp': 'max_dt', 'gap': 'max_dt'}


class GyroSession(ImuStart):
    """Strapdown integration of a gyro scene's samples (a real IMU's start: :class:`ImuStart`).
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
        self._output_sec = self._output_nanosec = 0
        #: The attitude covariance (parameter ``covariance``), or None.
        self.uncertainty: Uncertainty | None = None
        self._start_imu(values)
        super().__init__(scene, values, sink, clock_ns, monotonic)
        self.tell_calibration()
        if self._mount_given:
            self._tell_mount()
        if values['covariance']:
            self.uncertainty = Uncertainty(values, self.calibration_noise())
            self.wants_steps = True
            self.on_aligned = self._covariance_aligned
            sink.attitude_covariance(self.uncertainty.published)

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
        uncertainty = getattr(self, 'uncertainty', None)
        if uncertainty is not None:
            uncertainty.apply(values)

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
            return _refuse_stamp(self, sec, nanosec)
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
            self.warn('outlier_stamp',
                      f'gyro: {REJECTION_DETAIL["outlier_stamp"]} (parameter `max_dt`)')
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
        return True

    def _after_step(self, q_before: tuple[float, float, float, float],
                    rate_body: tuple[float, float, float], dt: float) -> None:
        """One integrated step: attitude at its start, the body rate [rad/s] that, held over
        the step, makes the rotation the strapdown method made (``exp_map``: the corrected rate
        of the sample that starts it; ``delta_single``: of the sample that ends it; any other
        method: ``log(q_before* ⊗ q_after) / dt``), its length [s]; grows the covariance."""
        uncertainty = self.uncertainty
        if uncertainty is not None and uncertainty.step(q_before, rate_body, dt):
            self.sink.attitude_covariance(uncertainty.published)

    def _covariance_aligned(self, result: AlignmentResult) -> None:
        """The integration's start is settled (``on_aligned``): levelled, the covariance
        starts from the levelling's uncertainty (the sink hears of it when it changed); from
        the scene it stays as it is (the unlevelled prior, or a ``set_pose``'s)."""
        uncertainty = self.uncertainty
        if uncertainty is not None and result.source != FROM_SCENE:
            before = uncertainty.published
            uncertainty.aligned(result)
            if uncertainty.published != before:
                self.sink.attitude_covariance(uncertainty.published)

    def _restart_uncertainty(self) -> None:
        """Back to the unlevelled prior (reset, a backward time jump)."""
        if self.uncertainty is not None:
            self.uncertainty.start(None)
            self.sink.attitude_covariance(self.uncertainty.published)

    def _pose_set(self, orientation_covariance: tuple[float, ...] | None) -> None:
        """``set_pose``: the message's orientation covariance, or ``set_pose_stddev``."""
        if self.uncertainty is not None:
            self.uncertainty.set_pose(orientation_covariance)
            self.sink.attitude_covariance(self.uncertainty.published)

    def report(self) -> DiagnosticReport:
        """The diagnostics report, with the calibration applied and the 1σ tilt and yaw (WARN
        past ``tilt_stddev_warn``)."""
        report = super().report()
        report = DiagnosticReport(report.level, report.message,
                                  report.values + tuple(self.calibration_values()))
        if self.uncertainty is None:
            return report
        problem, values = self.uncertainty.diagnostic()
        level, message = report.level, report.message
        if problem:
            level = max(level, LEVEL_WARN)
            message = problem if message == 'propagating' else f'{message}; {problem}'
        return DiagnosticReport(level, message, report.values + tuple(values))

    def _stepped(self, sec: int, nanosec: int, rate: Sequence[float],
                 imu: bytes | None) -> bool:
        """:meth:`gyro`'s integration with :meth:`_after_step` after each integrated step."""
        stream = self.stream
        outliers = stream.outliers if stream.pending else -1
        state = self.propagator.state
        time_before, q_before = state.time, state.attitude_tuple()
        omega_before = state.omega_tuple()
        outcome = stream.add(sec * NANOSECONDS_PER_SECOND + nanosec, rate)
        if outliers >= 0 and stream.outliers != outliers:
            self.warn('outlier_stamp',
                      f'gyro: {REJECTION_DETAIL["outlier_stamp"]} (parameter `max_dt`)')
        if outcome is INTEGRATED:  # the step as the propagator took it: length, rotation
            dt = state.time - time_before
            kind = type(self.propagator.method)
            if kind is ExpMap:  # q ⊗ exp(ω dt) with the previous sample's rate
                self._after_step(q_before, omega_before, dt)
            elif kind is DeltaSingle:  # with this sample's
                self._after_step(q_before, state.omega_tuple(), dt)
            else:
                self._after_step(q_before, scalar_step_rate(q_before, state.attitude_tuple(),
                                                            dt), dt)
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
        return True

    @property
    def output_stamp(self) -> tuple[int, int]:
        """``(sec, nanosec)`` of the last attitude that went to the sink."""
        return self._output_sec, self._output_nanosec

    def _rejected(self, outcome: Outcome) -> None:
        reason = outcome.reason
        if outcome.reset:  # once per jump, never throttled
            self._restart_uncertainty()
            self.sink.log(LEVEL_WARN, f'gyro: stamps jumped back by more than '
                                      f'time_jump_threshold ({self.stream.time_jump_threshold:g}'
                                      f' s; looping bag?), confirmed by the next samples; reset '
                                      f'to the initial state of scene {self.scene.name!r}')
            return
        hint = _HINT.get(reason)
        self.warn(reason, f'gyro: {REJECTION_DETAIL[reason]}'
                          + (f' (parameter `{hint}`)' if hint else ''))

    def _non_finite_result(self) -> bool:
        """An integration whose result is not finite: refused, counted, the scene restarts."""
        self.rejections['non_finite_result'] += 1
        self.error(f'gyro: integration gave a non-finite attitude; reset to the initial state '
                   f'of scene {self.scene.name!r} (parameter `integrator`)')
        self.stream.reset()
        self._restart_uncertainty()
        return False

    def reset(self) -> None:
        """Back to the scene's initial attitude and level again (with levelling); the next
        sample is a new baseline."""
        self._restart_levelling()
        self.stream.reset()
        self._restart_uncertainty()

    def resume(self) -> None:
        """The attitude kept; the next sample is a new baseline."""
        self.stream.resume()

    def accepted_count(self) -> int:
        """Gyro samples (levelling included) and poses used so far."""
        return self.stream.accepted + self.poses_accepted + self._align_samples

    def missed_count(self) -> int:
        """Samples lost upstream so far (from the stamp spacing, :meth:`GyroStream.settle`)."""
        self.stream.settle()
        return self.stream.missed_samples

    def missed_cause(self) -> str:
        """The gaps counted since the last call, with their likely cause."""
        return self.stream.period.gaps_text()

    def malformed(self, topic: str, reason: str) -> None:
        """An undecodable message: on a gyro topic, a sample received (never missed)."""
        super().malformed(topic, reason)
        self.stream.refused_samples += topic in ('imu', 'angular_velocity')

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


def _refuse_stamp(session: GyroSession, sec: int, nanosec: int) -> bool:
    """A gyro sample whose header stamp is zero or invalid: refused, counted (never missed),
    warned about; always False (nothing published)."""
    session.stream.refused_samples += 1  # received: never counted as missed
    if sec == 0 and nanosec == 0:
        session.rejections['zero_stamp'] += 1
        session.warn('zero_stamp', 'gyro: a zero header stamp; sample ignored (unstamped '
                                   'input: set use_header_stamps:=false)')
        return False
    problem = stamp_problem(sec, nanosec)
    session.rejections['invalid_stamp'] += 1
    session.warn('invalid_stamp', f'gyro: an invalid header stamp ({problem}); sample '
                                  f'ignored (parameter `use_header_stamps`)')
    return False
