"""Time handling of input streams, shared by the node and the replay tool.

The propagators integrate; this module decides *whether and how far* to integrate for each
incoming message, and counts what it refuses. Rules (the node's documented behaviour):

Gyro samples (:class:`GyroStream`)
    * non-finite stamp or rate → rejected, ``non_finite``; the state is untouched;
    * the first sample only sets the baseline (nothing to integrate across);
    * a stamp equal to or older than the last → rejected, ``stale_stamp``; but a backward
      jump larger than ``time_jump_threshold`` (a looping bag) → the state resets to the
      scene's initial state and the sample is the new baseline, ``time_jump``;
    * a gap longer than ``max_dt`` → not integrated across; the sample is the new baseline,
      ``gap``;
    * otherwise integrated over ``stamp − last`` (or ``constant_dt`` when set).

Commanded inputs (:class:`CommandStream`): non-finite → ``non_finite``; older than the last
command of the same input → ``stale_stamp``; otherwise passed to the propagator.

Clock ticks for dynamics scenes (:class:`ClockDriver`): the first tick sets the scene's start
time; a backward jump larger than ``time_jump_threshold`` resets (``time_jump``); a forward
jump larger than it is not integrated across (``gap``); otherwise the state is integrated up
to the tick.

Every message ends up in exactly one bucket: ``accepted`` or one rejection reason.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator, _Propagator

__all__ = ['ClockDriver', 'CommandStream', 'GyroStream', 'Outcome', 'REASONS']

#: Rejection reasons, in the order the diagnostics list them.
REASONS = ('non_finite', 'stale_stamp', 'gap', 'time_jump')


@dataclass(frozen=True)
class Outcome:
    """What happened to one message.

    Attributes:
        accepted: the message was used (integrated, or taken as the baseline).
        integrated: the state advanced.
        reason: the rejection reason (one of :data:`REASONS`), or ``''`` when accepted.
        reset: the state was reset to the scene's initial state (a time jump).
    """

    accepted: bool
    integrated: bool = False
    reason: str = ''
    reset: bool = False


_BASELINE = Outcome(accepted=True)
_INTEGRATED = Outcome(accepted=True, integrated=True)


class _Counting:
    """Counts accepted messages and rejections by reason."""

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
        """Messages seen: accepted plus rejected."""
        return self.accepted + sum(self.rejected.values())


def _finite(stamp: float, values: Sequence[float]) -> bool:
    isfinite = math.isfinite
    return isfinite(stamp) and isfinite(values[0]) and isfinite(values[1]) and isfinite(
        values[2])


class GyroStream(_Counting):
    """Feeds gyro samples into a :class:`GyroPropagator` under the stream rules above."""

    def __init__(self, propagator: GyroPropagator, max_dt: float, time_jump_threshold: float,
                 constant_dt: float = 0.0) -> None:
        """Apply ``max_dt`` [s], ``time_jump_threshold`` [s] and ``constant_dt`` (0 = off)."""
        super().__init__()
        self.propagator = propagator
        self.max_dt = max_dt
        self.time_jump_threshold = time_jump_threshold
        self.constant_dt = constant_dt
        self.last_stamp = -math.inf

    def reset(self) -> None:
        """Reset the propagator; the next sample is a new baseline."""
        self.propagator.reset()
        self.last_stamp = -math.inf

    def add(self, stamp: float, omega_body: Sequence[float]) -> Outcome:
        """Process one gyro sample stamped ``stamp`` [s] with rate ``omega_body`` [rad/s]."""
        if len(omega_body) != 3 or not _finite(stamp, omega_body):
            return self._reject('non_finite')
        propagator = self.propagator
        if not propagator.has_sample:
            return self._baseline(stamp, omega_body)
        if stamp <= self.last_stamp:
            if self.last_stamp - stamp > self.time_jump_threshold:
                propagator.reset()
                propagator.start(stamp, omega_body)
                self.last_stamp = stamp
                return self._reject('time_jump', reset=True)
            return self._reject('stale_stamp')
        if stamp - self.last_stamp > self.max_dt:
            propagator.start(stamp, omega_body)
            self.last_stamp = stamp
            return self._reject('gap')
        sample = (float(omega_body[0]), float(omega_body[1]), float(omega_body[2]))
        if self.constant_dt > 0.0:
            propagator.advance(propagator.state.time + self.constant_dt, sample)
        else:
            propagator.advance(float(stamp), sample)
        self.last_stamp = stamp
        self.accepted += 1
        return _INTEGRATED

    def _baseline(self, stamp: float, omega_body: Sequence[float]) -> Outcome:
        self.propagator.start(stamp, omega_body)
        self.last_stamp = stamp
        return self._accept(_BASELINE)


class CommandStream(_Counting):
    """Feeds commanded inputs (torque, force, rotor torque) into a propagator."""

    def __init__(self, propagator: _Propagator) -> None:
        """Route commands to ``propagator``."""
        super().__init__()
        self.propagator = propagator
        self.last_stamps: dict[str, float] = {}

    def add(self, input_name: str, stamp: float, value: Sequence[float]) -> Outcome:
        """Process one command ``value`` for ``input_name`` stamped ``stamp`` [s]."""
        if len(value) != 3 or not _finite(stamp, value):
            return self._reject('non_finite')
        if stamp < self.last_stamps.get(input_name, -math.inf):
            return self._reject('stale_stamp')
        self.propagator.command(input_name, stamp, value)
        self.last_stamps[input_name] = stamp
        return self._accept(_BASELINE)

    def reset(self) -> None:
        """Forget the last stamps (after a time jump)."""
        self.last_stamps.clear()


class ClockDriver(_Counting):
    """Advances a :class:`DynamicsPropagator` to each tick of a clock (node or sim time)."""

    def __init__(self, propagator: DynamicsPropagator, time_jump_threshold: float) -> None:
        """Reset on backward jumps larger than ``time_jump_threshold`` [s]."""
        super().__init__()
        self.propagator = propagator
        self.time_jump_threshold = time_jump_threshold
        self.started = False

    def tick(self, now: float) -> Outcome:
        """Integrate up to ``now`` [s] (clock seconds)."""
        if not math.isfinite(now):
            return self._reject('non_finite')
        propagator = self.propagator
        if not self.started:
            propagator.reset(time=now)
            self.started = True
            return self._accept(_BASELINE)
        last = propagator.state.time
        if now < last - self.time_jump_threshold:
            propagator.reset(time=now)
            return self._reject('time_jump', reset=True)
        if now <= last:
            return self._reject('stale_stamp')
        if now - last > self.time_jump_threshold:
            propagator.state.time = now
            return self._reject('gap')
        propagator.advance_to(now)
        return self._accept(_INTEGRATED)

    def reset(self) -> None:
        """The next tick starts the scene again."""
        self.started = False
