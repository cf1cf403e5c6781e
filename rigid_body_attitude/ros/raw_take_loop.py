"""The raw-take loop: raw subscriptions and a node's timers served on one reused wait set.

rclpy's executors handle one message per wake-up and rebuild their wait set each time (about
100 µs of Python per message with a ``SingleThreadedExecutor`` on this project's machine); at
kHz gyro rates that is the whole budget. A :class:`RawTakeLoop` holds one reused ``rcl`` wait
set with raw subscriptions (the propagation node's gyro topics, the controller's inputs) and
the node's timers; after each wake-up it takes *every* queued message of each subscription and
hands the CDR bytes to its handler, then runs the timers that are due (the dynamics scenes'
ticks among them; :class:`~.step_loop.StepLoop` builds the sim clock's loop on it). The
entities it serves belong to a :class:`DedicatedGroup`: executors run them like any mutually
exclusive group until a loop claims the group; the loop then also serves the
subscriptions' QoS events (rclpy's warning about an incompatible publisher). rclpy's private
wait-set binding is reached through :mod:`rigid_body_attitude.ros.rclpy_internals` only.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import threading
import time
from typing import Any, cast

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.event_handler import EventHandler
from rclpy.exceptions import InvalidHandle
from rclpy.guard_condition import GuardCondition
from rclpy.signals import SignalHandlerGuardCondition
from rclpy.subscription import Subscription
from rclpy.timer import Timer

from rigid_body_attitude.ros.rclpy_internals import (
    entity_handle, new_wait_set, raw_taker, timer_runner)

__all__ = ['DRAINED', 'DedicatedGroup', 'EVENT_CHECK_PERIOD', 'RawTakeLoop', 'Handler',
           'WAIT_TIMEOUT_NS']

#: Nanoseconds one wait may last before the loop re-checks its context (guards wake it first).
WAIT_TIMEOUT_NS = 1_000_000_000

#: Seconds between two looks at the subscriptions' QoS events (a warning about an incompatible
#: publisher comes at most this late).
EVENT_CHECK_PERIOD = 1.0

#: A handler gets one message's serialized (CDR) bytes.
Handler = Callable[[bytes], Any]

#: What a handler returns when it took every message queued behind the one it was given
#: (a command topic's coalescing handler): the loop then asks that subscription for no more.
DRAINED = 'drained'


class DedicatedGroup(MutuallyExclusiveCallbackGroup):
    """A mutually exclusive callback group whose entities a :class:`RawTakeLoop` can claim.

    Until :attr:`claimed` is set, executors run the entities as usual; afterwards they leave
    them out of their wait sets and never begin executing them.
    """

    def __init__(self) -> None:
        """Unclaimed: executors serve the entities."""
        super().__init__()  # type: ignore[no-untyped-call]
        self.claimed = False

    def can_execute(self, entity: Any) -> bool:
        """Executors may wait on ``entity`` only while the group is unclaimed."""
        allowed: bool = super().can_execute(entity)  # type: ignore[no-untyped-call]
        return not self.claimed and allowed

    def beginning_execution(self, entity: Any) -> bool:
        """An executor may run ``entity``'s callback only while the group is unclaimed."""
        if self.claimed:
            return False
        began: bool = super().beginning_execution(entity)  # type: ignore[no-untyped-call]
        return began


def _run_event(handler: EventHandler) -> None:
    """Take a ready QoS event and run its callback (what an executor does with it)."""
    coroutine = handler.execute(handler.take_data())
    try:
        coroutine.send(None)  # a plain callback: done in one step
    except StopIteration:
        pass


class RawTakeLoop:
    """Waits on raw subscriptions and timers; hands every queued message to its handler and
    runs the timers that are due.

    Creating the loop claims the entities' :class:`DedicatedGroup`, so create it before an
    executor that serves the rest of the node starts spinning (an executor that already began
    one of their callbacks would otherwise run it concurrently).
    """

    def __init__(self, context: Context, served: Sequence[tuple[Subscription, Handler]],
                 timers: Sequence[Timer] = ()) -> None:
        """Serve ``served`` (raw subscriptions, handlers) and ``timers`` (their callbacks),
        all in :class:`DedicatedGroup` s."""
        for subscription, _ in served:
            if not subscription.raw:
                raise ValueError(f'Expected raw subscriptions, got {subscription.topic_name!r}')
        for entity in [subscription for subscription, _ in served] + list(timers):
            if not isinstance(entity.callback_group, DedicatedGroup):
                raise ValueError(f'Expected entities in a DedicatedGroup, got {entity!r}')
            entity.callback_group.claimed = True
        # QoS events of the subscriptions (incompatible QoS, incompatible type): rclpy puts
        # them in the subscription's group, so no executor serves them once it is claimed.
        # (A list, although rclpy 7.1.6 annotates it as one EventHandler.)
        self.events = [handler for subscription, _ in served
                       for handler in cast('list[EventHandler]', subscription.event_handlers)]
        self.context = context
        self.served = [(entity_handle(subscription), raw_taker(subscription, True), handler)
                       for subscription, handler in served]
        #: (binding handle, callback) of each timer served.
        self.timers = [(entity_handle(timer), timer.callback) for timer in timers]
        self._run_if_due = [timer_runner(timer) for timer in timers]
        self.handled = 0
        self._stopping = threading.Event()
        self._sigint_guard = SignalHandlerGuardCondition(context)
        self._wake_guard = GuardCondition(
            None, None, context=context)
        self._closed = False
        context.on_shutdown(self.stop)

    def stop(self) -> None:
        """Make :meth:`run` return after the messages of its current wake-up (any thread)."""
        self._stopping.set()
        if not self._closed:
            try:
                self._wake_guard.trigger()
            except InvalidHandle:  # closed meanwhile: run() has returned already
                pass

    def run(self) -> None:
        """Wait and handle messages until :meth:`stop`, SIGINT or context shutdown.

        A handler's exception ends the loop and propagates. The subscriptions' QoS events are
        waited on once every :data:`EVENT_CHECK_PERIOD` seconds only: the middleware keeps an
        event's status until it is taken, and an event in the wait set wakes it up with every
        message of its subscription (a ``SingleThreadedExecutor`` serving them woke for every
        gyro message: 70 % of a core at 1 kHz).
        """
        context, served, timers, events = self.context, self.served, self.timers, self.events
        stopping, monotonic = self._stopping, time.monotonic
        wait_set = new_wait_set(context, len(served), 2, len(timers), len(events))
        guards = self.guard_handles()
        next_event_check = monotonic()
        try:
            while context.ok() and not stopping.is_set():
                with_events = monotonic() >= next_event_check
                self._fill(wait_set, guards, with_events)
                wait_set.wait(WAIT_TIMEOUT_NS)
                self.handle_ready(wait_set)
                if with_events:
                    next_event_check = monotonic() + EVENT_CHECK_PERIOD
                    for event in events:
                        if event.is_ready(wait_set):
                            _run_event(event)
        finally:
            wait_set.destroy_when_not_in_use()

    def handle_ready(self, wait_set: Any) -> None:
        """Hand every queued message of the subscriptions ``wait_set`` found ready to its
        handler (one that returns :data:`DRAINED` took the rest of its queue itself); run
        the timers that are due. A subscription the wait did not find ready is not asked: an
        empty take costs as much as a message's."""
        for index, (_, take, handler) in enumerate(self.served):
            if not wait_set.is_ready('subscription', index):
                continue
            data = take()
            while data is not None:
                self.handled += 1
                if handler(data) is DRAINED:
                    break
                data = take()
        for run_if_due in self._run_if_due:
            run_if_due()

    def guard_handles(self) -> tuple[Any, Any]:
        """The SIGINT and wake-up guards' handles, for a wait set."""
        return entity_handle(self._sigint_guard), entity_handle(self._wake_guard)

    def _fill(self, wait_set: Any, guards: tuple[Any, Any], with_events: bool) -> None:
        """Put the subscriptions, timers, guards (and with ``with_events`` the QoS events)
        into the cleared ``wait_set``."""
        wait_set.clear_entities()
        for handle, _, _ in self.served:
            wait_set.add_subscription(handle)
        for handle, _ in self.timers:
            wait_set.add_timer(handle)
        for guard in guards:
            wait_set.add_guard_condition(guard)
        if with_events:
            for event in self.events:
                event.add_to_wait_set(wait_set)

    def close(self) -> None:
        """Release the guard conditions (after :meth:`run` returned)."""
        if not self._closed:
            self._closed = True
            self._sigint_guard.destroy()
            self._wake_guard.destroy()
