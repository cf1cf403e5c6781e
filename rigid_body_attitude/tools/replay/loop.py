"""The replay's event loop: the bag's messages and the node's timers on the bag's time axis.

As the node runs with ``use_sim_time`` when a player publishes ``/clock`` with the bag times
(bag time = the recorder's receive time):

* **ticks** of the output timer (dynamics scenes; a gyro scene has none) at the multiples
  ``k P`` (``k ≥ 1``) of its period ``P = timer_period_ns(publish_rate)`` within the bag's time
  span, each before the messages recorded at the same instant (the player publishes
  ``/clock = T`` first): the session integrates to ``T`` and publishes;
* **lockstep** (parameter ``lockstep``): the ticks follow the command stamps instead, as the
  node's sim clock made them: ticks at ``k P`` from ``t_0 = 0``; before a command stamped
  ``s`` is handled, every tick at or before ``s`` runs, so the command answering tick ``k``
  is held over ``[t_k, t_k+1)``, as in the live loop (docs/closed-loop.md); after the last
  message, one more tick (the node advanced past the last command);
* **diagnostics** every second of bag time from the first message, and once more at the next
  second (dynamics: or tick, if later) after the end;
* **messages**: handed to the node's own input handlers
  (:func:`rigid_body_attitude.session.decoding.input_handler`): decoded and given to the
  session; one that cannot be decoded goes to ``session.malformed`` and one that raises inside
  the session to ``session.internal_error``, and the replay goes on, as the node does.

The session's clocks read the bag time: ``clock_ns`` the time of the message or tick being
handled, ``monotonic`` the same in seconds, so warnings are throttled on bag time and the
dynamics timing (real-time factor, lag) does not depend on the machine.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from typing import Protocol

from rigid_body_attitude.bag import BagMessage
from rigid_body_attitude.msgs.cdr import header_stamp_ns
from rigid_body_attitude.session.decoding import Handler, input_handler, MALFORMED
from rigid_body_attitude.session.interface import NODE_INTERFACE
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.settings import AnySession, DIAGNOSTICS_PERIOD
from rigid_body_attitude.session.times import seconds_to_ns
from rigid_body_attitude.tools.replay.plan import Plan
from rigid_body_attitude.tools.replay.sink import BagSink
from rigid_body_attitude.tools.replay.truth import AlignmentError

__all__ = ['EventLoop', 'FLUSH_RECORDS', 'PROGRESS_CHUNK', 'Progress']

#: Progress-bar updates and output flushes every this many messages (a tqdm update costs
#: about a microsecond).
PROGRESS_CHUNK = 4096
#: Output records buffered at most before they are written (about 3 MB of messages).
FLUSH_RECORDS = 4 * PROGRESS_CHUNK
_DIAGNOSTICS_NS = seconds_to_ns(DIAGNOSTICS_PERIOD)
#: The next tick of a scene without an output timer (gyro scenes): never.
_NEVER_NS = 2**63 - 1


class Progress(Protocol):
    """A progress bar (tqdm's interface)."""

    def update(self, n: int) -> object:
        """``n`` more messages done."""

    def close(self) -> None:
        """The end."""


class EventLoop:
    """Feeds one bag's messages and the timers' events to a session, in bag-time order."""

    def __init__(self, session: AnySession, sink: BagSink, plan: Plan, period_ns: int,
                 first_ns: int, lockstep: bool = False) -> None:
        """Ticks every ``period_ns`` and diagnostics every second from ``first_ns``, the bag
        time of the first message; with ``lockstep`` the ticks follow the command stamps."""
        self.session = session
        self.sink = sink
        self.plan = plan
        self.period_ns = period_ns
        self.next_tick_ns = (max(-(-first_ns // period_ns), 1) * period_ns
                             if isinstance(session, DynamicsSession) and not lockstep
                             else _NEVER_NS)
        #: Lockstep: the sim time of the next tick (``None``: ticks on bag time).
        self.lockstep_next_ns: int | None = (
            0 if lockstep and isinstance(session, DynamicsSession) else None)
        commands = NODE_INTERFACE.names('in', ('command',))
        self.command_topics = frozenset(topic for topic, node_topic in plan.inputs.items()
                                        if node_topic in commands)
        self.next_diagnostics_ns = first_ns + _DIAGNOSTICS_NS
        #: Messages read per bag topic (the gyro topic's added at the end of the gyro loop).
        self.read: Counter[str] = Counter()
        #: Ticks of the output timer so far (the one after the end not included).
        self.ticks = 0
        self.handlers = {topic: input_handler(self.session, node_topic)
                         for topic, node_topic in plan.inputs.items()}
        #: The gyro topic's handler (gyro scenes): the node's, with the bag's message type.
        self.gyro_handler: Handler | None = None
        if plan.gyro_type:
            self.gyro_handler = input_handler(
                session, 'imu' if plan.gyro_is_imu else 'angular_velocity', plan.gyro_type,
                reraise=(AlignmentError,))
        sink.now_ns = first_ns

    # -- timers -----------------------------------------------------------------------------

    def next_event_ns(self) -> int:
        """Bag time of the next tick or diagnostics message."""
        return min(self.next_tick_ns, self.next_diagnostics_ns)

    def run_until(self, bag_time_ns: int) -> None:
        """Run the ticks and diagnostics due at or before ``bag_time_ns``, in time order (a
        tick before the diagnostics of the same instant)."""
        while True:
            tick, diagnostics = self.next_tick_ns, self.next_diagnostics_ns
            if min(tick, diagnostics) > bag_time_ns:
                return
            if tick <= diagnostics:
                self.tick(tick)
                self.next_tick_ns = tick + self.period_ns
            else:
                self.diagnostics(diagnostics)
                self.next_diagnostics_ns = diagnostics + _DIAGNOSTICS_NS

    def tick(self, now_ns: int) -> None:
        """The output timer at bag time ``now_ns`` (the node's ``tick_callback``)."""
        self.sink.now_ns = now_ns
        session = self.session
        if isinstance(session, DynamicsSession):
            session.tick(now_ns)
        self.ticks += 1
        if len(self.sink.records) >= FLUSH_RECORDS:
            self.sink.flush()

    def lockstep_until(self, stamp_ns: int) -> None:
        """Lockstep: the ticks at or before a command's ``stamp_ns``."""
        session, next_ns = self.session, self.lockstep_next_ns
        assert isinstance(session, DynamicsSession) and next_ns is not None
        while next_ns <= stamp_ns:
            session.lockstep_tick(next_ns)
            self.ticks += 1
            next_ns += self.period_ns
        self.lockstep_next_ns = next_ns

    def diagnostics(self, now_ns: int) -> None:
        """The node's ``/diagnostics`` at bag time ``now_ns``."""
        self.sink.now_ns = now_ns
        self.session.publish_diagnostics()

    def finish(self) -> None:
        """After the last message: the diagnostics at the next second (dynamics: or the
        next tick, if later)."""
        if isinstance(self.session, GyroSession):
            self.diagnostics(self.next_diagnostics_ns)
        elif self.lockstep_next_ns is not None:
            self.lockstep_until(self.lockstep_next_ns)
            self.diagnostics(self.next_diagnostics_ns)
        else:
            self.diagnostics(max(self.next_diagnostics_ns, self.next_tick_ns))

    # -- messages ---------------------------------------------------------------------------

    def run(self, messages: Iterator[BagMessage], progress: Progress) -> int:
        """Replay every message, then :meth:`finish`; returns the gyro messages handled."""
        if isinstance(self.session, GyroSession):
            count = self._gyro_messages(messages, progress)
        else:
            count = 0
            self._messages(messages, progress)
        self.finish()
        return count

    def _messages(self, messages: Iterator[BagMessage], progress: Progress) -> None:
        """Dynamics scenes: every message advances the clock; inputs go to the session."""
        sink, handlers, read = self.sink, self.handlers, self.read
        chunk = 0
        for topic, bag_time_ns, _, data in messages:
            if bag_time_ns >= self.next_event_ns():
                self.run_until(bag_time_ns)
            sink.now_ns = bag_time_ns
            read[topic] += 1
            handler = handlers.get(topic)
            if self.lockstep_next_ns is not None and topic in self.command_topics:
                self._lockstep_ticks(data)
            if handler is not None:
                handler(data)
            chunk += 1
            if chunk == PROGRESS_CHUNK:
                progress.update(chunk)
                sink.flush()
                chunk = 0
        progress.update(chunk)

    def _lockstep_ticks(self, data: bytes) -> None:
        """Lockstep: the ticks up to a command's stamp (a message too short to hold a stamp
        is left to its handler, which counts it malformed)."""
        try:
            stamp_ns = header_stamp_ns(data)
        except MALFORMED:
            return
        self.lockstep_until(stamp_ns)

    def _gyro_messages(self, messages: Iterator[BagMessage], progress: Progress) -> int:
        """Gyro scenes (the hot path): per gyro message the node's gyro handler (one decoder
        call, ``session.gyro``, the sink appending the encoded outputs to its buffer)."""
        plan, sink, handlers, read = self.plan, self.sink, self.handlers, self.read
        gyro_topic, handle = plan.gyro_topic, self.gyro_handler
        assert handle is not None
        next_event = self.next_event_ns()
        count = chunk = 0
        for topic, bag_time_ns, _, data in messages:
            if bag_time_ns >= next_event:
                self.run_until(bag_time_ns)
                next_event = self.next_event_ns()
            sink.now_ns = bag_time_ns
            chunk += 1
            if chunk == PROGRESS_CHUNK:
                progress.update(chunk)
                sink.flush()
                chunk = 0
            if topic != gyro_topic:
                read[topic] += 1
                handlers[topic](data)
                continue
            count += 1
            handle(data)
        progress.update(chunk)
        read[gyro_topic] += count
        return count
