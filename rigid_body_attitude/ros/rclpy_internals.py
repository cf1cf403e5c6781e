"""The one place that reaches into rclpy's private parts, and the way out when they move.

rclpy 7 (Jazzy) exposes no public wait set that can be reused across wake-ups, no public way
to take a queued message or publish CDR bytes without a per-call wrapper, and not its
``RCLError`` type. The node's fast path (:class:`~.raw_take_loop.RawTakeLoop`, the raw outputs, the
command coalescing, the clock read) uses them through the functions here, and only here:

* the C binding ``rclpy.impl.implementation_singleton.rclpy_implementation``: its ``WaitSet``
  and ``RCLError``, and the methods of its ``Subscription``, ``Publisher``, ``Timer`` and
  ``Clock`` objects listed in :data:`BINDING_METHODS`;
* the ``handle`` attribute of rclpy's ``Context``, ``Subscription``, ``Publisher``, ``Timer``,
  ``GuardCondition`` and ``Clock`` (documented as not for use outside rclpy):
  :data:`HANDLE_OWNERS`.

:func:`fast_path_problem` checks every one of them once. When one is missing (an rclpy release
that moved it), or when the environment variable :data:`STOCK_EXECUTOR_VARIABLE` is ``1``, the
node says so in one log line and is served by rclpy's stock ``SingleThreadedExecutor`` with
public calls only (:func:`~.serve.spin`): the same topics and results, at a higher CPU cost
(docs/performance.md). ``test/ros/test_rclpy_internals.py`` lists every name and fails, loudly,
when an rclpy upgrade moves one.
"""

from __future__ import annotations

from collections.abc import Callable
import functools
import os
from typing import Any

from rclpy.clock import Clock
from rclpy.context import Context
from rclpy.guard_condition import GuardCondition
import rclpy.impl.implementation_singleton as _singleton
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription
from rclpy.timer import Timer

__all__ = ['BINDING_METHODS', 'HANDLE_OWNERS', 'RCLError', 'STOCK_EXECUTOR_VARIABLE',
           'WAIT_SET_METHODS', 'clock_nanoseconds', 'entity_handle', 'fast_path_problem',
           'missing_private_names', 'new_wait_set', 'raw_output', 'raw_taker', 'timer_runner']

_binding: Any = _singleton.rclpy_implementation

#: Set to ``1``: serve with rclpy's stock executor even when the fast path is available.
STOCK_EXECUTOR_VARIABLE = 'RIGID_BODY_ATTITUDE_STOCK_EXECUTOR'

#: The methods of the binding's ``WaitSet`` that :class:`~.raw_take_loop.RawTakeLoop` calls, itself
#: or through rclpy's event handlers.
WAIT_SET_METHODS = ('add_event', 'add_guard_condition', 'add_subscription', 'add_timer',
                    'clear_entities', 'destroy_when_not_in_use', 'is_ready', 'wait')

#: Binding attribute → the methods of it that the fast path calls.
BINDING_METHODS: dict[str, tuple[str, ...]] = {
    'WaitSet': WAIT_SET_METHODS,
    'RCLError': (),
    'Subscription': ('take_message',),
    'Publisher': ('publish_raw', 'get_subscription_count'),
    'Timer': ('is_timer_ready', 'call_timer'),
    'Clock': ('get_now',),
}

#: rclpy's public classes whose private ``handle`` the fast path reads.
HANDLE_OWNERS: tuple[type, ...] = (Context, Subscription, Publisher, Timer, GuardCondition,
                                   Clock)


class _NotRaised(Exception):
    """Stands for ``RCLError`` when the binding no longer has it (nothing raises it)."""


#: rcl's error type (raised e.g. when the context shuts down during a take or publish).
RCLError: type[Exception] = getattr(_binding, 'RCLError', _NotRaised)


def missing_private_names(binding: Any = _binding,
                          handle_owners: tuple[type, ...] = HANDLE_OWNERS) -> list[str]:
    """The private names of :data:`BINDING_METHODS` and :data:`HANDLE_OWNERS` that
    ``binding`` and the classes lack (``[]``: the fast path can run)."""
    missing = []
    for name, methods in BINDING_METHODS.items():
        owner = getattr(binding, name, None)
        if owner is None:
            missing.append(name)
            continue
        missing += [f'{name}.{method}' for method in methods if not hasattr(owner, method)]
    missing += [f'{owner.__name__}.handle' for owner in handle_owners
                if not hasattr(owner, 'handle')]
    return missing


@functools.cache
def fast_path_problem() -> str | None:
    """Why the node cannot use its fast path (``None``: it can); decided once per process."""
    if os.environ.get(STOCK_EXECUTOR_VARIABLE, '') == '1':
        return f'{STOCK_EXECUTOR_VARIABLE}=1'
    missing = missing_private_names()
    if missing:
        return f'this rclpy lacks {", ".join(missing)}'
    return None


def new_wait_set(context: Context, subscriptions: int, guard_conditions: int,
                 timers: int, events: int = 0) -> Any:
    """An rcl wait set with room for the given entities (no clients or services)."""
    return _binding.WaitSet(subscriptions, guard_conditions, timers, 0, 0, events,
                            context.handle)


def entity_handle(entity: Subscription | Timer | GuardCondition) -> Any:
    """The binding object of a subscription, timer or guard condition (for a wait set)."""
    return entity.handle


def _fast(fast: bool | None) -> bool:
    """``fast``, or by default whether this process uses the fast path."""
    return fast_path_problem() is None if fast is None else fast


def raw_taker(subscription: Subscription, fast: bool | None = None
              ) -> Callable[[], bytes | None]:
    """A function taking the next queued message of a raw ``subscription`` as CDR bytes
    (``None``: none queued). Without the ``fast`` path it takes nothing: the stock executor
    hands each message to the callback itself."""
    if not _fast(fast):
        return _nothing_taken
    take, msg_type = subscription.handle.take_message, subscription.msg_type

    def take_bytes() -> bytes | None:
        taken = take(msg_type, True)
        return None if taken is None else taken[0]
    return take_bytes


def _nothing_taken() -> None:
    """The stock path's taker: the executor delivers every message."""
    return None


def raw_output(publisher: Publisher, fast: bool | None = None
               ) -> tuple[Callable[[], int], Callable[[bytes], None]]:
    """``(subscription_count, publish)`` of ``publisher``, publish taking CDR bytes: bound to
    the binding's handle (``fast``), else rclpy's public calls."""
    if _fast(fast):
        handle = publisher.handle
        return handle.get_subscription_count, handle.publish_raw
    return publisher.get_subscription_count, publisher.publish


def timer_runner(timer: Timer) -> Callable[[], bool]:
    """A function that runs ``timer``'s callback if it is due and says whether it did."""
    handle, callback = timer.handle, timer.callback

    def run_if_due() -> bool:
        if not handle.is_timer_ready():
            return False
        handle.call_timer()
        callback()
        return True
    return run_if_due


def clock_nanoseconds(clock: Clock, fast: bool | None = None) -> Callable[[], int]:
    """A function reading ``clock`` in nanoseconds: ``clock.now().nanoseconds`` without the
    ``Time`` object on the ``fast`` path. It follows the clock's ROS-time override
    (``use_sim_time``), which lives in the same handle; the clock must outlive the function's
    use."""
    if not _fast(fast):
        return lambda: clock.now().nanoseconds
    get_now = clock.handle.get_now

    def nanoseconds() -> int:
        value: int = get_now().nanoseconds
        return value
    return nanoseconds
