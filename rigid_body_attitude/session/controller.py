"""The attitude controller without ROS: the plant's stamped state, sample and hold, checks.

The plant publishes its state for each tick ``k`` stamped ``t_k``: ``odom`` (pose in
world_frame, twist in body_frame, one message: :meth:`ControllerSession.odometry`) or, with
``state_input`` ``orientation_twist``, ``orientation`` (world_frame) and ``twist``
(body_frame, the body rate). :class:`ControllerSession` answers each tick with one torque
stamped ``t_k`` exactly, once it holds the tick's attitude and rate (an ``odom`` message, or
both messages of that stamp, paired); so its output depends on the stamped inputs only, never
on when they arrive. With a ``control_period`` ``P > 0`` the
torque is recomputed only at the first tick of each interval ``[n P, (n+1) P)`` of stamps
(integer nanoseconds, so the choice is exact) and otherwise the held torque is sent again,
stamped ``t_k`` (sample and hold). The law is
:func:`rigid_body_attitude.core.control.pd_torque_floats`.

Every input is checked: decodable (``malformed``), a valid stamp (``invalid_stamp``), finite
(``non_finite``), quaternions of unit norm within
:data:`~.controller_parameters.UNIT_TOLERANCE` (``non_unit``), the expected frame
(``wrong_frame``), a target not older than the one in force (``stale_stamp``) and an input
whose partner of the same stamp never came (``unpaired``). A tick the plant publishes again
(a lockstep plant repeats its first tick until a command arrives, in case the first answer
went to a writer it had not yet matched) is answered again with the torque already sent for
it, counted in ``ticks answered again``.
Rejections are counted by reason and warned about, at most every
:data:`~.base.WARNING_INTERVAL` seconds per reason. A complete pair stamped before the last
answered tick means the plant's time went back (a reset): the hold is cleared and the pair
answered (counted as ``time_jumps_back``).

With torque rods (:mod:`~rigid_body_attitude.session.magnetic_control`: B-dot, or dumping the
wheels' momentum) each tick is answered with a dipole too (``actuator`` ``magnetorquers``: the
dipole only), once its magnetometer sample (and wheel state) came: a complete tick waits for
them (at most :data:`MAX_PENDING` ticks; one that never gets them before a later tick is
answered counts as ``unpaired``).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.control import as_axis_gains, pd_torque_floats
from rigid_body_attitude.session.base import LEVEL_INFO, WARNING_INTERVAL
from rigid_body_attitude.session.controller_parameters import UNIT_TOLERANCE
from rigid_body_attitude.core.attitude.quaternion import from_rpy
from rigid_body_attitude.session.magnetic_control import MagneticControl
from rigid_body_attitude.session.magnetic_ticks import MagneticTicks
from rigid_body_attitude.session.reports import DiagnosticReport, LEVEL_OK, LEVEL_WARN
from rigid_body_attitude.session.times import seconds_to_ns, stamp_problem, to_ns

__all__ = ['ControllerSession', 'MAX_PENDING', 'TorqueSink', 'target_from_values']

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]

#: Inputs of each topic kept while waiting for their partner of the same stamp.
MAX_PENDING = 64

_IDENTITY: Quaternion = (1.0, 0.0, 0.0, 0.0)
_ZERO: Vector = (0.0, 0.0, 0.0)


class TorqueSink(Protocol):
    """Where the controller's outputs go (a publisher, a list in a test)."""

    def torque(self, sec: int, nanosec: int, torque_body: Vector) -> None:
        """The torque [N m, body axes] answering the tick stamped ``(sec, nanosec)``."""

    def dipole(self, sec: int, nanosec: int, dipole_body: Vector) -> None:
        """The rods' dipole [A m², body axes] answering the tick stamped ``(sec, nanosec)``."""

    def diagnostics(self, report: DiagnosticReport) -> None:
        """One diagnostics report."""

    def log(self, level: int, text: str) -> None:
        """A log line (``LEVEL_INFO``, ``LEVEL_WARN``)."""


def target_from_values(values: Mapping[str, Any]) -> Quaternion:
    """The target (w, x, y, z) of checked parameter values: ``target_quaternion_xyzw``
    (normalised), else ``target_rpy``, else the identity."""
    if values['target_quaternion_xyzw']:
        x, y, z, w = values['target_quaternion_xyzw']
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        return w / norm, x / norm, y / norm, z / norm
    if values['target_rpy']:
        w, x, y, z = from_rpy(values['target_rpy']).tolist()
        return w, x, y, z
    return _IDENTITY


class ControllerSession(MagneticTicks):
    """Answers each tick's stamped orientation and twist with one torque of the same stamp."""

    def __init__(self, values: Mapping[str, Any], sink: TorqueSink,
                 monotonic: Callable[[], float], magnetic: MagneticControl | None = None
                 ) -> None:
        """``values``: checked parameters (:mod:`.controller_parameters`); ``magnetic``: the
        torque rods' part (:func:`~.magnetic_control.magnetic_control`), if any."""
        self.sink, self.monotonic, self.magnetic = sink, monotonic, magnetic
        self.parked = {}
        #: Whether a torque (or the wheels' torques) answers the ticks (not B-dot alone).
        self.torque_out = values.get('actuator', 'body') != 'magnetorquers'
        self.rejections: Counter[str] = Counter()
        self.pending: dict[str, dict[int, tuple[float, ...]]] = {'orientation': {}, 'twist': {}}
        self._targets: list[tuple[int, Quaternion]] = []
        self._target_stamp = -1
        self._last_warning: dict[str, float] = {}
        self.answered = self.computed = self.time_jumps_back = self.repeated = 0
        self._period_answered = 0
        self._period_rejections: Counter[str] = Counter()
        self.last_stamp: int | None = None
        self.held: tuple[int, Vector] | None = None  # (control interval, torque)
        self._last_sample: tuple[Sequence[float], Quaternion] | None = None
        self.apply(values)
        #: What the diagnostics say the controller waits for (``state_input``).
        self.waiting_for = ('odom' if values.get('state_input', 'odom') == 'odom'
                            else 'orientation and twist of equal stamps')

    def apply(self, values: Mapping[str, Any]) -> None:
        """Take (run-time) parameters; a new target or gain acts from the next tick on (the
        hold is cleared)."""
        self.world_frame: str = values['world_frame']
        self.body_frame: str = values['body_frame']
        self.kp = tuple(as_axis_gains(values['kp'], 'kp').tolist())
        self.kd = tuple(as_axis_gains(values['kd'], 'kd').tolist())
        self.limit = tuple(as_axis_gains(values['torque_limit'], 'torque_limit', True).tolist())
        self.period_ns = seconds_to_ns(values['control_period'])
        self.target: Quaternion = target_from_values(values)
        self.held = None

    # -- inputs -----------------------------------------------------------------------------

    def orientation(self, sec: int, nanosec: int, frame_id: str,
                    attitude: Sequence[float]) -> None:
        """The plant's attitude (w, x, y, z), body → world_frame, stamped ``(sec, nanosec)``."""
        stamp_ns = self._checked('orientation', sec, nanosec, frame_id, self.world_frame,
                                 attitude)
        if stamp_ns is not None:
            self._pend('orientation', stamp_ns, tuple(attitude))

    def twist(self, sec: int, nanosec: int, frame_id: str, angular: Sequence[float]) -> None:
        """The plant's body rate [rad/s] in body_frame stamped ``(sec, nanosec)``."""
        stamp_ns = self._checked('twist', sec, nanosec, frame_id, self.body_frame, angular)
        if stamp_ns is not None:
            self._pend('twist', stamp_ns, tuple(angular))

    def odometry(self, sec: int, nanosec: int, frame_id: str, child_frame_id: str,
                 attitude: Sequence[float], angular: Sequence[float]) -> None:
        """The plant's state in one message (nav_msgs/Odometry): the attitude (w, x, y, z),
        body → ``frame_id`` (world_frame), and the body rate [rad/s] in ``child_frame_id``
        (body_frame), stamped ``(sec, nanosec)``; answered at once."""
        stamp_ns = self._checked('odom', sec, nanosec, frame_id, self.world_frame, attitude)
        if stamp_ns is None:
            return
        if child_frame_id != self.body_frame:
            self._reject('wrong_frame', f'odom: child frame {child_frame_id[:100]!r}, '
                                        f'expected {self.body_frame!r}')
            return
        if not all(math.isfinite(value) for value in angular):
            self._reject('non_finite', 'odom: a non-finite value (NaN or Inf)')
            return
        self._answer(stamp_ns, tuple(attitude), tuple(angular))

    def target_message(self, sec: int, nanosec: int, frame_id: str,
                       attitude: Sequence[float]) -> None:
        """A new target (w, x, y, z) in world_frame, in force for ticks stamped at or after
        ``(sec, nanosec)`` (a zero stamp: from the next recomputation)."""
        stamp_ns = self._checked('target', sec, nanosec, frame_id, self.world_frame, attitude)
        if stamp_ns is None:
            return
        if stamp_ns < self._target_stamp:
            self._reject('stale_stamp', 'target: stamped before the target in force')
            return
        norm = math.sqrt(sum(value * value for value in attitude))
        w, x, y, z = (value / norm for value in attitude)
        self._targets = [entry for entry in self._targets if entry[0] < stamp_ns]
        self._targets.append((stamp_ns, (w, x, y, z)))
        self._target_stamp = stamp_ns

    def malformed(self, topic: str, reason: str) -> None:
        """Bytes on ``topic`` that are not a message of its type."""
        self._reject('malformed', f'{topic}: {reason[:200]}; message ignored')

    def _checked(self, topic: str, sec: int, nanosec: int, frame_id: str, expected_frame: str,
                 values: Sequence[float]) -> int | None:
        """The stamp in nanoseconds, or None (counted) for a rejected input."""
        problem = stamp_problem(sec, nanosec)
        if problem:
            self._reject('invalid_stamp', f'{topic}: an invalid header stamp ({problem})')
            return None
        if frame_id != expected_frame:
            self._reject('wrong_frame', f'{topic}: frame {frame_id[:100]!r}, expected '
                                        f'{expected_frame!r}')
            return None
        if not all(math.isfinite(value) for value in values):
            self._reject('non_finite', f'{topic}: a non-finite value (NaN or Inf)')
            return None
        if len(values) == 4 and abs(math.sqrt(sum(v * v for v in values)) - 1.0) > UNIT_TOLERANCE:
            self._reject('non_unit', f'{topic}: a quaternion of norm beyond 1 ± '
                                     f'{UNIT_TOLERANCE:g}')
            return None
        return to_ns(sec, nanosec)

    # -- pairing and answering --------------------------------------------------------------

    def _pend(self, topic: str, stamp_ns: int, value: tuple[float, ...]) -> None:
        waiting = self.pending[topic]
        waiting[stamp_ns] = value
        if len(waiting) > MAX_PENDING:
            del waiting[min(waiting)]
            self._reject('unpaired', f'{topic}: more than {MAX_PENDING} inputs without their '
                                     f'partner of the same stamp')
        other = self.pending['twist' if topic == 'orientation' else 'orientation']
        if stamp_ns in other:
            attitude = self.pending['orientation'].pop(stamp_ns)
            rate = self.pending['twist'].pop(stamp_ns)
            self._answer(stamp_ns, attitude, rate)

    def _answer(self, stamp_ns: int, attitude: tuple[float, ...],
                rate: tuple[float, ...]) -> None:
        """Publish the torque (and dipole) for the tick ``stamp_ns`` (recomputed or held),
        or keep the tick until its magnetometer sample came."""
        magnetic = self.magnetic
        if magnetic is not None and magnetic.waiting_for(stamp_ns):
            self.park(stamp_ns, attitude, rate)
            return
        if self.last_stamp is not None and stamp_ns < self.last_stamp:
            self.time_jumps_back += 1
            self.held = None
            self._drop_pending(lambda stamp: True)
            if magnetic is not None:
                magnetic.restart(stamp_ns)
            self._note('time_jump_back', 'inputs stamped before the last answered tick: the '
                                         'plant restarted; hold cleared')
        else:
            self._drop_pending(lambda stamp: stamp < stamp_ns)
        if stamp_ns == self.last_stamp:
            self.repeated += 1  # the held torque of this tick's interval is sent again
        self.last_stamp = stamp_ns
        interval = stamp_ns // self.period_ns if self.period_ns else stamp_ns
        held = self.held
        recompute = held is None or held[0] != interval
        if held is None or recompute:
            held = self.held = (interval, self._compute(stamp_ns, attitude, rate)
                                if self.torque_out else _ZERO)
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        if magnetic is not None:
            self.sink.dipole(sec, nanosec, magnetic.answer(stamp_ns, recompute))
            self.count_dropped_inputs()
        if self.torque_out:
            self.sink.torque(sec, nanosec, held[1])
        self.answered += 1
        self._period_answered += 1

    def _compute(self, stamp_ns: int, attitude: tuple[float, ...],
                 rate: tuple[float, ...]) -> Vector:
        while self._targets and self._targets[0][0] <= stamp_ns:
            self.target = self._targets.pop(0)[1]
        self.computed += 1
        self._last_sample = (attitude, self.target)  # the pointing error: in report()
        return pd_torque_floats(attitude, rate, self.target, self.kp, self.kd, self.limit)

    def _drop_pending(self, drop: Callable[[int], bool]) -> None:
        for topic, waiting in self.pending.items():
            for stamp in [stamp for stamp in waiting if drop(stamp)]:
                del waiting[stamp]
                self._reject('unpaired', f'{topic}: no partner of the same stamp before a '
                                         f'later tick was answered')
        self.drop_parked(drop)

    # -- counting, warnings, diagnostics ----------------------------------------------------

    def _reject(self, reason: str, text: str) -> None:
        self.rejections[reason] += 1
        self._period_rejections[reason] += 1
        self._note(reason, f'{text} [{self.rejections[reason]} {reason} so far]', LEVEL_WARN)

    def _note(self, key: str, text: str, level: int = LEVEL_INFO) -> None:
        now = self.monotonic()
        if now - self._last_warning.get(key, -math.inf) >= WARNING_INTERVAL:
            self._last_warning[key] = now
            self.sink.log(level, text)

    @property
    def pointing_error(self) -> float:
        """The angle [rad] between the last computed-on attitude and its target (NaN before
        the first), computed when asked (the diagnostics), not every tick."""
        if self._last_sample is None:
            return math.nan
        return float(quaternion.attitude_error(*self._last_sample))

    def report(self) -> DiagnosticReport:
        """This period's diagnostics; WARN while no tick was answered or inputs were
        rejected. Starts the next period."""
        problems = [f'{count} {reason}' for reason, count in
                    sorted(self._period_rejections.items())]
        if not self._period_answered:
            waiting = self.waiting_for
            if self.parked and self.magnetic is not None:
                waiting = self.magnetic.waiting_for(min(self.parked)) or waiting
            problems.insert(0, f'no tick answered: waiting for {waiting}')
        values = (
            ('ticks answered', str(self.answered)), ('torques computed', str(self.computed)),
            ('ticks answered again', str(self.repeated)),
            ('pointing error [deg]', f'{math.degrees(self.pointing_error):.6g}'),
            ('torque [N m]', str(self.held[1] if self.held else None)),
            *((('dipole [A m2]', str(self.magnetic.dipole)),) if self.magnetic else ()),
            ('target (w, x, y, z)', str(self.target)),
            ('time jumps back', str(self.time_jumps_back)),
            *((f'rejected {reason}', str(count))
              for reason, count in sorted(self.rejections.items())))
        self._period_answered = 0
        self._period_rejections = Counter()
        return DiagnosticReport(LEVEL_WARN if problems else LEVEL_OK,
                                '; '.join(problems) or 'controlling', values)

    def publish_diagnostics(self) -> None:
        """Hand this period's report to the sink."""
        self.sink.diagnostics(self.report())
