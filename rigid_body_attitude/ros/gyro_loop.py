"""The gyro loop: raw gyro subscriptions and the node's timers served on one reused wait set.

rclpy's executors handle one message per wake-up and rebuild their wait set each time (about
100 µs of Python per message with a ``SingleThreadedExecutor`` on this project's machine); at
kHz gyro rates that is the whole budget. A :class:`GyroLoop` holds one reused ``rcl`` wait set
with the gyro subscriptions and the node's timers; after each wake-up it takes *every* queued
message of each subscription and hands the CDR bytes to its handler, then runs the timers that
are due. The entities it serves belong to a :class:`DedicatedGroup`: executors run them like
any mutually exclusive group until a loop claims the group; the subscriptions' QoS event
handlers stay with the executors. rclpy's private wait-set binding is reached through
:mod:`rigid_body_attitude.ros.rclpy_internals` only.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import threading
from typing import Any, cast

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.event_handler import EventHandler
from rclpy.exceptions import InvalidHandle
from rclpy.guard_condition import GuardCondition
from rclpy.signals import SignalHandlerGuardCondition
from rclpy.subscription import Subscription
from rclpy.timer import Timer

from rigid_body_attitude.ros.rclpy_internals import new_wait_set

__all__ = ['DedicatedGroup', 'GyroLoop', 'Handler', 'WAIT_TIMEOUT_NS']

#: Nanoseconds one wait may last before the loop re-checks its context (guards wake it first).
WAIT_TIMEOUT_NS = 1_000_000_000

#: A handler gets one message's serialized (CDR) bytes.
Handler = Callable[[bytes], Any]


class DedicatedGroup(MutuallyExclusiveCallbackGroup):
    """A mutually exclusive callback group whose entities a :class:`GyroLoop` can claim.

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


def _hand_events_to_executors(subscriptions: Sequence[Subscription]
                              ) -> MutuallyExclusiveCallbackGroup:
    """Move the subscriptions' event handlers (QoS events: incompatible QoS, incompatible
    type) into a group of their own that executors serve, and return it.

    rclpy creates a subscription's event handlers in the subscription's callback group; once
    a loop claims that group no executor would run them, and a publisher offering an
    incompatible QoS on a gyro topic would go unreported, while the node's other
    subscriptions log rclpy's warning about it.
    """
    group = MutuallyExclusiveCallbackGroup()  # type: ignore[no-untyped-call]
    for subscription in subscriptions:
        # A list, although rclpy 7.1.6 annotates it as one EventHandler.
        for handler in cast('list[EventHandler]', subscription.event_handlers):
            handler.callback_group = group
            group.add_entity(handler)
    return group


class GyroLoop:
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
        self.events_group = _hand_events_to_executors([sub for sub, _ in served])
        self.context = context
        self.served = [(subscription.handle, subscription.msg_type, handler)
                       for subscription, handler in served]
        self.timers = [(timer.handle, timer.callback) for timer in timers]
        self.handled = 0
        self._stopping = threading.Event()
        self._sigint_guard = SignalHandlerGuardCondition(context)  # type: ignore[no-untyped-call]
        self._wake_guard = GuardCondition(  # type: ignore[no-untyped-call]
            None, None, context=context)
        self._closed = False
        context.on_shutdown(self.stop)

    def stop(self) -> None:
        """Make :meth:`run` return after the messages of its current wake-up (any thread)."""
        self._stopping.set()
        if not self._closed:
            try:
                self._wake_guard.trigger()  # type: ignore[no-untyped-call]
            except InvalidHandle:  # closed meanwhile: run() has returned already
                pass

    def run(self) -> None:
        """Wait and handle messages until :meth:`stop`, SIGINT or context shutdown.

        A handler's exception ends the loop and propagates.
        """
        context, served, timers = self.context, self.served, self.timers
        stopping = self._stopping
        wait_set = new_wait_set(context, len(served), 2, len(timers))
        sigint_handle, wake_handle = self._sigint_guard.handle, self._wake_guard.handle
        try:
            while context.ok() and not stopping.is_set():
                wait_set.clear_entities()
                for handle, _, _ in served:
                    wait_set.add_subscription(handle)
                for handle, _ in timers:
                    wait_set.add_timer(handle)
                wait_set.add_guard_condition(sigint_handle)
                wait_set.add_guard_condition(wake_handle)
                wait_set.wait(WAIT_TIMEOUT_NS)
                for handle, msg_type, handler in served:
                    taken = handle.take_message(msg_type, True)
                    while taken is not None:
                        handler(taken[0])
                        self.handled += 1
                        taken = handle.take_message(msg_type, True)
                for handle, callback in timers:
                    if handle.is_timer_ready():
                        handle.call_timer()
                        callback()
        finally:
            wait_set.destroy_when_not_in_use()

    def close(self) -> None:
        """Release the guard conditions (after :meth:`run` returned)."""
        if not self._closed:
            self._closed = True
            self._sigint_guard.destroy()  # type: ignore[no-untyped-call]
            self._wake_guard.destroy()  # type: ignore[no-untyped-call]
