"""The one place that reaches into rclpy's private C binding (``rclpy.impl``).

rclpy 7 (Jazzy) exposes no public wait set that can be reused across wake-ups, nor its
``RCLError`` type; both live in ``rclpy.impl.implementation_singleton.rclpy_implementation``.
Its ``Clock.now`` builds a ``Time`` object per call; :func:`clock_nanoseconds` reads the
clock's binding handle (``Clock.handle``, documented as not for use outside rclpy) directly.
``test/ros/test_rclpy_internals.py`` checks every name used here, so an rclpy upgrade that
moves one fails there, loudly, instead of deep inside the node.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.clock import Clock
from rclpy.context import Context
from rclpy.impl.implementation_singleton import rclpy_implementation as _binding

__all__ = ['RCLError', 'USED_NAMES', 'WAIT_SET_METHODS', 'clock_nanoseconds', 'new_wait_set']

#: The binding's attributes this adapter uses (checked by the test).
USED_NAMES = ('WaitSet', 'RCLError')

#: The methods of the binding's ``WaitSet`` that :class:`~.gyro_loop.GyroLoop` calls, itself
#: or through rclpy's event handlers (checked by the test).
WAIT_SET_METHODS = ('add_event', 'add_guard_condition', 'add_subscription', 'add_timer',
                    'clear_entities', 'destroy_when_not_in_use', 'wait')

#: rcl's error type (raised e.g. when the context shuts down during a take or publish).
RCLError: type[Exception] = _binding.RCLError


def new_wait_set(context: Context, subscriptions: int, guard_conditions: int,
                 timers: int, events: int = 0) -> Any:
    """An rcl wait set with room for the given entities (no clients or services)."""
    return _binding.WaitSet(subscriptions, guard_conditions, timers, 0, 0, events,
                            context.handle)


def clock_nanoseconds(clock: Clock) -> Callable[[], int]:
    """A function reading ``clock`` in nanoseconds: ``clock.now().nanoseconds`` without the
    ``Time`` object. It follows the clock's ROS-time override (``use_sim_time``), which lives
    in the same handle; the clock must outlive the function's use."""
    get_now = clock.handle.get_now

    def nanoseconds() -> int:
        value: int = get_now().nanoseconds
        return value
    return nanoseconds
