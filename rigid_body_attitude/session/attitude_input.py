"""A filtered gyro session's ``attitude_measurement`` input: checked, fused in stamp order.

An attitude measurement (a star tracker, motion capture: ``PoseWithCovarianceStamped`` in
``world_frame``) stamped ``s`` is fused at the gyro state of the last sample stamped at or
before ``s``:

* at once when the state is stamped ``s`` (or later: the gyro ran ahead of it, which is
  counted as ``attitude_late`` in the filter's updates, and the measurement is paired with
  the newer state);
* otherwise held until the next gyro sample stamped after ``s`` arrives, and fused just
  before that sample is integrated.

Either way a measurement changes no output stamped at or before its own stamp, and the
outputs stamped after it carry it, whatever the order in which a measurement and a gyro
sample of the same stamp arrive: the estimate a lockstep controller reads for tick ``t_k``
holds the measurements stamped before ``t_k`` (the one stamped ``t_k`` reaches the estimate
of the next sample).

**Waiting for the measurement** (parameter ``attitude_measurement_period`` ``P > 0``, the
sensor's period: its samples are stamped at the multiples of ``P``): a gyro sample stamped
``t`` is held, not integrated, until the measurement stamped at the last multiple of ``P``
before ``t`` came (from the filter's start on), then integrated and published. So the
estimate stamped ``t`` holds that measurement however late it arrives, and two runs of a
lockstep loop fuse the same measurements into the same outputs. A later gyro sample ends the
wait: the held samples go on without the measurement, counted ``attitude_missing`` (a
lockstep plant moves on only after its ``lockstep_timeout``; a star tracker blinded by the Sun
gives no sample: set ``P`` 0 there). With ``P`` 0 nothing waits.
The measurement is paired with the propagated attitude at its stamp when its stamp is a gyro
sample's (the world-axis error ``log(q_true ⊗ q_est*)`` does not change over a step both
attitudes take with the same rate); between two samples it is paired with the earlier one.

With ``estimation: {start: attitude_measurement}`` the filter starts at the first accepted
measurement: its attitude and its covariance (the attitude block; the gyro states keep their
prior) at its stamp, which is the gyro stream's first instant (:meth:`GyroStream.start_at
<rigid_body_attitude.session.stream.GyroStream.start_at>`), and the start is published at
that stamp with a zero body rate (no gyro sample yet). Gyro samples before it are refused
(``awaiting_attitude``).

The start's measurement coming again before any gyro sample (a lockstep plant repeats its
first tick, and its sensors' samples, until a controller that subscribed late answers) makes
the start's outputs published again (counted ``attitude_start_repeated``), so the controller
gets the estimate of that tick whenever it subscribed.

Refusals (counted ``attitude_measurement_<reason>``): ``stale_stamp`` (a stamp not newer than
the last accepted measurement's), ``stale_measurement`` (further than ``max_dt`` from the
latest gyro sample), ``queue_full`` (more than :data:`MEASUREMENT_QUEUE` held for a stalled
gyro: the oldest is dropped), besides the message checks of the session.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.session.levelling import FROM_SCENE, AlignmentResult
from rigid_body_attitude.session.times import split_ns, to_ns
from rigid_body_attitude.session.uncertainty import orientation_block

__all__ = ['ATTITUDE_START_STATUS', 'AttitudeInput', 'AttitudeMeasurements',
           'MEASUREMENT_QUEUE', 'start_result']

Quat = tuple[float, float, float, float]
#: Measurements held for a gyro that has not reached their stamps (a gyro sample waits for
#: its measurement alone: the next one releases it).
MEASUREMENT_QUEUE = 64
#: The alignment status of a filter started from an attitude measurement.
ATTITUDE_START_STATUS = 'started from the first attitude_measurement'
#: A gyro sample held for a measurement: its stamp and :meth:`gyro`'s arguments.
HeldSample = tuple[int, int, int, Sequence[float], 'bytes | None',
                   'Sequence[float] | None']


class AttitudeMeasurements:
    """The held measurements and the last accepted stamp of one session (module docstring).
    """

    def __init__(self) -> None:
        """None held, none accepted."""
        self.held: deque[tuple[int, Quat, tuple[float, ...]]] = deque()
        self.last_ns: int | None = None
        #: The stamp of the measurement the filter started from (``None``: none).
        self.start_ns: int | None = None
        #: Gyro samples held for a measurement (``attitude_measurement_period``).
        self.samples: deque[HeldSample] = deque()
        #: The stamp before which no measurement is waited for (the filter's start), and the
        #: last one given up (``attitude_missing``).
        self.wait_from_ns = self.given_up_ns = 0

    def restart(self) -> None:
        """Forget the held measurements and samples and the last stamp (reset, a jump back)."""
        self.held.clear()
        self.samples.clear()
        self.last_ns = self.start_ns = None
        self.wait_from_ns = self.given_up_ns = 0

    def accept(self, stamp_ns: int) -> str:
        """``''`` when a measurement stamped ``stamp_ns`` is newer than the last accepted
        (it becomes the last), else ``'stale_stamp'``."""
        if self.last_ns is not None and stamp_ns <= self.last_ns:
            return 'stale_stamp'
        self.last_ns = stamp_ns
        return ''

    def hold(self, stamp_ns: int, q: Quat, block: tuple[float, ...]) -> bool:
        """Hold a measurement until the gyro passes its stamp; True when the queue was full
        (the oldest dropped)."""
        held = self.held
        held.append((stamp_ns, q, block))
        if len(held) > MEASUREMENT_QUEUE:
            held.popleft()
            return True
        return False

    def due(self, sample_ns: int) -> list[tuple[Quat, tuple[float, ...]]]:
        """The held measurements stamped before a gyro sample stamped ``sample_ns``, oldest
        first (removed from the queue)."""
        held = self.held
        due = []
        while held and held[0][0] < sample_ns:
            _, q, block = held.popleft()
            due.append((q, block))
        return due

    def awaited(self, sample_ns: int, period_ns: int) -> int | None:
        """The stamp of the measurement a gyro sample stamped ``sample_ns`` waits for (the
        last multiple of ``period_ns`` before it), or None when it waits for none."""
        if period_ns <= 0:
            return None
        stamp = (sample_ns - 1) // period_ns * period_ns
        if stamp < self.wait_from_ns or stamp <= self.given_up_ns or (
                self.last_ns is not None and stamp <= self.last_ns):
            return None
        return stamp


def start_result(q: Quat) -> AlignmentResult:
    """The start of a filter from an attitude measurement ``q`` (w, x, y, z)."""
    return AlignmentResult(attitude=q, gyro_bias=(0.0, 0.0, 0.0), window_seconds=0.0,
                           at_rest=False, source=FROM_SCENE, status=ATTITUDE_START_STATUS)


class AttitudeInput:
    """The ``attitude_measurement`` side of
    :class:`~rigid_body_attitude.session.filtered_gyro.FilteredGyroSession` (module
    docstring): the session's attributes it uses are declared here, set by the session."""

    measurements: AttitudeMeasurements
    starts_from_attitude: bool
    measurement_period_ns: int
    estimation_inputs: int
    _sample_ns: int
    _aligning: bool
    _output_sec: int
    _output_nanosec: int
    world_frame: str
    use_header_stamps: bool
    estimation: Any
    propagator: Any
    stream: Any
    sink: Any
    tracker: Any
    alignment: AlignmentResult | None
    rejections: Counter[str]
    _refused: Callable[..., None]
    _corrected: Callable[[], None]
    _filter_aligned: Callable[[AlignmentResult], None]
    _update_paths: Callable[[], None]
    _integrated_gyro: Callable[..., bool]

    def attitude_measurement(self, sec: int, nanosec: int, frame: str,
                             attitude: Quat, covariance: Sequence[float]) -> None:
        """One ``attitude_measurement`` (module docstring); refused ones counted by reason."""
        if frame != self.world_frame:
            return self._refused('wrong_frame', 'attitude_measurement', frame)
        if not all(math.isfinite(value) for value in attitude):
            return self._refused('non_finite', 'attitude_measurement')
        norm = math.sqrt(sum(value * value for value in attitude))
        if norm == 0.0:
            return self._refused('invalid_pose', 'attitude_measurement')
        try:
            block = orientation_block(covariance)
        except InputError:
            return self._refused('invalid_covariance', 'attitude_measurement')
        stamp_ns = to_ns(sec, nanosec)
        if not self.use_header_stamps:
            stamp_ns = self._sample_ns
        w, x, y, z = (value / norm for value in attitude)
        if not self.estimation.started:
            if self._aligning and self.starts_from_attitude:
                return self._start_from_measurement(stamp_ns, (w, x, y, z), block)
            return self._refused('not_started', 'attitude_measurement')
        if abs(stamp_ns - self._sample_ns) > self.stream.max_dt * 1e9:
            return self._refused('stale_measurement', 'attitude_measurement')
        reason = self.measurements.accept(stamp_ns)
        if reason and self.starts_from_attitude and stamp_ns == self.stream.last_ns == (
                self.measurements.start_ns):  # the start's sample again, nothing integrated
            self.estimation.counts['attitude_start_repeated'] += 1
            return self._publish_start(stamp_ns)
        if reason:
            return self._refused(reason, 'attitude_measurement')
        self.estimation_inputs += 1
        self._take((w, x, y, z), block, stamp_ns)
        if self.measurements.samples:
            self._release(missing=False)

    def _take(self, q: Quat, block: tuple[float, ...], stamp_ns: int) -> None:
        """An accepted measurement: held while the gyro has not reached its stamp, else
        fused at once (``attitude_late`` when the gyro is past it)."""
        if stamp_ns > self.stream.last_ns:  # the gyro has not reached it: held
            if self.measurements.hold(stamp_ns, q, block):
                self._refused('queue_full', 'attitude_measurement')
            return
        if stamp_ns < self.stream.last_ns:
            self.estimation.counts['attitude_late'] += 1
        self._fuse(q, block)

    def _fuse(self, q_measured: Quat, block: tuple[float, ...]) -> None:
        """A measurement fused at the current gyro state."""
        state = self.propagator.state
        q = self.estimation.attitude_measurement(state.attitude_tuple(), q_measured, block)
        state.set_sample(state.time, q, state.omega_tuple())
        self._corrected()

    def _fuse_due(self) -> None:
        """The held measurements stamped before the gyro sample at hand, fused."""
        for q_measured, block in self.measurements.due(self._sample_ns):
            self._fuse(q_measured, block)

    def _waits(self, stamp_ns: int, sample: HeldSample) -> bool:
        """Whether a gyro sample stamped ``stamp_ns`` is held for its measurement (then it
        is); samples held before it go on without theirs (``attitude_missing``)."""
        measurements = self.measurements
        if measurements.samples:
            self._release(missing=True)
        if measurements.awaited(stamp_ns, self.measurement_period_ns) is None:
            return False
        measurements.samples.append(sample)
        return True

    def _release(self, missing: bool) -> None:
        """The held gyro samples whose measurement came (``missing``: all of them, their
        measurements given up), integrated in order."""
        measurements = self.measurements
        samples = measurements.samples
        while samples:
            stamp_ns, sec, nanosec, rate, imu, accel = samples[0]
            awaited = measurements.awaited(stamp_ns, self.measurement_period_ns)
            if awaited is not None and not missing:
                return
            if awaited is not None:
                self.estimation.counts['attitude_missing'] += 1
                measurements.given_up_ns = awaited
            samples.popleft()
            self._integrated_gyro(sec, nanosec, rate, imu, accel)

    def _start_from_measurement(self, stamp_ns: int, q: Quat,
                                block: tuple[float, ...]) -> None:
        """The filter's start at the first measurement (``start: attitude_measurement``): its
        attitude and covariance at its stamp, the gyro stream's baseline; published there."""
        self.measurements.accept(stamp_ns)
        self.estimation_inputs += 1
        propagator = self.propagator
        propagator.scene = replace(propagator.scene, initial_attitude=np.array(q))
        propagator.set_attitude(q)
        self.stream.start_at(stamp_ns)
        self._sample_ns = stamp_ns
        result = start_result(q)
        self.alignment = result
        self._aligning = False
        self._filter_aligned(result)
        self.estimation.reset_attitude_block(block)
        self.sink.attitude_covariance(self.estimation.published)
        self.measurements.start_ns = stamp_ns
        self._publish_start(stamp_ns)

    def _publish_start(self, stamp_ns: int) -> None:
        """The start's outputs, stamped like its measurement (again when the measurement
        comes again before any gyro sample: a lockstep plant repeating its first tick for a
        controller that subscribed late)."""
        sec, nanosec = split_ns(stamp_ns)
        attitude = self.tracker.attitude(self.propagator)
        self.sink.attitude(sec, nanosec, attitude, None)
        self._output_sec, self._output_nanosec = sec, nanosec
        self.sink.odometry(sec, nanosec, attitude, (0.0, 0.0, 0.0),
                           self.estimation.rate_covariance)
