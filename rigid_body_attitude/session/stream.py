"""Time rules of the input streams: whether and how far to integrate for each input.

The propagators integrate; this module decides what each input does, and counts what it
refuses. Times are integer nanoseconds (:mod:`rigid_body_attitude.session.times`). Every input
ends up in exactly one bucket: ``accepted``, one rejection reason, or (for a while) ``pending``.

Gyro samples (:class:`GyroStream`)
    * a rate that is not 3 finite numbers → ``non_finite``; of a magnitude above
      ``max_angular_rate`` → ``out_of_range``; the state is untouched;
    * the first sample only sets the baseline (nothing to integrate across);
    * a stamp at most ``max_dt`` after the last → integrated over the stamp difference (or
      ``constant_dt`` when set);
    * a stamp equal to or older than the last, by at most ``time_jump_threshold`` →
      ``stale_stamp``;
    * a **jump** (a stamp more than ``max_dt`` ahead, or more than ``time_jump_threshold``
      back) is taken only when the next :data:`JUMP_CONFIRMATIONS` samples confirm it, each
      within ``max_dt`` after the one before. Until then the samples are ``pending`` (nothing
      changes, nothing is published). Confirmed, the first of them counts as ``gap`` (forward:
      the new baseline, not integrated across) or ``time_jump`` (backward, a looping bag: the
      state resets to the scene's initial state), and the confirming samples are integrated
      from it. A sample that continues the old time line instead ends the wait: the pending
      samples count as ``outlier_stamp`` and the stream goes on undisturbed.
    * **missed samples**, with header stamps only: every integrated sample's stamp and step go
      to a :class:`~rigid_body_attitude.session.period.PeriodLearner`, which learns the
      sample period and counts the samples missed upstream against the expected sample index
      (its module says how); :meth:`GyroStream.settle` counts a partial batch (at each
      diagnostics report). They are counted in :attr:`GyroStream.missed_samples`.

Commanded inputs (:class:`CommandStream`): first their stamps against the scene's time
(:meth:`CommandStream.timing`): received before the scene's first tick (the first after a
start, a reset or a backward clock jump: scene time 0) → ``not_started``; without lockstep,
stamped more than ``time_jump_threshold`` ahead of the clock → ``future_stamp``, before the
scene's start or more than ``time_jump_threshold`` behind the clock → ``stale_stamp``. A
command never moves the scene's time. Then the value: not 3 finite numbers → ``non_finite``; a
magnitude above :data:`COMMAND_LIMIT` → ``out_of_range``; older than the last command of the
same input → ``stale_stamp``; otherwise passed to the propagator. In lockstep
(:attr:`CommandStream.tick_ns` set: the tick the commands must answer) a command is used only
when stamped exactly with that tick, once per input: a later stamp → ``future_stamp``, an
earlier one or a second one for the tick → ``stale_stamp``.

Clock ticks of dynamics scenes (:class:`ClockDriver`): the first tick starts the scene (its
time there is the one its ``start`` gives: the session's scene time 0); a backward jump larger
than ``time_jump_threshold`` starts it again (``time_jump``); a forward jump larger than it is
not integrated across (``gap``); otherwise the state is integrated up to the tick.
"""

from __future__ import annotations

import math
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator, _Propagator
from rigid_body_attitude.session.period import PERIOD_BATCH, PeriodLearner

__all__ = ['COMMAND_LIMIT', 'ClockDriver', 'CommandStream', 'GyroStream', 'INTEGRATED',
           'JUMP_CONFIRMATIONS', 'Outcome', 'REASONS']

#: Rejection reasons of the streams, in the order the diagnostics list them.
REASONS = ('non_finite', 'out_of_range', 'stale_stamp', 'outlier_stamp', 'gap', 'time_jump',
           'future_stamp', 'not_started')

#: Samples after a jump that must confirm it (each within ``max_dt`` of the one before).
JUMP_CONFIRMATIONS = 2

#: Largest magnitude of a commanded torque [N m] or force [N]: far above any actuator (the
#: largest control moment gyros give ~1e4 N m, a launcher's engines ~1e7 N), far below
#: values whose integration could overflow a float.
COMMAND_LIMIT = 1e12

Vector = tuple[float, float, float]


@dataclass(frozen=True)
class Outcome:
    """What happened to one input.

    Attributes:
        accepted: the input was used (integrated, or taken as the baseline).
        integrated: the state advanced.
        reason: the rejection reason (one of :data:`REASONS`), or ``''``; for the sample
            that confirmed a jump, the jump's (``gap`` or ``time_jump``).
        reset: the state was reset to the scene's initial state (a time jump).
        pending: held until the next samples confirm or refute a jump.
    """

    accepted: bool
    integrated: bool = False
    reason: str = ''
    reset: bool = False
    pending: bool = False

    @property
    def moved(self) -> bool:
        """Whether the state moved to this input's time (so outputs are published)."""
        return self.accepted or self.reason in ('gap', 'time_jump')


_BASELINE = Outcome(accepted=True)
#: The outcome of an ordinary integrated sample (one object: callers may test identity).
INTEGRATED = Outcome(accepted=True, integrated=True)
_PENDING = Outcome(accepted=False, pending=True)


class _Counting:
    """Counts accepted inputs and rejections by reason."""

    def __init__(self) -> None:
        self.accepted = 0
        self.rejected: Counter[str] = Counter()

    def _reject(self, reason: str, reset: bool = False) -> Outcome:
        self.rejected[reason] += 1
        return Outcome(accepted=False, reason=reason, reset=reset)

    def _accept(self, outcome: Outcome) -> Outcome:
        self.accepted += 1
        return outcome

    @property
    def total(self) -> int:
        """Inputs seen: accepted plus rejected."""
        return self.accepted + sum(self.rejected.values())


def _vector(values: Sequence[float]) -> Vector | None:
    """3 finite floats, or None."""
    if len(values) != 3:
        return None
    x, y, z = values
    if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
        return float(x), float(y), float(z)
    return None


class GyroStream(_Counting):
    """Feeds gyro samples into a :class:`GyroPropagator` under the stream rules above."""

    def __init__(self, propagator: GyroPropagator, max_dt: float, time_jump_threshold: float,
                 constant_dt: float = 0.0, max_angular_rate: float = math.inf,
                 count_missed: bool = True) -> None:
        """Rules with ``max_dt``, ``time_jump_threshold``, ``constant_dt`` (0 = off) [s] and
        ``max_angular_rate`` [rad/s]; ``count_missed``: learn the period and count missed
        samples (meaningful for header stamps, not for receive times)."""
        super().__init__()
        self.propagator = propagator
        self.max_dt = max_dt
        self.time_jump_threshold = time_jump_threshold
        self.constant_dt = constant_dt
        self.max_angular_rate = max_angular_rate
        self.count_missed = count_missed
        self.last_ns = 0
        self.epoch_ns = 0
        self.pending: list[tuple[int, Vector]] = []
        #: Samples found to be outliers so far (also in ``rejected``; cheap to watch).
        self.outliers = 0
        #: Samples with a stamp refused so far, here or by the session before (never missed).
        self.refused_samples = 0
        self.period = PeriodLearner()

    @property
    def max_dt(self) -> float:
        """Longest step integrated across [s]."""
        return self.max_dt_ns * 1e-9

    @max_dt.setter
    def max_dt(self, seconds: float) -> None:
        self.max_dt_ns = round(seconds * 1e9)

    @property
    def time_jump_threshold(self) -> float:
        """Largest backward step rejected as stale rather than a time jump [s]."""
        return self.threshold_ns * 1e-9

    @time_jump_threshold.setter
    def time_jump_threshold(self, seconds: float) -> None:
        self.threshold_ns = round(seconds * 1e9)

    @property
    def max_angular_rate(self) -> float:
        """Largest magnitude of a rate integrated [rad/s]."""
        return math.sqrt(self.max_rate_squared)

    @max_angular_rate.setter
    def max_angular_rate(self, rate: float) -> None:
        # Capped at the largest float: an infinite rate (or a square that overflows) is never
        # integrated, whatever the bound.
        self.max_rate_squared = min(rate * rate, sys.float_info.max)

    @property
    def missed_samples(self) -> int:
        """Samples lost upstream, from the stamp spacing."""
        return self.period.missed

    def settle(self) -> None:
        """Count the missed samples of the steps so far (a partial batch whose median agrees
        with the period; else they wait for the full batch)."""
        if self.count_missed:
            self.period.settle(self.refused_samples, partial=True)

    def _reject(self, reason: str, reset: bool = False) -> Outcome:
        self.refused_samples += 1
        return super()._reject(reason, reset)

    @property
    def total(self) -> int:
        """Samples seen: accepted, rejected and pending."""
        return self.accepted + sum(self.rejected.values()) + len(self.pending)

    def reset(self) -> None:
        """Reset the propagator; the next sample is a new baseline."""
        self.propagator.reset()
        self.pending.clear()

    def resume(self) -> None:
        """Keep the state; the next sample is a new baseline (after a pause in which the
        samples were not for this stream: nothing is integrated across it)."""
        self.propagator.has_sample = False

    def start_at(self, stamp_ns: int) -> None:
        """A baseline at ``stamp_ns`` without a sample: the state there is known from
        elsewhere (an attitude measurement); the next sample is integrated from it with its
        own rate (its rate is the first interval's for ``delta_single``; the baseline's rate is
        zero for the methods that read it)."""
        self.pending.clear()
        self.epoch_ns = stamp_ns - round(self.propagator.state.time * 1e9)
        self._start(stamp_ns, (0.0, 0.0, 0.0))

    def add(self, stamp_ns: int, omega_body: Sequence[float]) -> Outcome:
        """Process one gyro sample stamped ``stamp_ns`` with rate ``omega_body`` [rad/s]."""
        try:
            x, y, z = omega_body
            squared = x * x + y * y + z * z
        except (TypeError, ValueError):
            return self._reject('non_finite')
        if not squared <= self.max_rate_squared:  # NaN, Inf, overflow and too fast alike
            return self._reject('out_of_range' if _vector(omega_body) else 'non_finite')
        if not self.propagator.has_sample:
            # After a reset the propagator's time is 0; after resume() it goes on from its
            # time: the pause is not part of the time axis.
            self.epoch_ns = stamp_ns - round(self.propagator.state.time * 1e9)
            self._start(stamp_ns, (float(x), float(y), float(z)))
            return self._accept(_BASELINE)
        if self.pending:
            return self._resolve(stamp_ns, (float(x), float(y), float(z)))
        step_ns = stamp_ns - self.last_ns
        if 0 < step_ns <= self.max_dt_ns:
            return self._integrate(stamp_ns, step_ns, (float(x), float(y), float(z)))
        if step_ns <= 0 and -step_ns <= self.threshold_ns:
            return self._reject('stale_stamp')
        self.pending.append((stamp_ns, (float(x), float(y), float(z))))
        return _PENDING

    def _integrate(self, stamp_ns: int, step_ns: int, sample: Vector) -> Outcome:
        propagator = self.propagator
        if self.count_missed:
            period = self.period
            count = period.count
            period.steps[count] = step_ns
            period.stamps[count] = stamp_ns
            period.count = count + 1
            if count + 1 == PERIOD_BATCH:
                period.settle(self.refused_samples)
        if self.constant_dt > 0.0:
            propagator.advance(propagator.state.time + self.constant_dt, sample)
        else:
            propagator.advance((stamp_ns - self.epoch_ns) * 1e-9, sample)
        self.last_ns = stamp_ns
        self.accepted += 1
        return INTEGRATED

    def _start(self, stamp_ns: int, sample: Vector) -> None:
        """A new baseline at ``stamp_ns`` (the stamps' time line breaks: the period learner
        counts what it has and finds the lattice again). The propagator's time is seconds
        since :attr:`epoch_ns`, the stamp of the first sample since the last reset."""
        if self.count_missed:
            self.period.break_line(self.refused_samples)
        self.last_ns = stamp_ns
        self.propagator.start((stamp_ns - self.epoch_ns) * 1e-9, sample)

    def _resolve(self, stamp_ns: int, sample: Vector) -> Outcome:
        """A sample while a jump waits for confirmation."""
        step_ns = stamp_ns - self.pending[-1][0]
        if 0 < step_ns <= self.max_dt_ns:
            self.pending.append((stamp_ns, sample))
            if len(self.pending) <= JUMP_CONFIRMATIONS:
                return _PENDING
            return self._take_jump()
        self.rejected['outlier_stamp'] += len(self.pending)
        self.outliers += len(self.pending)
        self.refused_samples += len(self.pending)
        self.pending.clear()
        return self.add(stamp_ns, sample)

    def _take_jump(self) -> Outcome:
        """The pending samples confirmed a jump: the first is a new baseline, the rest are
        integrated from it."""
        (first_ns, first), *confirming = self.pending
        self.pending = []
        backward = first_ns < self.last_ns
        if backward:
            self.rejected['time_jump'] += 1
            self.propagator.reset()
            self.epoch_ns = first_ns
        else:
            self.rejected['gap'] += 1
            if self.count_missed:
                self.period.gap(first_ns - self.last_ns)
        self._start(first_ns, first)
        for stamp_ns, sample in confirming:
            self._integrate(stamp_ns, stamp_ns - self.last_ns, sample)
        return Outcome(accepted=True, integrated=True, reason='time_jump' if backward else 'gap',
                       reset=backward)


class CommandStream(_Counting):
    """Feeds commanded inputs (torque, force, rotor torque) into a propagator."""

    def __init__(self, propagator: _Propagator) -> None:
        """Route commands to ``propagator``."""
        super().__init__()
        self.propagator = propagator
        self.last_ns: dict[str, int] = {}
        #: Lockstep: the tick [ns] a command must be stamped with (``None``: any time).
        self.tick_ns: int | None = None

    def check(self, value: Sequence[float]) -> str:
        """The rejection reason of a command value (3 numbers, or one per wheel), or ``''``."""
        if len(value) == 3:
            vector = _vector(value)
            if vector is None:
                return 'non_finite'
            x, y, z = vector
            square = x * x + y * y + z * z
        else:
            try:
                values = [float(item) for item in value]
            except (TypeError, ValueError):
                return 'non_finite'
            if not all(math.isfinite(item) for item in values):
                return 'non_finite'
            square = sum(item * item for item in values)
        if square > COMMAND_LIMIT * COMMAND_LIMIT:
            return 'out_of_range'
        return ''

    def timing(self, stamp_ns: int, clock_ns: int, start_ns: int | None,
               window_ns: int) -> Outcome | None:
        """The refusal (counted) of a command stamped ``stamp_ns`` received at ``clock_ns``
        in a scene started at ``start_ns`` (``None``: not started), or ``None`` when its
        stamp may act: ``not_started``; without lockstep (the tick rule of :meth:`add`
        decides then) a stamp more than ``window_ns`` ahead of the clock (``future_stamp``:
        held from it, it would hold back every later command), or before the start or more
        than ``window_ns`` behind the clock (``stale_stamp``)."""
        if start_ns is None:
            return self._reject('not_started')
        if self.tick_ns is not None:
            return None
        if stamp_ns > clock_ns + window_ns:
            return self._reject('future_stamp')
        if stamp_ns < start_ns or stamp_ns < clock_ns - window_ns:
            return self._reject('stale_stamp')
        return None

    def add(self, input_name: str, stamp_ns: int, time_s: float,
            value: Sequence[float], key: str = '') -> Outcome:
        """Process one command ``value`` for ``input_name`` stamped ``stamp_ns`` (``time_s``
        on the propagator's time axis); ``key``: the topic whose stamps are kept, when one
        topic carries several inputs (a wheel array's torques or speeds)."""
        reason = self.check(value)
        if reason:
            return self._reject(reason)
        key = key or input_name
        if stamp_ns < self.last_ns.get(key, stamp_ns):
            return self._reject('stale_stamp')
        tick_ns = self.tick_ns
        if tick_ns is not None and stamp_ns != tick_ns:
            return self._reject('future_stamp' if stamp_ns > tick_ns else 'stale_stamp')
        if tick_ns is not None and self.last_ns.get(key) == tick_ns:
            return self._reject('stale_stamp')  # a second answer to the same tick
        self.propagator.command(input_name, time_s, value)
        self.last_ns[key] = stamp_ns
        return self._accept(_BASELINE)

    def reset(self) -> None:
        """Forget the last stamps (after a time jump or reset)."""
        self.last_ns.clear()

    def answered(self, input_names: Sequence[str]) -> bool:
        """Lockstep: whether each of ``input_names`` has a command stamped :attr:`tick_ns`."""
        tick_ns, last_ns = self.tick_ns, self.last_ns
        return all(last_ns.get(name) == tick_ns for name in input_names)


class ClockDriver(_Counting):
    """Advances a :class:`DynamicsPropagator` to each tick of a clock (node or sim time)."""

    def __init__(self, propagator: DynamicsPropagator, time_jump_threshold: float,
                 start: Callable[[float], float] | None = None) -> None:
        """Reset on backward jumps larger than ``time_jump_threshold`` [s]; ``start``: the
        scene's time at the tick that (re)starts it, from the tick's time (default: the
        tick's time)."""
        super().__init__()
        self.propagator = propagator
        self.time_jump_threshold = time_jump_threshold
        #: The scene's time at a tick that starts it (the session's: 0, its time base moved).
        self.start: Callable[[float], float] = start if start is not None else _same
        self.started = False
        self.resuming = False
        #: Integrates up to a time [s]: the propagator's ``advance_to``, or a simulated
        #: sensors' (:class:`~rigid_body_attitude.session.sensors.SensorSampler`) that samples
        #: on the way.
        self.advance: Callable[[float], int] = propagator.advance_to

    def tick(self, now: float) -> Outcome:
        """Integrate up to ``now`` [s on the propagator's time axis]."""
        if not math.isfinite(now):
            return self._reject('non_finite')
        propagator = self.propagator
        if not self.started:
            propagator.reset(time=self.start(now))
            self.started = True
            return self._accept(_BASELINE)
        if self.resuming:
            self.resuming = False
            if now > propagator.state.time:
                propagator.state.time = now  # the pause: not integrated across
                return self._accept(_BASELINE)
        last = propagator.state.time
        # Compared in whole nanoseconds: a tick exactly time_jump_threshold after the last
        # (1 Hz ticks, a 1 s threshold) is no jump, whatever the round-off of the seconds.
        step_ns, threshold_ns = round((now - last) * 1e9), round(self.time_jump_threshold * 1e9)
        if step_ns < -threshold_ns:
            propagator.reset(time=self.start(now))
            return self._reject('time_jump', reset=True)
        if now <= last:
            return self._reject('stale_stamp')
        if step_ns > threshold_ns:
            propagator.state.time = now
            return self._reject('gap')
        self.advance(now)
        return self._accept(INTEGRATED)

    def reset(self) -> None:
        """The next tick starts the scene again."""
        self.started = False

    def resume(self) -> None:
        """Keep the state; the next tick is a new baseline (nothing integrated across the
        pause before it)."""
        self.resuming = True


def _same(now: float) -> float:
    return now
