"""What every session shares: its sink, settings, counting, poses, resets, warnings, reports.

A session is the node without ROS. An adapter (the node, the replay tool, a test) decodes each
message into plain values and calls the session with them; the session applies the time rules
(:mod:`~rigid_body_attitude.session.stream`), advances the propagator, counts, and hands what
is to be published to its :class:`OutputSink`. The adapter also gives it two clocks: the node
clock (``clock_ns``: receive times, when header stamps are not used) and a monotonic clock
(``monotonic``: warning throttling, work timing). No input, however malformed or absurd, raises
out of a session, corrupts its state or reaches the sink as a non-finite value: it is rejected,
counted by reason and warned about (at most every :data:`WARNING_INTERVAL` per reason).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.msgs.untrusted import quoted
from rigid_body_attitude.session.outputs import OutputSample, OutputTracker
from rigid_body_attitude.session.parameters import check_values
from rigid_body_attitude.session.uncertainty import orientation_block
from rigid_body_attitude.session.reports import (
    DiagnosticReport, LEVEL_ERROR, LEVEL_WARN, PeriodCounts, StrapdownState, diagnostic_report,
    stale_command_count, state_summary)

__all__ = ['AccelerationEstimate', 'LEVEL_INFO', 'OutputSink', 'POSITION_LIMIT', 'Session',
           'WARNING_INTERVAL']

#: Seconds between repeated warnings about the same reason.
WARNING_INTERVAL = 5.0
#: Log level of ordinary messages (warnings and errors use the diagnostics levels).
LEVEL_INFO = 0
#: Rejection reasons that count no input: expired commands, refused integrations of clock
#: ticks, the session's own failures, and static transforms (not inputs of the propagator).
NOT_INPUTS = ('stale_torque', 'integration_failed', 'non_finite_result', 'internal_error',
              'tf_bad_frames', 'tf_non_finite', 'tf_denormalized', 'tf_evicted')
#: Largest distance of a ``set_pose`` position from the origin [m] (0.1 light-year).
POSITION_LIMIT = 1e15

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]
#: A sample's gravity-free acceleration and its covariance, computed when called.
AccelerationEstimate = Callable[[], tuple[Vector, tuple[float, ...]]]


class OutputSink(Protocol):
    """Where a session's outputs go (publishers, a bag writer, a list in a test)."""

    #: Whether outputs carry the inputs' header stamps (else the receive time was used).
    use_header_stamps: bool

    def attitude(self, sec: int, nanosec: int, attitude: Quaternion,
                 imu: bytes | None) -> None:
        """A gyro sample's body attitude (w, x, y, z) stamped ``(sec, nanosec)``; ``imu``: the
        serialized Imu the sample came from (``imu/data`` is it with the sensor frame's
        attitude, :meth:`sensor_mount`), or None."""

    def sensor_mount(self, q_body_sensor: Quaternion | None) -> None:
        """The rotation (w, x, y, z) of the IMU's frame in the body frame (``None``: identity):
        ``imu/data`` carries the sensor frame's attitude ``attitude ⊗ q_body_sensor``
        (REP-145), the other outputs the body's. Given at start and when the mount changes."""

    def attitude_covariance(self, covariance: tuple[float, ...]) -> None:
        """The row-major 3×3 attitude covariance [rad²] about fixed world axes that goes with
        the following attitudes (given when it changes; gyro scenes with ``covariance`` on)."""

    def dynamics(self, sec: int, nanosec: int, sample: OutputSample,
                 velocity_body: Vector) -> None:
        """A dynamics tick's state (attitude, position, rate, velocity in body axes)."""

    def invariants(self, sec: int, nanosec: int, energy: float,
                   world_momentum: Vector) -> None:
        """A dynamics tick's kinetic energy [J] and world angular momentum [N m s], stamped
        like its attitude."""

    def acceleration(self, sec: int, nanosec: int, estimate: AccelerationEstimate) -> None:
        """A filtered gyro sample's gravity-free acceleration (scenes with an ``estimation``
        section), stamped like the attitude: ``estimate()`` gives it [m/s², body frame] with
        its row-major 3×3 covariance [(m/s²)²], computed when called (an output that
        publishes nothing need not)."""

    def odometry(self, sec: int, nanosec: int, attitude: Quaternion, omega_body: Vector,
                 rate_covariance: tuple[float, ...]) -> None:
        """A filtered gyro sample's state for ``odom`` (scenes with an ``estimation``
        section), stamped like the attitude just given: the attitude (w, x, y, z) with the
        attitude covariance given last, the corrected body rate [rad/s] with its row-major
        3×3 covariance [(rad/s)²]."""

    def sensor_wanted(self, topic: str) -> bool:
        """Whether a simulated sensor's sample on the output ``topic`` would reach anyone (a
        matched subscription, a topic of the output bag): the session encodes it only then."""

    def simulated_sensor(self, topic: str, data: bytes) -> None:
        """A simulated sensor's sample (dynamics scenes with ``sensors``), serialized, for the
        output ``topic``: its ``sensor_msgs/msg/Imu``, ``sensor_msgs/msg/MagneticField`` or
        ``geometry_msgs/msg/PoseWithCovarianceStamped``."""

    def wheel_state(self, data: bytes) -> None:
        """A dynamics tick's reaction wheels (scenes with ``reaction_wheels``): a serialized
        ``sensor_msgs/msg/JointState`` for ``wheels/state``, stamped like the attitude."""

    def diagnostics(self, report: DiagnosticReport) -> None:
        """One diagnostics report."""

    def log(self, level: int, text: str) -> None:
        """A log line (:data:`LEVEL_INFO`, ``LEVEL_WARN`` or ``LEVEL_ERROR``)."""


class Session(ABC):
    """The shared part of :class:`~.gyro.GyroSession` and :class:`~.dynamics.DynamicsSession`.

    ``values`` are the parameters (:mod:`~rigid_body_attitude.session.parameters`; run-time
    ones again through :meth:`apply`).
    """

    propagator: DynamicsPropagator | GyroPropagator

    def __init__(self, scene: Scene, values: Mapping[str, Any], sink: OutputSink,
                 clock_ns: Callable[[], int], monotonic: Callable[[], float]) -> None:
        """Build the propagator of ``scene``; outputs go to ``sink``."""
        self.scene = scene
        self.sink = sink
        self.clock_ns = clock_ns
        self.monotonic = monotonic
        self.tracker = OutputTracker()
        self.rejections: Counter[str] = Counter()  # the session's own reasons
        self.malformed_by_topic: Counter[str] = Counter()
        self.poses_accepted = 0
        self._last_warning: dict[str, float] = {}
        self._period: tuple[float, int, int, Counter[str], int] = (
            monotonic(), 0, 0, Counter(), 0)
        #: Inputs accepted per second in the last diagnostics period [Hz].
        self.last_input_rate = 0.0
        self.apply(values)

    # -- parameters -------------------------------------------------------------------------

    def apply(self, values: Mapping[str, Any]) -> None:
        """Take the run-time parameters (frames, stamps, thresholds)."""
        self.world_frame: str = values['world_frame']
        self.use_header_stamps: bool = values['use_header_stamps']
        self.sink.use_header_stamps = self.use_header_stamps

    def check(self, values: Mapping[str, Any]) -> str:
        """Why new parameter values are unusable for this session, or ``''``."""
        return check_values(values)

    # -- inputs -----------------------------------------------------------------------------

    def malformed(self, topic: str, reason: str) -> None:
        """A message on ``topic`` that could not be decoded (``reason``)."""
        self.rejections['malformed'] += 1
        self.malformed_by_topic[topic] += 1
        self.warn('malformed', f'{topic}: malformed message rejected ({reason})')

    def internal_error(self, topic: str, err: Exception) -> None:
        """An input on ``topic`` that raised ``err`` inside the session (a bug): counted and
        logged (throttled); the node goes on."""
        self.rejections['internal_error'] += 1
        self.warn('internal_error', f'{topic}: internal error {type(err).__name__}: '
                                    f'{str(err)[:200]}; input ignored')

    def set_pose(self, frame_id: str, attitude: Quaternion, position: Vector,
                 covariance: Sequence[float] | None = None) -> None:
        """Re-initialise the attitude (w, x, y, z) (and the position, with translation).

        ``covariance``: the 36 row-major values of a ``PoseWithCovarianceStamped``, whose
        orientation block (about fixed world axes, rad²) becomes the attitude covariance of a
        gyro scene; it must be finite, symmetric, positive semi-definite with variances at
        most π² rad² (else the pose is refused as ``invalid_covariance``, checked before
        anything changes). None: the covariance resets to ``set_pose_stddev``.
        """
        reason, detail = self._pose_problem(frame_id, attitude, position)
        block = None
        if not reason and covariance is not None:
            try:
                block = orientation_block(covariance)
            except InputError as err:
                reason, detail = 'invalid_covariance', str(err)
        if reason:
            self.rejections[reason] += 1
            self.warn(reason, f'set_pose rejected ({reason}): {detail}')
            return
        propagator = self.propagator
        scale = max(abs(value) for value in attitude)  # no overflow when squared below
        unit = tuple(value / scale for value in attitude)
        try:
            propagator.set_attitude(unit, position if propagator.has_translation else None)
        except InputError as err:
            self.rejections['invalid_pose'] += 1
            self.warn('invalid_pose', f'set_pose rejected (invalid_pose): {err}')
            return
        self.poses_accepted += 1
        self._pose_set(block)
        where = f', position {position}' if propagator.has_translation else ''
        self.note('set_pose', f'set_pose: attitude (w, x, y, z) {attitude}{where}',
                  self.poses_accepted)

    def _pose_set(self, orientation_covariance: tuple[float, ...] | None) -> None:
        """A pose was set, with the row-major 3×3 orientation covariance given (or None)."""

    def _pose_problem(self, frame_id: str, attitude: Quaternion,
                      position: Vector) -> tuple[str, str]:
        if frame_id != self.world_frame:
            return 'wrong_frame', (f'frame {quoted(frame_id)}, expected world_frame '
                                   f'{quoted(self.world_frame)}')
        if not all(math.isfinite(value) for value in attitude + position):
            return 'non_finite', f'{attitude + position}'
        if max(abs(value) for value in attitude) == 0.0:
            return 'invalid_pose', 'zero quaternion'
        if max(abs(value) for value in position) > POSITION_LIMIT:
            return 'out_of_range', f'position {position} beyond {POSITION_LIMIT:g} m'
        return '', ''

    @abstractmethod
    def reset(self) -> None:
        """Back to the scene's initial state (the ``~/reset`` service)."""

    @abstractmethod
    def resume(self) -> None:
        """Keep the state and let the next input start a new baseline: nothing is integrated
        across a pause (a managed node reactivated)."""

    # -- warnings and diagnostics -----------------------------------------------------------

    def warn(self, reason: str, text: str) -> None:
        """A warning per reason at most every :data:`WARNING_INTERVAL` seconds."""
        now = self.monotonic()
        if now - self._last_warning.get(reason, -math.inf) >= WARNING_INTERVAL:
            self._last_warning[reason] = now
            self.sink.log(LEVEL_WARN, f'{text} [{self.rejection_counts()[reason]} so far]')

    def note(self, key: str, text: str, count: int) -> None:
        """An INFO line per ``key`` at most every :data:`WARNING_INTERVAL` seconds, with the
        ``count`` of such events so far."""
        now, key = self.monotonic(), f'note {key}'
        if now - self._last_warning.get(key, -math.inf) >= WARNING_INTERVAL:
            self._last_warning[key] = now
            self.sink.log(LEVEL_INFO, f'{text} [{count} so far]')

    def error(self, text: str) -> None:
        """An error log line (never throttled: each marks a reset of the state)."""
        self.sink.log(LEVEL_ERROR, text)

    def rejection_counts(self) -> Counter[str]:
        """Rejected inputs so far by reason."""
        counts = Counter(self.rejections)
        for stream_counts in self._stream_rejections():
            counts.update(stream_counts)
        counts['stale_torque'] = stale_command_count(self.propagator.counters())
        return counts

    def accepted_count(self) -> int:
        """Inputs used so far (gyro samples, commands, poses; not clock ticks)."""
        return self.poses_accepted

    def received_count(self) -> int:
        """Inputs received so far, whatever became of them (not clock ticks, not commands
        that expired: :data:`NOT_INPUTS`)."""
        rejected = sum(count for reason, count in self.rejections.items()
                       if reason not in NOT_INPUTS)
        rejected += sum(sum(counts.values()) for counts in self._input_rejections())
        return self.accepted_count() + rejected + self._pending_count()

    def missed_count(self) -> int:
        """Samples lost upstream so far."""
        return 0

    def missed_cause(self) -> str:
        """What the samples missed since the last call look like, and their likely cause."""
        return ''

    def publish_diagnostics(self) -> None:
        """Hand the period's report to the sink and start a new period."""
        self.sink.diagnostics(self.report())

    def report(self) -> DiagnosticReport:
        """The diagnostics report of the period since the last one (starts a new period)."""
        now = self.monotonic()
        start, received0, accepted0, rejections0, missed0 = self._period
        received, accepted = self.received_count(), self.accepted_count()
        rejections, missed = self.rejection_counts(), self.missed_count()
        self._period = (now, received, accepted, rejections, missed)
        counts = PeriodCounts(
            elapsed=max(now - start, 1e-9), received=received - received0,
            accepted=accepted - accepted0, accepted_total=accepted, received_total=received,
            rejections=rejections,
            new_rejections=rejections - rejections0, missed=missed - missed0,
            missed_total=missed, missed_cause=self.missed_cause(),
            malformed_by_topic=Counter(self.malformed_by_topic),
            gyro_scene=isinstance(self.propagator, GyroPropagator))
        self._timing(counts)
        self.last_input_rate = counts.accepted / counts.elapsed
        return diagnostic_report(self.propagator, counts, self.step_text(), self.time_s(),
                                 self.strapdown_state())

    def strapdown_state(self) -> StrapdownState | None:
        """A strapdown session's alignment and bias for the reports (``None``: none)."""
        return None

    def _timing(self, counts: PeriodCounts) -> None:
        """Dynamics: fill in the real-time factor and lag of the period."""

    def step_text(self) -> str:
        """The step, as the diagnostics describe it."""
        return f'{self.scene.step:g}'

    def time_s(self) -> float:
        """The propagated time shown in the diagnostics [s]."""
        return self.propagator.state.time

    def _stream_rejections(self) -> list[Counter[str]]:
        """The rejection counters of the session's streams (inputs and clock ticks)."""
        return self._input_rejections()

    def _input_rejections(self) -> list[Counter[str]]:
        """The rejection counters of the streams of inputs."""
        return []

    def _pending_count(self) -> int:
        return 0

    def summary(self) -> str:
        """The INFO line the node logs every few diagnostics periods."""
        state = state_summary(self.propagator, self.strapdown_state())
        rejected = sum(self.rejection_counts().values())
        return (f't={self.time_s():.3f} s: {state}, accepted {self.accepted_count()} '
                f'({self.last_input_rate:.1f} Hz), rejected {rejected}, missed '
                f'{self.missed_count()}')
