"""The stepping loop of a dynamics scene on its own sim clock (``publish_clock``, ``lockstep``).

Instead of a timer of the node clock, the loop itself makes the ticks
(:class:`~rigid_body_attitude.session.sim_clock.SimClock`): each tick publishes ``/clock`` (with
``publish_clock``), then the session integrates to it and publishes the outputs stamped with
it. In lockstep the loop then waits for the commands answering the tick: it sleeps in ``rcl``'s
wait on one reused wait set (the command subscriptions, the diagnostics timer, a wake-up guard
and SIGINT's guard; GIL released, no busy spinning) until they arrived or ``lockstep_timeout``
of wall time passed. Between ticks it waits the same way for the wall-time schedule of
``real_time_factor``, serving commands and diagnostics meanwhile. The command subscriptions
and timers belong to :class:`~.raw_take_loop.DedicatedGroup` s, so no executor takes them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import threading
import time
from typing import Any

from rclpy.context import Context
from rclpy.subscription import Subscription
from rclpy.timer import Timer

from rigid_body_attitude.msgs.cdr import encode_clock
from rigid_body_attitude.ros.raw_take_loop import RawTakeLoop, Handler
from rigid_body_attitude.ros.outputs import RawOutput, RosOutputs
from rigid_body_attitude.ros.rclpy_internals import new_wait_set
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.sim_clock import SimClock

__all__ = ['READY_POLL_S', 'StepLoop', 'step_loop']

#: Wall seconds between two publications of the first tick while lockstep waits for a
#: controller's first command (outputs are volatile: a controller that subscribed later
#: missed the earlier ones).
READY_POLL_S = 0.1


class StepLoop(RawTakeLoop):
    """Makes the sim clock's ticks and serves commands and timers between them."""

    def __init__(self, context: Context, served: Sequence[tuple[Subscription, Handler]],
                 timers: Sequence[Timer], clock: SimClock, tick: Callable[[], None],
                 answered: Callable[[], bool], repeat: Callable[[], None],
                 on_timeout: Callable[[], None]) -> None:
        """Serve ``served`` (command subscriptions) and ``timers``; per tick call ``tick``
        (publish ``/clock``, integrate, publish). In lockstep, ``answered`` says whether the
        tick's commands arrived, ``repeat`` publishes the first tick again while no
        controller answered it, ``on_timeout`` counts a tick advanced without commands."""
        super().__init__(context, served, timers)
        self.clock, self.tick, self.answered = clock, tick, answered
        self.repeat, self.on_timeout = repeat, on_timeout
        self.ticks = 0

    def run(self) -> None:
        """Tick, wait and serve until :meth:`stop`, SIGINT or context shutdown."""
        clock, stopping = self.clock, self._stopping
        wait_set = new_wait_set(self.context, len(self.served), 2, len(self.timers))
        monotonic = time.monotonic
        try:
            first = True
            while self.context.ok() and not stopping.is_set():
                self.tick()
                self.ticks += 1
                if clock.lockstep and first:
                    first = False
                    if not self._wait_for_controller(wait_set):
                        return
                elif clock.lockstep:
                    deadline = monotonic() + clock.lockstep_timeout
                    while not self.answered():
                        remaining = deadline - monotonic()
                        if remaining <= 0.0:
                            self.on_timeout()
                            break
                        if not self._serve(wait_set, remaining):
                            return
                if not clock.lockstep and not self._serve(
                        wait_set, max(clock.seconds_to_next(), 0.0)):
                    return  # (lockstep served commands and timers while it waited)
                while (remaining := clock.seconds_to_next()) > 0.0:
                    if not self._serve(wait_set, remaining):
                        return
        finally:
            wait_set.destroy_when_not_in_use()

    def _wait_for_controller(self, wait_set: Any) -> bool:
        """The first lockstep tick: wait (without timeout, saying so in ``/diagnostics``)
        for its commands, publishing it again every :data:`READY_POLL_S` s. False once the
        loop is to end."""
        clock = self.clock
        clock.waiting = True
        next_repeat = time.monotonic() + READY_POLL_S
        while not self.answered():
            if not self._serve(wait_set, max(next_repeat - time.monotonic(), 0.0)):
                return False
            if time.monotonic() >= next_repeat:
                next_repeat += READY_POLL_S
                self.repeat()
        clock.waiting = False
        return True

    def _serve(self, wait_set: Any, timeout_s: float) -> bool:
        """Wait at most ``timeout_s`` for a message, timer or guard; hand every queued
        message to its handler and run the due timers. False once the loop is to end."""
        self._fill(wait_set, self.guard_handles(), False)
        wait_set.wait(int(timeout_s * 1e9))
        self.handle_ready(wait_set)
        return self.context.ok() and not self._stopping.is_set()


def step_loop(context: Context, session: DynamicsSession, clock: SimClock,
              served: Sequence[tuple[Subscription, Handler]], timers: Sequence[Timer],
              clock_output: RawOutput | None, lock: threading.Lock,
              outputs: RosOutputs) -> StepLoop:
    """The :class:`StepLoop` of a node: its ticks publish ``/clock`` (raw bytes, when
    ``clock_output`` has subscribers) and tick ``session`` under ``lock``; a lockstep timeout
    is counted and logged through ``outputs``."""
    raw = clock_output
    tick = session.lockstep_tick if clock.lockstep else session.tick

    def publish_clock(now_ns: int) -> None:
        if raw is not None and raw.matched():
            raw.publish(encode_clock(now_ns))

    def sim_tick() -> None:
        with lock:
            now_ns = clock.next_tick()
            publish_clock(now_ns)
            tick(now_ns)

    def repeat() -> None:
        with lock:
            publish_clock(clock.now_ns)
            session.republish()

    def answered() -> bool:
        if session.lockstep_answered():
            clock.answered()
            return True
        return False

    def timed_out() -> None:
        with lock:
            clock.timed_out(outputs)
    outputs.log(LEVEL_INFO, 'lockstep: waiting for a controller to answer the first tick (t=0) '
                            'on the command topics' if clock.lockstep else 'sim clock: ticking')
    return StepLoop(context, served, timers, clock, sim_tick, answered, repeat, timed_out)
